"""The blend fill: the exemplar's copies of the surface, blended where they meet and held to the surroundings.

The exemplar fill (``exemplar.py``) lays patches copied from around the hole side by side: where two
patches meet the seam is a hard line, a patch that shift-map could not place stays unfilled (its
reduced pixels are zero in CIELAB, a pure blue), and a patch of something that is not the surface (a
bottle on a shelf beside the hole) is copied whole. The blend fill keeps the same shifts but lays them
softly and only where they look like the surface:

- every shift read back is laid over the pixels that chose it and, fading with a Gaussian
  (:data:`SEAM_SIGMA`), over their neighbours: where patches meet, both are averaged, so a seam is a
  gradual change, not a line;
- each copy is weighed by how close its local colour comes to a smooth fill of the surroundings
  (:func:`smooth_fill`; :data:`LIKENESS`): a copy of another thing, unlike the surface where it is laid,
  fades out, and the smooth fill takes what no likely copy covers (the unfilled pixels too);
- after the shading and grain matching of the exemplar fill, no pixel is left farther than
  :data:`COLOUR_CAP` from every colour of its surroundings (:func:`cap_colours`).
"""

from __future__ import annotations

import cv2
import numpy as np

from .exemplar import EXEMPLAR_CONTEXT, EXEMPLAR_HOLE_PIXELS, NO_SHIFT, SHADING_DEPTH, SHADING_SIGMA, \
    SHADING_TRUST, match_shading, shift_map
from .grain import match_grain, odd_border
from .pixels import blur

#: Width over which copies that meet are averaged, as a fraction of the hole's narrower side (at least 1.5 px).
SEAM_SIGMA = 0.03
#: Low-pass (Gaussian sigma, pixels) of the copies' and the smooth fill's colours when they are compared, and
#: the colour difference (RGB distance, levels) at which a copy's weight has fallen to 1/e.
LIKENESS_SIGMA = 3.0
LIKENESS = 30.0
#: Weight of the smooth fill beside the copies: it shows only where no likely copy reaches.
SMOOTH_WEIGHT = 0.02
#: Most distance (RGB, levels) a filled pixel may lie from every colour of its surroundings (the known pixels
#: within :data:`SURROUND` of the diagonal of its part of the hole); a pixel farther is moved towards the
#: nearest of them until it is this far.
COLOUR_CAP = 55.0
SURROUND = 0.05


def fill_blend(photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``photo`` (H, W, 3) uint8 RGB with ``hole`` (H, W) bool filled as the module says, one window per
    connected part of the hole (as :func:`~.exemplar.fill_exemplar` makes them)."""
    h, w = hole.shape
    out = photo.copy()
    n, labels, stats, _ = cv2.connectedComponentsWithStats(hole.astype(np.uint8), connectivity=8)
    total = max(1, int(hole.sum()))
    for k in range(1, n):
        x, y, bw, bh = stats[k, :4]
        m = int(round(EXEMPLAR_CONTEXT * max(bw, bh))) + 8
        x0, y0, x1, y1 = max(0, x - m), max(0, y - m), min(w, x + bw + m), min(h, y + bh + m)
        win_hole = hole[y0:y1, x0:x1]
        if win_hole.all():
            win_hole = hole
            x0, y0, x1, y1 = 0, 0, w, h
        filled = _blend_window(photo[y0:y1, x0:x1], win_hole, min(bw, bh), SHADING_DEPTH * np.hypot(h, w),
                               EXEMPLAR_HOLE_PIXELS * float(stats[k, 4]) / total)
        own = labels[y0:y1, x0:x1] == k
        out[y0:y1, x0:x1][own] = filled[own]
    return cap_colours(photo, out, hole)


def _blend_window(img: np.ndarray, hole: np.ndarray, size: int, depth: float, budget: float) -> np.ndarray:
    """The blend fill of ``hole`` in the window ``img`` (h, w, 3) RGB; ``size``, ``depth`` and ``budget`` as the
    exemplar's window takes them."""
    _, offsets = shift_map(img, hole, budget)
    src = img.astype(np.float32)
    known = ~hole
    smooth = smooth_fill(src, known & ~odd_border(cv2.cvtColor(img, cv2.COLOR_RGB2BGR), hole))
    smooth_low = cv2.GaussianBlur(smooth, (0, 0), LIKENESS_SIGMA)
    sigma = max(1.5, SEAM_SIGMA * size)
    ys, xs = np.nonzero(hole)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    box = (slice(y0, y1), slice(x0, x1))
    acc = smooth[box] * SMOOTH_WEIGHT
    weight = np.full((y1 - y0, x1 - x0), SMOOTH_WEIGHT, np.float32)
    d = offsets[ys, xs]
    found = d[:, 0] != NO_SHIFT
    h, w = hole.shape
    for dy, dx in np.unique(d[found], axis=0):
        chose = np.zeros((h, w), np.float32)
        pick = found & (d[:, 0] == dy) & (d[:, 1] == dx)
        chose[ys[pick], xs[pick]] = 1.0
        # the copy laid over the whole window: each pixel takes the pixel (dy, dx) from it, where that is known
        shift = np.float32([[1, 0, dx], [0, 1, dy]])
        copy = cv2.warpAffine(src, shift, (w, h), flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
        valid = cv2.warpAffine(known.astype(np.uint8), shift, (w, h), flags=cv2.INTER_NEAREST,
                               borderMode=cv2.BORDER_CONSTANT) > 0
        spread = blur(chose, sigma) * valid
        if not spread[box].any():
            continue
        low = cv2.GaussianBlur(copy * valid[..., None], (0, 0), LIKENESS_SIGMA)
        low /= np.maximum(cv2.GaussianBlur(valid.astype(np.float32), (0, 0), LIKENESS_SIGMA), 1e-3)[..., None]
        unlike = np.linalg.norm(low[box] - smooth_low[box], axis=-1) / LIKENESS
        wk = spread[box] * np.exp(-unlike ** 2)
        acc += copy[box] * wk[..., None]
        weight += wk
    out = img.copy()
    laid = acc / weight[..., None]
    out[box] = np.where(hole[box][..., None], np.clip(laid + 0.5, 0, 255), img[box]).astype(np.uint8)
    out = match_shading(img, out, hole, max(3.0, SHADING_SIGMA * size), depth, SHADING_TRUST)
    return match_grain(img, out, hole)


def smooth_fill(img: np.ndarray, known: np.ndarray) -> np.ndarray:
    """(h, w, 3) float32: ``img`` (h, w, 3) float32 where ``known`` (h, w) bool, and elsewhere a smooth
    interpolation of the known pixels (push-pull: averages over the known pixels at halving sizes, each size's
    gaps filled from the next coarser one, blended in by how much of it is known)."""
    levels = []
    value, weight = img * known[..., None], known.astype(np.float32)
    while True:
        levels.append((value, weight))
        h, w = weight.shape
        if min(h, w) <= 2 or weight.min() > 0:
            break
        size = (max(1, (w + 1) // 2), max(1, (h + 1) // 2))
        value = cv2.resize(value, size, interpolation=cv2.INTER_AREA)
        weight = cv2.resize(weight, size, interpolation=cv2.INTER_AREA)
    value, weight = levels[-1]
    filled = value / np.maximum(weight, 1e-6)[..., None]
    if weight.max() <= 0:
        filled[:] = 0.0
    for value, weight in reversed(levels[:-1]):
        up = cv2.resize(filled, weight.shape[::-1], interpolation=cv2.INTER_LINEAR)
        mean = value / np.maximum(weight, 1e-6)[..., None]
        a = np.clip(weight * 4.0, 0.0, 1.0)[..., None]  # a coarse pixel half known is trusted fully
        filled = mean * a + up * (1.0 - a)
    return np.where(known[..., None], img, filled).astype(np.float32)


def cap_colours(photo: np.ndarray, filled: np.ndarray, hole: np.ndarray, cap: float = COLOUR_CAP) -> np.ndarray:
    """``filled`` (H, W, 3) uint8 with each pixel of ``hole`` (H, W) bool that lies farther than ``cap`` (RGB
    distance, levels) from every colour of its surroundings in ``photo`` (the known pixels within
    :data:`SURROUND` of the diagonal of its connected part of the hole) moved straight towards the nearest of
    those colours until it is ``cap`` from it."""
    from scipy.spatial import cKDTree

    hole = np.asarray(hole, bool)
    if not hole.any() or hole.all():
        return filled
    h, w = hole.shape
    reach = max(8.0, SURROUND * float(np.hypot(h, w)))
    out = filled.copy()
    n, labels = cv2.connectedComponents(hole.astype(np.uint8), connectivity=8)
    for k in range(1, n):
        part = labels == k
        ring = (cv2.distanceTransform((~part).astype(np.uint8), cv2.DIST_L2, 5) <= reach) & ~hole
        if not ring.any():
            continue
        colours = np.unique(photo[ring].reshape(-1, 3), axis=0).astype(np.float32)
        here = out[part].astype(np.float32)
        dist, idx = cKDTree(colours).query(here)
        far = dist > cap
        if not far.any():
            continue
        near = colours[idx[far]]
        here[far] = near + (here[far] - near) * (cap / dist[far])[:, None]
        out[part] = np.clip(np.round(here), 0, 255).astype(np.uint8)
    return out
