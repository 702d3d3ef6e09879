"""The plate widened beyond the photo's frame, for camera moves: mirrored (:func:`mirror_outpaint`) or quilted
from the plate's own surfaces (:func:`exemplar_outpaint`, the default outpainter)."""

from __future__ import annotations

import cv2
import numpy as np

#: Distance from the photo's edge, as a fraction of its longer side, over which an outpainted margin
#: fades from the mirrored plate to its blur (so the mirror's symmetry does not read as a second scene).
MIRROR_FADE = 0.2


def mirror_outpaint(plate: np.ndarray, margins: tuple[int, int, int, int]) -> np.ndarray:
    """``plate`` (H, W, 3) uint8 widened by (top, bottom, left, right) pixels → (H+t+b, W+l+r, 3) uint8: each
    margin mirrors the plate across its edge and fades into a blur of it with the distance from the edge; the
    original pixels are kept at [t:t+H, l:l+W]."""
    t, b, l, r = (int(m) for m in margins)
    h, w = plate.shape[:2]
    # a margin wider than the plate reflects more than once: pad in steps of at most the plate's own size
    out = plate
    while t or b or l or r:
        st, sb = min(t, out.shape[0] - 1), min(b, out.shape[0] - 1)
        sl, sr = min(l, out.shape[1] - 1), min(r, out.shape[1] - 1)
        out = cv2.copyMakeBorder(out, st, sb, sl, sr, cv2.BORDER_REFLECT_101)
        t, b, l, r = t - st, b - sb, l - sl, r - sr
    t, b, l, r = (int(m) for m in margins)
    wide = out.astype(np.float32)
    outside = np.ones(wide.shape[:2], np.uint8)
    outside[t:t + h, l:l + w] = 0
    size = float(max(h, w))
    d = cv2.distanceTransform(outside, cv2.DIST_L2, 3)
    small = cv2.resize(wide, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)
    blur = cv2.resize(cv2.GaussianBlur(small, (0, 0), max(1.0, 0.01 * size)), wide.shape[1::-1],
                      interpolation=cv2.INTER_LINEAR)
    a = np.clip(d / (MIRROR_FADE * size), 0.0, 1.0)[..., None]
    result = np.clip(wide * (1.0 - a) + blur * a + 0.5, 0, 255).astype(np.uint8)
    result[t:t + h, l:l + w] = plate
    return result


#: Side of the patches an exemplar margin is quilted from, as a fraction of the plate's shorter side.
OUTPAINT_PATCH = 0.1
#: Depth of the plate along each edge that its margin takes patches from, as a fraction of the plate's side
#: across that edge: the floor continues the floor, the wall the wall.
OUTPAINT_BAND = 0.2
#: Scale of the shading an exemplar margin keeps from the plate's edge (Gaussian sigma, fraction of the
#: plate's longer side): only light and colour this coarse carry over, never a recognisable copy.
OUTPAINT_SHADING = 0.04
#: Width of the seam along the photo's edge over which a margin blends in from the edge's own pixels, as a
#: fraction of the plate's longer side.
OUTPAINT_SEAM = 0.01
#: Candidate patches drawn for each place in a margin; the one that best matches what already lies under
#: its overlap is kept (image quilting), so neighbouring patches continue each other.
OUTPAINT_CANDIDATES = 12
#: Longest side of the copy of the plate on which the patches are chosen: the choice (which part of the plate
#: goes where) is made there and the chosen patches are then laid from the plate itself at its full size, so
#: the margins keep the plate's own grain and the time hardly grows with the plate.
OUTPAINT_MATCH_SIDE = 256


def _quilt_places(plate: np.ndarray, margins: tuple[int, int, int, int], p: int, rng) -> list[tuple]:
    """Image quilting of the margins of ``plate`` (h, w, 3) with patches of side ``p``: per place, in the
    order laid, (y, x) in the widened image and (sy, sx) in the plate, the patch chosen for it."""
    t, b, l, r = margins
    h, w = plate.shape[:2]
    H, W = h + t + b, w + l + r
    step = max(2, p // 2)
    band_y, band_x = min(h, max(p, int(OUTPAINT_BAND * h))), min(w, max(p, int(OUTPAINT_BAND * w)))
    window = np.outer(np.hanning(p + 2)[1:-1], np.hanning(p + 2)[1:-1]).astype(np.float32) + 1e-4
    src = plate.astype(np.float32)
    patches = np.lib.stride_tricks.sliding_window_view(src, (p, p), axis=(0, 1))  # (h-p+1, w-p+1, 3, p, p)
    acc = np.zeros((H, W, 3), np.float32)
    weight = np.zeros((H, W), np.float32)
    acc[t:t + h, l:l + w], weight[t:t + h, l:l + w] = src, 1.0  # the first patches continue the plate
    outside = np.ones((H, W), bool)
    outside[t:t + h, l:l + w] = False

    def source_range(centre: float, extent: int, band: int) -> tuple[int, int]:
        """Where along one axis of the plate a patch whose centre lies at ``centre`` (plate coordinates) may
        come from: the band at the near edge when it lies beyond one, else around its own position."""
        if centre < 0:
            return 0, band - p
        if centre >= extent:
            return extent - band, extent - p
        c = int(np.clip(centre - p / 2, 0, extent - p))
        return max(0, c - p), min(extent - p, c + p)

    places = [(y, x) for y in range(-step, H, step) for x in range(-step, W, step)
              if outside[max(0, y):min(H, y + p), max(0, x):min(W, x + p)].any()]
    # nearest the photo first, so that the margin grows outward from it
    places.sort(key=lambda q: max(t - (q[0] + p), q[0] - (t + h), l - (q[1] + p), q[1] - (l + w), 0) ** 2
                + min(abs(q[0] + p / 2 - t - h / 2) / max(h, 1), abs(q[1] + p / 2 - l - w / 2) / max(w, 1)))
    chosen = []
    for y, x in places:
        y0, y1, x0, x1 = max(0, y), min(H, y + p), max(0, x), min(W, x + p)
        sy0, sy1 = source_range(y + p / 2 - t, h, band_y)
        sx0, sx1 = source_range(x + p / 2 - l, w, band_x)
        sy = rng.integers(sy0, max(sy0, sy1) + 1, OUTPAINT_CANDIDATES)
        sx = rng.integers(sx0, max(sx0, sx1) + 1, OUTPAINT_CANDIDATES)
        have = weight[y0:y1, x0:x1]
        laid = have > 0.05
        best = 0
        if laid.any():
            cands = patches[sy, sx][:, :, y0 - y:y1 - y, x0 - x:x1 - x]  # (C, 3, ph, pw)
            now = (acc[y0:y1, x0:x1] / np.maximum(have, 1e-6)[..., None]).transpose(2, 0, 1)
            err = (((cands - now) ** 2).sum(1) * laid).sum((1, 2))
            best = int(np.argmin(err))
        patch = patches[sy[best], sx[best]][:, y0 - y:y1 - y, x0 - x:x1 - x].transpose(1, 2, 0)
        win = window[y0 - y:y1 - y, x0 - x:x1 - x]
        acc[y0:y1, x0:x1] += patch * win[..., None]
        weight[y0:y1, x0:x1] += win
        chosen.append((y, x, int(sy[best]), int(sx[best])))
    return chosen


def exemplar_outpaint(plate: np.ndarray, margins: tuple[int, int, int, int], seed: int = 0) -> np.ndarray:
    """``plate`` (H, W, 3) uint8 widened by (top, bottom, left, right) pixels → (H+t+b, W+l+r, 3) uint8, each
    margin quilted from the plate's own surfaces: overlapping patches (side :data:`OUTPAINT_PATCH`),
    feathered together, laid from the photo's edge outward, each the best matching of a few drawn at random
    from the band of the plate along the nearest edge (its corner region for a corner) near the same
    position along it. The patches are chosen on a copy of the plate at most :data:`OUTPAINT_MATCH_SIDE`
    pixels long and laid from the full-size plate. Their fine texture is kept; their shading is replaced by
    the plate edge's, heavily blurred, so that light and colour continue across the edge. Unlike a mirror,
    no part of the photo appears again as a recognisable copy. The original pixels are kept at
    [t:t+H, l:l+W]."""
    t, b, l, r = (int(m) for m in margins)
    h, w = plate.shape[:2]
    if not (t or b or l or r):
        return plate.copy()
    rng = np.random.default_rng(seed)
    H, W = h + t + b, w + l + r
    size = float(max(h, w))
    k = min(1.0, OUTPAINT_MATCH_SIDE / size)
    sh, sw = max(8, round(h * k)), max(8, round(w * k))
    small = plate if k == 1.0 else cv2.resize(plate, (sw, sh), interpolation=cv2.INTER_AREA)
    ky, kx = sh / h, sw / w
    p = min(max(4, int(round(OUTPAINT_PATCH * min(sh, sw)))), sh, sw)
    chosen = _quilt_places(small, (round(t * ky), round(b * ky), round(l * kx), round(r * kx)), p, rng)
    # the same patches at full size: each place and source scaled up, the patch a pixel larger so that
    # rounding leaves no gap between neighbours
    py, px = min(h, int(np.ceil(p / ky)) + 1), min(w, int(np.ceil(p / kx)) + 1)
    window = np.outer(np.hanning(py + 2)[1:-1], np.hanning(px + 2)[1:-1]).astype(np.float32) + 1e-4
    src = plate.astype(np.float32)
    acc = np.zeros((H, W, 3), np.float32)
    weight = np.zeros((H, W), np.float32)
    tk, lk = round(t * ky), round(l * kx)
    for y, x, sy, sx in chosen:
        fy, fx = t + int(round((y - tk) / ky)), l + int(round((x - lk) / kx))
        fsy, fsx = min(h - py, int(round(sy / ky))), min(w - px, int(round(sx / kx)))
        y0, y1, x0, x1 = max(0, fy), min(H, fy + py), max(0, fx), min(W, fx + px)
        if y1 <= y0 or x1 <= x0:
            continue
        win = window[y0 - fy:y1 - fy, x0 - fx:x1 - fx]
        acc[y0:y1, x0:x1] += src[fsy + y0 - fy:fsy + y1 - fy, fsx + x0 - fx:fsx + x1 - fx] * win[..., None]
        weight[y0:y1, x0:x1] += win
    acc[t:t + h, l:l + w], weight[t:t + h, l:l + w] = src, 1.0
    quilt = acc / np.maximum(weight, 1e-6)[..., None]
    # shading: the plate's edge pixels carried outward, blurred far beyond any shape (the blurs at the
    # matching size: nothing finer than their sigma survives them)
    sigma = max(2.0, OUTPAINT_SHADING * size)
    edge = cv2.copyMakeBorder(small, round(t * ky), round(b * ky), round(l * kx), round(r * kx),
                              cv2.BORDER_REPLICATE).astype(np.float32)

    def low_pass(img: np.ndarray) -> np.ndarray:
        blurred = cv2.GaussianBlur(img, (0, 0), max(1.0, sigma * k))
        return cv2.resize(blurred, (W, H), interpolation=cv2.INTER_LINEAR)

    quilt_small = cv2.resize(quilt, edge.shape[1::-1], interpolation=cv2.INTER_AREA) if k < 1.0 else quilt
    wide = low_pass(edge) + (quilt - low_pass(quilt_small))
    outside = np.ones((H, W), np.uint8)
    outside[t:t + h, l:l + w] = 0
    d = cv2.distanceTransform(outside, cv2.DIST_L2, 3)
    a = np.clip(d / max(1.0, OUTPAINT_SEAM * size), 0.0, 1.0)[..., None]
    reflect = cv2.copyMakeBorder(plate, t, b, l, r, cv2.BORDER_REFLECT_101).astype(np.float32)
    result = np.clip(reflect * (1.0 - a) + wide * a + 0.5, 0, 255).astype(np.uint8)
    result[t:t + h, l:l + w] = plate
    return result
