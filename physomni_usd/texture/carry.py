"""The plate of a photo above :data:`FILL_PIXELS`: filled on a reduced copy and carried to the photo's size, its
detail taken from where the exemplar copied each patch (:func:`carry_plate`)."""

from __future__ import annotations

import cv2
import numpy as np

from .fill import feather_px

#: Pixels of the copy a larger photo's plate is filled on (by the built-in inpainter; never finer than the working
#: copy). The fill lays and weighs its copies over every pixel of its window, once per copy, so its cost follows
#: the window's pixels (what it saved, and its error against the truth: docs/reference.md, "A large photo: the
#: working resolution"). The fill's shading is smooth and faded with the depth into the hole, and the carry
#: brings the copied pixels' own detail back at the photo's size, so the filled surface keeps its grain.
FILL_PIXELS = 400_000
#: Rows of the photo :func:`carry_plate` works on at once: its float copies are of a strip, not of the photo.
CARRY_ROWS = 256


def carry_plate(photo: np.ndarray, work, small_photo: np.ndarray, small_plate: np.ndarray,
                sources: np.ndarray | None = None, weight: np.ndarray | None = None) -> np.ndarray:
    """The plate at the photo's size, (H, W, 3) uint8, from the plate filled on a reduced copy (at
    :data:`FILL_PIXELS`, or the working size where that is smaller).

    ``work`` is the :class:`~physomni_usd.perceive.working.Working` that took ``photo`` to ``small_photo``;
    ``small_plate`` is the plate of ``small_photo`` (the photo wherever it is not filled); ``sources`` what its
    exemplar fill copied from (:func:`~.fill.background_plate`). Outside the working hole the plate is the photo,
    pixel for pixel. Inside, the fill's low frequencies (its shading, matched to the border at the working
    resolution) come from the small plate, upsampled, and the detail finer than a working pixel from the photo's
    own pixels: from where the exemplar copied each patch (the offset scaled up), blended across the seam
    (:data:`~.fill.FEATHER`) into the
    photo's own detail where the working fill blends into the photo. So the fill keeps the surface's grain at
    full size for the cost of a few passes over the hole, not a search at full size. ``weight``: each working
    pixel's share of the fill, as the built-in plate gives it (``background_plate``); without it, read from the
    distance to the pixels the small plate left as they were, which is the seam's own blend only where nothing
    inside the hole was left as the photo: beside the photo the plate takes back around an object's edge, it
    brought the photo's own detail (the edge) back where the fill was kept.
    """
    changed = np.any(small_plate != small_photo, axis=2)
    if weight is not None:
        changed &= weight > 0
    out = photo.copy()
    if not changed.any():
        return out
    H, W = photo.shape[:2]
    fx, fy = work.fx, work.fy
    if weight is not None:
        blend = np.clip(weight, 0.0, 1.0).astype(np.float32)
    else:  # how far each working pixel of the hole is the fill rather than the photo: the seam's own blend
        feather = feather_px(small_photo.shape)
        blend = np.clip(cv2.distanceTransform(changed.astype(np.uint8), cv2.DIST_L2, 5) / (feather + 1.0), 0.0, 1.0)
    ys, xs = np.nonzero(changed)
    x0, x1 = max(0, int((xs.min() - 1) * fx)), min(W, int(np.ceil((xs.max() + 2) * fx)))
    y0, y1 = max(0, int((ys.min() - 1) * fy)), min(H, int(np.ceil((ys.max() + 2) * fy)))
    small_f = small_photo.astype(np.float32)
    for top in range(y0, y1, CARRY_ROWS):
        box = (x0, top, x1, min(y1, top + CARRY_ROWS))
        hole = work.up(changed.astype(np.uint8) * 255, cv2.INTER_LINEAR, box) > 0
        if not hole.any():
            continue
        rows = slice(box[1], box[3])
        hy, hx = np.nonzero(hole)
        own = photo[rows, x0:x1][hy, hx].astype(np.float32)
        detail = own - work.up(small_f, cv2.INTER_LINEAR, box)[hy, hx]
        a = work.up(blend.astype(np.float32), cv2.INTER_LINEAR, box)[hy, hx][:, None]
        value = work.up(small_plate.astype(np.float32), cv2.INTER_LINEAR, box)[hy, hx] + (1.0 - a) * detail
        if sources is not None:
            value += a * _copied_detail(photo, work, small_f, sources, hy + box[1], hx + x0)
        out[rows, x0:x1][hy, hx] = np.clip(value + 0.5, 0, 255).astype(np.uint8)
    return out


def _copied_detail(photo: np.ndarray, work, small_f: np.ndarray, sources: np.ndarray, yy: np.ndarray,
                   xx: np.ndarray) -> np.ndarray:
    """(N, 3) float32 for the photo's pixels (``yy``, ``xx``): the detail (the photo less its working-resolution
    low-pass) of the pixel each one's working pixel was copied from, offset scaled to the photo's pixels; 0
    where none was."""
    H, W = photo.shape[:2]
    sh, sw = sources.shape[:2]
    wy = np.clip(((yy + 0.5) / work.fy).astype(np.int64), 0, sh - 1)
    wx = np.clip(((xx + 0.5) / work.fx).astype(np.int64), 0, sw - 1)
    src = sources[wy, wx]
    found = src[:, 0] >= 0
    qy = np.clip(yy + np.round((src[:, 0] - wy) * work.fy).astype(np.int64), 0, H - 1)
    qx = np.clip(xx + np.round((src[:, 1] - wx) * work.fx).astype(np.int64), 0, W - 1)
    # the low-pass at the source pixel: the working photo sampled there, as Working.up maps pixel centres
    low = _bilinear(small_f, (qx + 0.5) / work.fx - 0.5, (qy + 0.5) / work.fy - 0.5)
    detail = photo[qy, qx].astype(np.float32) - low
    detail[~found] = 0.0
    return detail


def _bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, C) float32: ``img`` (h, w, C) sampled bilinearly at (``x``, ``y``), clamped at its border (as
    cv2.remap with BORDER_REPLICATE, which takes at most 32767 points a row)."""
    h, w = img.shape[:2]
    x = np.clip(x, 0.0, w - 1.0)
    y = np.clip(y, 0.0, h - 1.0)
    x0 = np.minimum(x.astype(np.int64), w - 2) if w > 1 else np.zeros(len(x), np.int64)
    y0 = np.minimum(y.astype(np.int64), h - 2) if h > 1 else np.zeros(len(y), np.int64)
    ax = (x - x0).astype(np.float32)[:, None]
    ay = (y - y0).astype(np.float32)[:, None]
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    top = img[y0, x0] * (1 - ax) + img[y0, x1] * ax
    return top * (1 - ay) + (img[y1, x0] * (1 - ax) + img[y1, x1] * ax) * ay
