"""The working resolution: perception and alignment of a large photo at about a megapixel.

What decides a scene (which pixels are which object, the ground, the camera, where each mesh stands) is there
at a megapixel; a 12 MP phone photo holds the same scene in twelve times the pixels, and every stage that
walks its pixels paid twelve times for nothing. So ``build`` reduces a photo above :data:`WORKING_PIXELS`
(``BuildSettings.working_pixels``) once, runs masks, cues, lifting and the placement solve on the reduced copy, and goes
back to the photo's own pixels only for what a viewer sees at full size: the plate, the textures and frame 0
(the photo itself). A photo at or under the working resolution is used as it is, and builds exactly as it
always did.

A mask given as a file at the photo's size is reduced for perception, but its own edge is kept for the texture's
cut-out; a mask cut from a box is cut at the working resolution and its edge smoothed up (:meth:`Working.up_mask`).
"""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np

#: Pixels of the working copy of a larger photo. A megapixel keeps a mask's edge within a pixel or two of the
#: photo's for the objects a build lifts (a 12 MP photo's edge then moves by at most ~3.5 photo pixels at the
#: working pixel's size) and holds every bundled example (the largest 1.4 MP bench photo excepted) as it is.
WORKING_PIXELS = 1_000_000


@dataclasses.dataclass(frozen=True)
class Working:
    """A photo of ``full`` (H, W) worked on at ``work`` (h, w); ``fx``, ``fy``: photo pixels per working pixel."""

    full: tuple[int, int]
    work: tuple[int, int]

    @property
    def fx(self) -> float:
        return self.full[1] / self.work[1]

    @property
    def fy(self) -> float:
        return self.full[0] / self.work[0]

    def down(self, image: np.ndarray) -> np.ndarray:
        """A photo-sized image reduced to the working size (area averaging: no aliasing of fine texture)."""
        return cv2.resize(image, (self.work[1], self.work[0]), interpolation=cv2.INTER_AREA)

    def down_mask(self, mask: np.ndarray) -> np.ndarray:
        """A photo-sized bool mask at the working size: a working pixel belongs where most of its area does."""
        return self.down(np.asarray(mask, np.uint8) * 255) >= 128

    def up_mask(self, mask: np.ndarray) -> np.ndarray:
        """A working-size bool mask at the photo's size, its staircase smoothed by bilinear interpolation."""
        up = self.up(np.asarray(mask, np.uint8) * 255, cv2.INTER_LINEAR)
        return up >= 128

    def up(self, image: np.ndarray, interpolation=cv2.INTER_LINEAR, box=None) -> np.ndarray:
        """A working-size image at the photo's size, or only its part ``box`` (x0, y0, x1, y1, photo pixels).

        Pixel centres are mapped exactly (photo x + 0.5 = (working x + 0.5) × fx), as ``cv2.resize`` maps
        them, so that a part comes out as the same pixels of the whole would."""
        x0, y0, x1, y1 = box if box is not None else (0, 0, self.full[1], self.full[0])
        m = np.float64([[1 / self.fx, 0, (x0 + 0.5) / self.fx - 0.5], [0, 1 / self.fy, (y0 + 0.5) / self.fy - 0.5]])
        return cv2.warpAffine(image, m, (x1 - x0, y1 - y0), flags=interpolation | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_REPLICATE)

    def camera(self, camera):
        """The working camera as the photo's: the same pose and field of view over the photo's pixels."""
        return dataclasses.replace(camera, width=self.full[1], height=self.full[0])

    def box_spec(self, spec: str) -> str:
        """A ``--box`` spec in photo pixels as the same box and clicks in working pixels."""
        from .masks import box_clicks, box_spec, parse_box

        (x0, y0, x1, y1), label = parse_box(spec)
        fx, fy = self.fx, self.fy
        box = (math.floor(x0 / fx), math.floor(y0 / fy), min(self.work[1], math.ceil(x1 / fx)),
               min(self.work[0], math.ceil(y1 / fy)))
        clicks = [(min(self.work[1] - 1, int(x / fx)), min(self.work[0] - 1, int(y / fy)), on)
                  for x, y, on in box_clicks(spec)]
        return box_spec(box, label, clicks)


def working(shape, pixels: int = WORKING_PIXELS) -> Working | None:
    """How a photo of ``shape`` (H, W, ...) is worked on: None when it has at most ``pixels`` pixels (it is
    used as it is), else the size with that many pixels at most and the photo's aspect."""
    h, w = int(shape[0]), int(shape[1])
    if h * w <= pixels:
        return None
    s = math.sqrt(pixels / (h * w))
    return Working((h, w), (max(16, int(h * s)), max(16, int(w * s))))

