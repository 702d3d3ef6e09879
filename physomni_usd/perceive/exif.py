"""The photo's field of view from what its camera wrote in EXIF: the 35 mm-equivalent focal length, else the
focal length over the sensor size its focal-plane resolution gives.

Phone and DSLR photos carry these; where nothing in the picture reads the field of view the build would
otherwise take a default one, and a wrong view misplaces objects along the camera's rays (bench general:
positions within 5 % of the camera distance went 25 % → 60 % under the true view). Pillow parses the tags.
"""

from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass

#: Half the diagonal of the 35 mm frame (36 × 24 mm), mm: FocalLengthIn35mmFilm is defined by the diagonal
#: angle of view, not by either side.
FULL_FRAME_HALF_DIAGONAL_MM = 0.5 * math.hypot(36.0, 24.0)

#: EXIF tags (Exif IFD) read here.
EXIF_IFD = 0x8769
FOCAL_LENGTH = 0x920A
FOCAL_LENGTH_35MM = 0xA405
FOCAL_PLANE_X_RESOLUTION = 0xA20E
FOCAL_PLANE_RESOLUTION_UNIT = 0xA210
PIXEL_X_DIMENSION = 0xA002
#: FocalPlaneResolutionUnit → millimetres per unit (2: inch, 3: cm, 4: mm, 5: µm); 1 ("none") tells no size.
_UNIT_MM = {2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}


@dataclass(frozen=True)
class ExifView:
    """What the photo's EXIF says of its vertical field of view: ``fov_deg`` and the ``source`` that read it
    (for the report), or None and a ``warning`` where a tag was there but unusable (absurd, zero)."""

    fov_deg: float | None
    source: str | None = None
    warning: str | None = None


def _number(value) -> float | None:
    try:
        x = float(value)
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return x if math.isfinite(x) and x > 0 else None


def vertical_from_diagonal(diagonal_deg: float, width: int, height: int) -> float:
    """The vertical field of view of a ``width`` × ``height`` image whose diagonal spans ``diagonal_deg``
    (a pinhole: the half-extents' tangents scale with the sides)."""
    return math.degrees(2 * math.atan(math.tan(math.radians(diagonal_deg) / 2) * height / math.hypot(width, height)))


def exif_view(path: str | pathlib.Path, width: int, height: int, limits: tuple[float, float]) -> ExifView | None:
    """The vertical field of view of the photo at ``path`` (``width`` × ``height`` as stored) from its EXIF,
    or None where it carries no focal length. A value outside ``limits`` (degrees, exclusive: the --fov
    range) is refused with a warning.

    The build works on the pixels as stored (EXIF Orientation is not applied), and a camera stores its
    sensor's rows: the stored height is the sensor's side the view is read along, whatever the Orientation."""
    from PIL import Image

    try:
        with Image.open(path) as im:
            exif = im.getexif()
            tags = exif.get_ifd(EXIF_IFD)
    except Exception:  # not an image Pillow reads, or a damaged EXIF block: no view from it
        return None
    if not tags:
        return None
    f35, f = tags.get(FOCAL_LENGTH_35MM), tags.get(FOCAL_LENGTH)
    if f35 is not None:
        mm = _number(f35)
        if mm is None:
            return _refused(f"35 mm-equivalent focal length {f35!r}")
        diagonal = math.degrees(2 * math.atan(FULL_FRAME_HALF_DIAGONAL_MM / mm))
        return _checked(vertical_from_diagonal(diagonal, width, height),
                        f"35 mm-equivalent focal length {mm:g} mm", limits)
    if f is None:
        return None
    mm = _number(f)
    per_unit = _UNIT_MM.get(int(_number(tags.get(FOCAL_PLANE_RESOLUTION_UNIT)) or 2))
    pixels_per_unit = _number(tags.get(FOCAL_PLANE_X_RESOLUTION))
    if mm is None:
        return _refused(f"focal length {f!r}")
    if pixels_per_unit is None or per_unit is None:
        return None  # a focal length without the sensor's size says nothing of the view
    # the resolution is of the image the camera wrote (PixelXDimension wide): a copy scaled down since keeps
    # its EXIF, and its sensor is as wide
    sensor_mm = (_number(tags.get(PIXEL_X_DIMENSION)) or width) * per_unit / pixels_per_unit
    fov = math.degrees(2 * math.atan(0.5 * sensor_mm * height / width / mm))
    return _checked(fov, f"focal length {mm:g} mm on a {sensor_mm:.1f} mm wide sensor", limits)


def _checked(fov: float, source: str, limits: tuple[float, float]) -> ExifView:
    if not (math.isfinite(fov) and limits[0] < fov < limits[1]):
        return _refused(f"{source} (a {fov:.1f}° vertical field of view, outside {limits[0]:g}-{limits[1]:g}°)")
    return ExifView(fov, "EXIF " + source)


def _refused(what: str) -> ExifView:
    return ExifView(None, warning=f"the photo's EXIF {what} is ignored; the field of view is read from the photo")
