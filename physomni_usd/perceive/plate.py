"""The background plate (the photo with the objects removed) and per-object textures."""

from __future__ import annotations

import cv2
import numpy as np

#: Inpainting radius of OpenCV's Telea method, pixels.
INPAINT_RADIUS = 5
#: Longest side at which large holes are inpainted; the fill is then upsampled.
INPAINT_MAX_SIDE = 480


def background_plate(photo: np.ndarray, masks, dilation: float) -> np.ndarray:
    """The photo with every object inpainted away (OpenCV Telea), (H, W, 3) uint8.

    ``dilation`` widens the union of the masks by that fraction of the image
    diagonal, so that soft edges and contact shadows go too. Large photos are
    inpainted at a reduced size and only the hole is taken from the upsampled
    result: the rest of the plate stays the photo, pixel for pixel.
    """
    h, w = photo.shape[:2]
    hole = np.zeros((h, w), np.uint8)
    for m in masks:
        hole |= m.astype(np.uint8)
    r = int(round(dilation * np.hypot(h, w)))
    if r > 0:
        hole = cv2.dilate(hole, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    bgr = cv2.cvtColor(photo, cv2.COLOR_RGB2BGR)
    scale = min(1.0, INPAINT_MAX_SIDE / max(h, w))
    if scale < 1.0:
        small = cv2.resize(bgr, (max(1, round(w * scale)), max(1, round(h * scale))), interpolation=cv2.INTER_AREA)
        small_hole = cv2.resize(hole, small.shape[1::-1], interpolation=cv2.INTER_NEAREST)
        small_hole = cv2.dilate(small_hole, np.ones((3, 3), np.uint8))
        filled = cv2.resize(cv2.inpaint(small, small_hole, INPAINT_RADIUS, cv2.INPAINT_TELEA), (w, h),
                            interpolation=cv2.INTER_CUBIC)
    else:
        filled = cv2.inpaint(bgr, hole, INPAINT_RADIUS, cv2.INPAINT_TELEA)
    out = np.where(hole[..., None] > 0, filled, bgr)
    return cv2.cvtColor(out, cv2.COLOR_BGR2RGB)


def object_texture(photo: np.ndarray, mask: np.ndarray, pad: int = 8) -> tuple[np.ndarray, tuple[int, int]]:
    """RGBA crop of one object, (h, w, 4) uint8, and its (x0, y0) offset in the photo.

    Alpha is the mask, so renderers cut the object out exactly; colours are
    pushed outward past the mask's edge so that filtered lookups at the border
    never pick up the background.
    """
    ys, xs = np.nonzero(mask)
    H, W = mask.shape
    x0, x1 = max(0, xs.min() - pad), min(W, xs.max() + 1 + pad)
    y0, y1 = max(0, ys.min() - pad), min(H, ys.max() + 1 + pad)
    rgb = photo[y0:y1, x0:x1].copy()
    m = mask[y0:y1, x0:x1].astype(np.uint8)
    rgb = extend_colours(rgb, m, pad)
    alpha = (m * 255).astype(np.uint8)
    return np.dstack([rgb, alpha]), (int(x0), int(y0))


def extend_colours(rgb: np.ndarray, mask: np.ndarray, steps: int) -> np.ndarray:
    """Grow the colours inside ``mask`` outward by ``steps`` pixels (mean of known neighbours)."""
    known = mask.astype(bool).copy()
    out = rgb.astype(np.float32)
    kernel = np.ones((3, 3), np.float32)
    for _ in range(steps):
        if known.all():
            break
        w = cv2.filter2D(known.astype(np.float32), -1, kernel, borderType=cv2.BORDER_CONSTANT)
        s = cv2.filter2D(out * known[..., None], -1, kernel, borderType=cv2.BORDER_CONSTANT)
        grow = (~known) & (w > 0)
        out[grow] = s[grow] / w[grow][:, None]
        known |= grow
    return np.clip(out + 0.5, 0, 255).astype(np.uint8)
