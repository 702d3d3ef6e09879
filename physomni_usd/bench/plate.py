"""``bench plate``: the background plate's fill on real photos of empty surfaces, where the photo is the truth.

Surfaces are real photos shipped with scikit-image (``skimage.data``: brick,
grass, gravel, and the wooden table and the garage floor beside the coffee cup
and the motorcycle). Object-shaped holes (a cup, a saucer seen from above, a
pencil lying diagonally, a bottle, a chair) are cut in each, the hole is filled
exactly as ``build`` fills it (:func:`~physomni_usd.texture.fill.plate_hole` and
``fill_hole``, default dilation, with and without the shift-map exemplar fill; not
the plate's photo put back beyond the masks' edge, which here would be the truth), and the fill
is compared with the photo inside the hole:

- gradient ratio: mean gradient magnitude inside the hole over that in a ring
  around it (1 keeps the surface's grain; a smear is far below 1);
- colour difference: mean absolute difference from the photo of the local colour (both averaged with a
  Gaussian of σ = 8 px), 0–255 levels, and the plain per-pixel difference beside it;
- SSIM inside the hole (Gaussian window σ = 1.5);
- seconds of the fill.
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from ..metrics.image import ssim
from ..texture.fill import feather_px, fill_hole, plate_hole
from ..settings import BuildSettings

#: Ring around a hole in which the surface's own gradient is measured, pixels.
RING = 10
#: Width of the Gaussian over which colours are compared, pixels: a surface's grain cannot be predicted
#: pixel by pixel (no fill can), its local colour and shading can.
COLOUR_SIGMA = 8.0
#: Acceptance band of the gradient ratio, and the colour difference allowed (levels).
RATIO_RANGE = (0.6, 1.6)
MAX_COLOUR_DIFF = 15.0


def surfaces() -> dict[str, np.ndarray]:
    """Name → (H, W, 3) uint8 RGB photo of an empty surface, from scikit-image's bundled data."""
    from skimage import data

    grey = lambda a: np.ascontiguousarray(np.repeat(a[..., None], 3, 2))  # noqa: E731
    return {
        "brick": grey(data.brick()),
        "grass": grey(data.grass()),
        "gravel": grey(data.gravel()),
        "table": np.ascontiguousarray(data.coffee()[:, 485:]),  # the wooden table right of the saucer
        "floor": np.ascontiguousarray(data.stereo_motorcycle()[0][320:, :120]),  # garage floor left of the bike
    }


def hole_shapes(h: int, w: int) -> dict[str, np.ndarray]:
    """Name → (h, w) bool: object-shaped holes centred in an ``h`` × ``w`` photo, about 40 % of its short side."""
    s = 0.4 * min(h, w)
    cx, cy = w // 2, h // 2
    out = {}
    m = np.zeros((h, w), np.uint8)
    cv2.rectangle(m, (int(cx - 0.3 * s), int(cy - 0.4 * s)), (int(cx + 0.3 * s), int(cy + 0.35 * s)), 1, -1)
    cv2.ellipse(m, (cx, int(cy + 0.35 * s)), (int(0.3 * s), int(0.1 * s)), 0, 0, 360, 1, -1)
    cv2.ellipse(m, (int(cx + 0.3 * s), cy), (int(0.15 * s), int(0.2 * s)), 0, -90, 90, 1, int(max(2, 0.06 * s)))
    out["cup"] = m > 0
    m = np.zeros((h, w), np.uint8)
    cv2.ellipse(m, (cx, cy), (int(0.5 * s), int(0.33 * s)), 0, 0, 360, 1, -1)
    out["saucer"] = m > 0
    m = np.zeros((h, w), np.uint8)
    d = 0.5 * s * np.array([np.cos(0.6), np.sin(0.6)])
    cv2.line(m, (int(cx - d[0]), int(cy - d[1])), (int(cx + d[0]), int(cy + d[1])), 1, max(3, int(0.06 * s)))
    out["pencil"] = m > 0
    m = np.zeros((h, w), np.uint8)
    cv2.rectangle(m, (int(cx - 0.15 * s), int(cy - 0.1 * s)), (int(cx + 0.15 * s), int(cy + 0.5 * s)), 1, -1)
    cv2.rectangle(m, (int(cx - 0.06 * s), int(cy - 0.5 * s)), (int(cx + 0.06 * s), int(cy - 0.1 * s)), 1, -1)
    out["bottle"] = m > 0
    m = np.zeros((h, w), np.uint8)
    t = max(2, int(0.05 * s))
    cv2.rectangle(m, (int(cx - 0.3 * s), int(cy - 0.5 * s)), (int(cx - 0.3 * s) + t, int(cy + 0.5 * s)), 1, -1)
    cv2.rectangle(m, (int(cx + 0.3 * s) - t, int(cy)), (int(cx + 0.3 * s), int(cy + 0.5 * s)), 1, -1)
    cv2.rectangle(m, (int(cx - 0.3 * s), int(cy)), (int(cx + 0.3 * s), int(cy) + t), 1, -1)
    cv2.rectangle(m, (int(cx - 0.3 * s), int(cy - 0.5 * s)), (int(cx - 0.1 * s), int(cy - 0.1 * s)), 1, -1)
    out["chair"] = m > 0
    return out


def gradient_ratio(image: np.ndarray, hole: np.ndarray, ring: int = RING) -> float:
    """Mean Sobel gradient magnitude of ``image``'s lightness inside ``hole`` over that in a ring around it."""
    g = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32)
    mag = np.hypot(cv2.Sobel(g, cv2.CV_32F, 1, 0), cv2.Sobel(g, cv2.CV_32F, 0, 1))
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * ring + 1, 2 * ring + 1))
    around = (cv2.dilate(hole.astype(np.uint8), k) > 0) & ~hole
    inside = cv2.erode(hole.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # the Sobel support stays inside
    return float(mag[inside].mean() / max(mag[around].mean(), 1e-6))


def measure(photo: np.ndarray, mask: np.ndarray, method: str, dilation: float) -> dict:
    """Fill one hole as ``build`` would and compare the fill with the photo."""
    hole = plate_hole(photo, [mask], dilation)
    t0 = time.perf_counter()
    # the fill of the whole hole, without the plate's photo put back where it looks like the surface around
    # (texture.fill._world_back): here the photo under the hole is the truth, and that would show it
    plate = fill_hole(photo, hole, method, feather_px(photo.shape))
    seconds = time.perf_counter() - t0
    a, b = plate.astype(np.float32), photo.astype(np.float32)
    pixel = np.abs(a - b)[hole].mean()
    blur = lambda x: cv2.GaussianBlur(x, (0, 0), COLOUR_SIGMA)  # noqa: E731
    colour = np.abs(blur(a) - blur(b))[hole].mean()
    return {"gradient_ratio": round(gradient_ratio(plate, hole), 3), "colour_diff": round(float(colour), 2),
            "pixel_diff": round(float(pixel), 2),
            "ssim": round(ssim(plate, photo, hole), 4), "seconds": round(seconds, 3),
            "hole_pixels": int(hole.sum())}


def bench_plate(quick: bool = False, echo=print) -> dict:
    """Every surface × hole, exemplar and Telea side by side; rows and whether the acceptance holds. Refused
    (InputError) where scikit-image, whose photos the surfaces are, is not installed."""
    try:
        import skimage  # noqa: F401
    except ImportError:
        from ..errors import InputError

        raise InputError("bench plate: scikit-image is not installed (pip install 'physomni-usd[test]')") from None
    dilation = BuildSettings().plate_dilation
    rows = []
    echo(f"{'surface':<8}{'hole':<8}{'pixels':>8} | {'exemplar: ratio':>15}{'colour':>8}{'ssim':>7}{'s':>7} | "
         f"{'telea: ratio':>12}{'colour':>8}{'ssim':>7}{'s':>7}")
    for sname, photo in surfaces().items():
        holes = hole_shapes(*photo.shape[:2])
        if quick:
            holes = {k: holes[k] for k in ("saucer", "pencil")}
        for hname, mask in holes.items():
            ex = measure(photo, mask, "exemplar", dilation)
            te = measure(photo, mask, "telea", dilation)
            rows.append({"surface": sname, "hole": hname, "size": list(photo.shape[1::-1]),
                         "exemplar": ex, "telea": te})
            echo(f"{sname:<8}{hname:<8}{ex['hole_pixels']:>8} | {ex['gradient_ratio']:>15.2f}{ex['colour_diff']:>8.1f}"
                 f"{ex['ssim']:>7.3f}{ex['seconds']:>7.2f} | {te['gradient_ratio']:>12.2f}{te['colour_diff']:>8.1f}"
                 f"{te['ssim']:>7.3f}{te['seconds']:>7.2f}")
    judged = [r for r in rows if r["telea"]["gradient_ratio"] < 0.5]
    ratio_ok = all(RATIO_RANGE[0] <= r["exemplar"]["gradient_ratio"] <= RATIO_RANGE[1] for r in judged)
    colour_ok = all(r["exemplar"]["colour_diff"] <= MAX_COLOUR_DIFF for r in rows)
    mean = lambda m, k: float(np.mean([r[m][k] for r in rows]))  # noqa: E731
    echo(f"mean     exemplar: ratio {mean('exemplar', 'gradient_ratio'):.2f}, colour {mean('exemplar', 'colour_diff'):.1f},"
         f" ssim {mean('exemplar', 'ssim'):.3f}, {mean('exemplar', 'seconds'):.2f} s;  telea: ratio "
         f"{mean('telea', 'gradient_ratio'):.2f}, colour {mean('telea', 'colour_diff'):.1f}, ssim "
         f"{mean('telea', 'ssim'):.3f}, {mean('telea', 'seconds'):.2f} s")
    echo(f"gradient ratio in {RATIO_RANGE[0]}–{RATIO_RANGE[1]} on the {len(judged)} holes where Telea is below 0.5: "
         f"{'yes' if ratio_ok else 'no'}; colour difference ≤ {MAX_COLOUR_DIFF:g} on all {len(rows)}: "
         f"{'yes' if colour_ok else 'no'}")
    return {"rows": rows, "dilation": dilation, "ratio_range": list(RATIO_RANGE),
            "max_colour_diff": MAX_COLOUR_DIFF, "ratio_ok": ratio_ok, "colour_ok": colour_ok}
