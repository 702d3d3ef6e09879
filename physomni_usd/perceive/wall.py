"""The line where a wall behind the objects meets the ground, read from the photo.

Owns :func:`find_wall_line`. A wall behind a scene is a vertical plane; where it meets the ground it draws a
straight line across the photo, with the wall's surface above it and the ground's below. The line is the one
whose bands just above and just below differ most in colour, compared with how much each band varies in itself
(the pixels of the objects' masks take no part: they are neither wall nor ground). Each band is averaged along
the whole line, so a texture's own edges (a chequered floor's tiles, a board's print) cancel out, while the
change from the wall's surface to the ground's does not. What the line says of the scene's geometry (the wall's
plane, an object held against it) is ``align/wall.py``'s; the plate's floor fill stops at it (``texture/floor.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: The photo is read at this many columns (a wall's line needs no fine detail, and the print of a board blurs
#: away).
READ_WIDTH = 160
#: Each band is this fraction of the photo's height.
BAND_FRACTION = 0.08
#: Lines tried: the rows at the photo's left and right edges, every this fraction of its height.
ROW_STEP_FRACTION = 0.02
#: The photo's colours are sorted into this many kinds.
PALETTE = 8
#: A line whose bands share more of their colours than 1 - this is no wall's edge.
MIN_CONTRAST = 0.25
#: ... nor one whose bands this fraction of the photo's width does not show (the rest hidden by objects).
MIN_SEEN_FRACTION = 0.4
#: Within this fraction of the photo's height of an object's foot the line may be a soft shade across the ground
#: rather than the wall's foot: a foot this far above it is held above the ground (align), and a line counts as
#: the floor's end only with a foot this far below it (texture.floor).
ABOVE_FRACTION = 0.05


@dataclass
class WallLine:
    """The wall's line in the photo: row ``left`` at u = 0 and ``right`` at u = width; ``contrast``: its bands'
    colour difference over their spread."""

    left: float
    right: float
    width: int
    contrast: float

    def row(self, u) -> np.ndarray:
        return self.left + (self.right - self.left) * np.asarray(u, float) / self.width


_LAST: dict = {}


def find_wall_line(photo: np.ndarray, masks) -> WallLine | None:
    """The wall's line (see the module) of ``photo`` (H, W, 3) with the objects' ``masks`` left out, or None
    where no line stands out. The last answer is kept: a build asks again for every pitch it weighs."""
    if photo is None or np.ndim(photo) != 3:
        return None
    import hashlib

    key = hashlib.sha1(np.ascontiguousarray(photo).tobytes()
                       + np.packbits(np.stack([np.asarray(m, bool) for m in masks])).tobytes()).hexdigest()
    if key not in _LAST:
        _LAST.clear()
        _LAST[key] = _find(photo, masks)
    return _LAST[key]


def _find(photo: np.ndarray, masks) -> WallLine | None:
    h, w = photo.shape[:2]
    f = min(1.0, READ_WIDTH / w)
    sw, sh = max(8, int(round(w * f))), max(8, int(round(h * f)))
    img = cv2.resize(photo[..., :3].astype(np.uint8), (sw, sh), interpolation=cv2.INTER_AREA)
    lab = cv2.cvtColor(img, cv2.COLOR_RGB2LAB).astype(float)
    taken = np.zeros((h, w), bool)
    for m in masks:
        taken |= np.asarray(m, bool)
    taken = cv2.resize(taken.astype(np.uint8) * 255, (sw, sh), interpolation=cv2.INTER_AREA) > 0
    taken = cv2.dilate(taken.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    valid = ~taken
    # the photo's colours sorted into a few kinds (its palette): a band is read as how much of each kind it holds
    pix = lab.reshape(-1, 3).astype(np.float32)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.5)
    cv2.setRNGSeed(0)
    _, kind, _ = cv2.kmeans(pix, PALETTE, None, crit, 2, cv2.KMEANS_PP_CENTERS)
    onehot = (kind.reshape(sh, sw)[..., None] == np.arange(PALETTE)) & valid[..., None]
    cn = np.vstack([np.zeros((1, sw)), np.cumsum(valid, 0)])
    ck = np.concatenate([np.zeros((1, sw, PALETTE)), np.cumsum(onehot, 0)])
    band = max(2, int(round(BAND_FRACTION * sh)))
    step = max(1, int(round(ROW_STEP_FRACTION * sh)))
    ends = np.arange(band, sh - band + 1, step)
    left, right = np.meshgrid(ends, ends, indexing="ij")
    left, right = left.ravel(), right.ravel()
    cols = np.arange(sw)
    rows = np.rint(left[:, None] + (right - left)[:, None] * (cols[None] + 0.5) / sw).astype(int)
    rows = np.clip(rows, band, sh - band)

    def share(a, b):  # over every line: the share of each colour kind among the seen pixels of rows [a, b)
        k = (ck[b, cols] - ck[a, cols]).sum(1)
        return k / np.maximum(k.sum(1, keepdims=True), 1)

    above, below = share(rows - band, rows), share(rows, rows + band)
    seen_cols = np.minimum(cn[rows, cols] - cn[rows - band, cols], cn[rows + band, cols] - cn[rows, cols])
    seen = (seen_cols >= 0.5 * band).mean(1)
    # 1 - the Bhattacharyya coefficient: 0 for the same mix of colours, 1 for none in common
    contrast = 1.0 - np.sqrt(above * below).sum(1)
    contrast[seen < MIN_SEEN_FRACTION] = 0.0
    best = int(np.argmax(contrast))
    if contrast[best] < MIN_CONTRAST:
        return None
    return WallLine(float(left[best]) / f, float(right[best]) / f, w, float(contrast[best]))


def foot_above(line: WallLine, u: float, v: float, height: int) -> bool:
    """Whether a foot at pixel (u, v) is above ``line`` by more than :data:`ABOVE_FRACTION` of the photo."""
    return float(v) < float(line.row(u)) - ABOVE_FRACTION * height
