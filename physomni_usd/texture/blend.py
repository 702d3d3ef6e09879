"""The blend fill: the exemplar's copies of the surface, blended where they meet and held to the surroundings.

The exemplar fill (``exemplar.py``) lays patches copied from around the hole side by side: where two
patches meet the seam is a hard line, a patch that shift-map could not place stays unfilled (its
reduced pixels are zero in CIELAB, a pure blue), and a patch of something that is not the surface (a
bottle on a shelf beside the hole) is copied whole. The blend fill keeps the same shifts but lays them
softly and only where they look like the surface:

- every shift read back is laid over the pixels that chose it and, fading with a Gaussian
  (:data:`SEAM_SIGMA`), over their neighbours: where patches meet, both are averaged, so a seam is a
  gradual change, not a line; where no shift was read back, shift-map's own reduced result is laid the
  same way, and where it left pixels unfilled, nothing is;
- each copy is weighed by how close its local colour comes to a smooth fill of the surroundings
  (:func:`smooth_fill`; :data:`LIKENESS`, looser deep inside a large hole) and by how common its colour is
  on the hole's border (:data:`TYPICAL`): a copy of another thing fades out, and the smooth fill (itself made
  of the border's common colours only) takes what no likely copy covers;
- the fill is the smooth fill and :data:`COPY_SHARE` of the copies' difference from it; then the shading
  and grain matching of the exemplar fill, and no pixel is left farther than :data:`COLOUR_CAP` from every
  colour of its surroundings (:func:`cap_colours`).
"""

from __future__ import annotations

import cv2
import numpy as np

from .exemplar import NO_SHIFT, SHADING_DEPTH, SHADING_SIGMA, SHADING_TRUST, hole_windows, match_shading, shift_map
from .grain import match_grain, odd_border
from .pixels import blur, blur_over, nearest_surrounding, within

#: Width over which copies that meet are averaged, as a fraction of the hole's narrower side (at least 1.5 px).
SEAM_SIGMA = 0.03
#: Low-pass (Gaussian sigma, pixels) of the copies' and the smooth fill's colours when they are compared, and
#: the colour difference (RGB distance, levels) at which a copy's weight has fallen to 1/e. At 30 the smooth
#: fill took too much of the motorcycle's revealed floor from the dark shadow beside it (its colour 9.0 levels
#: off the floor around it, where bench look allows 8; 4.0 at 60, and the exemplar's 3.8); without the test at
#: all, copies of the bottle beside the hole in tests/test_fill_truth.py came back (57 yellow pixels; 3 at 60).
LIKENESS_SIGMA = 3.0
LIKENESS = 60.0
#: How far OpenCV's Gaussian of LIKENESS_SIGMA reaches on a float image (its kernel is 4 sigma a side), plus one:
#: a part of the window grown by it blurs to the same bits as the whole window does.
LOW_REACH = (int(round(LIKENESS_SIGMA * 8 + 1)) | 1) // 2 + 1
#: ... growing with the depth into the hole: by LIKENESS more for each LIKENESS_DEPTH of the window's diagonal.
LIKENESS_DEPTH = 0.05
#: A copy's colour must be common on the hole's border: its share of the border (the known pixels within
#: TYPICAL_REACH of the hole's narrower side, at least 8 pixels, their colours in bins of COLOUR_BIN levels) at
#: least TYPICAL of a typical colour's there, else its weight falls in proportion (a bottle on the shelf beside
#: the hole is rare around it; the wall and the floor are not). The smooth fill is made from that border alone.
#: At 0.25 the border reached past the surface the hole lies in: where six dark parts stood on a lit white
#: panel (a hole 476 pixels across) it took in the dark frame and the room, the smooth fill went grey in the
#: middle and copies of the frame and its bracket passed as like it (a dark blob the parts' shape); beside a
#: rubber toy, the orange of a foam letter and a curtain below and beside the hole counted as common, and the
#: letter was copied in whole. At 0.02 both fills are the panel's white and the cloth's blue; against the true
#: background (bench fill_truth) the faded fill's mean error is 5.75 levels on seed 62 (8 scenes) as before and
#: 11.67 on seed 73 (4 scenes; 11.75 before), at most the better of Telea and the blend in 2 of 8 and 2 of 4 as
#: before: the generated scenes' holes are small beside the surface they lie in.
TYPICAL = 0.2
TYPICAL_REACH = 0.02
COLOUR_BIN = 16
#: How much of the fill is the copies, the rest being the smooth fill. Less would err less against the truth where
#: no copy continues the surface (bench fill_truth, 4 scenes of seed 1, with LIKENESS 30: mean error 16.7 levels
#: at 0.5, 18.3 at 1; Telea 16.9) but loses the grain: at 0.5 the desk cap's revealed strip was 8.8 levels off the
#: wood around it (bench look allows 8) and the ball's grain 0.63 of the wood's; at 0.75, 7.85 and 0.75.
COPY_SHARE = 1.0
#: Weight of the smooth fill beside the copies: it shows only where no likely copy reaches.
SMOOTH_WEIGHT = 0.02
#: Most distance (RGB, levels) a filled pixel may lie from every colour of its surroundings (the known pixels
#: within :data:`~.pixels.SURROUND` of the diagonal of its part of the hole); a pixel farther is moved towards
#: the nearest of them until it is this far (rounding to whole levels adds at most 0.87).
COLOUR_CAP = 55.0
#: How far from the hole pixels that chose a copy its shift is tried on the known surface (:func:`shift_trust`), as
#: a fraction of the image diagonal (at least TRUST_MIN pixels), and the fewest known pixels it is read on (fewer:
#: trusted as before).
TRUST_REACH = 0.03
TRUST_MIN = 6.0
TRUST_PIXELS = 16
TRUST_MEAN = 0.5
TRUST_NOISE = 1.5
TRUST_RATIO = 1.5
#: The faded blend (the plate's default, ``fill.py``): the widest its copies are averaged (Gaussian sigma), as a
#: fraction of the image diagonal.
FADE_MAX = 0.025


def fill_blend(photo: np.ndarray, hole: np.ndarray, fade: float = 0.0, trust: np.ndarray | None = None) -> np.ndarray:
    """``photo`` (H, W, 3) uint8 RGB with ``hole`` (H, W) bool filled as the module says, one window per
    connected part of the hole (as :func:`~.exemplar.fill_exemplar` makes them); with ``fade`` > 0 each window's
    fill is then faded into its local mean with the depth into the hole (:func:`fade_with_depth`) and its grain
    matched to the surface's again (:func:`~.grain.match_grain`). ``trust``: (H, W) float32 given by the caller;
    the fill writes there, for each pixel of the hole, how far its copies can be trusted to continue the surface
    in step (:func:`shift_trust`, weighed as the copies are; 1 where the smooth fill or shift-map's own result
    took the pixel), and leaves it 1 elsewhere."""
    h, w = hole.shape
    out = photo.copy()
    if trust is not None:
        trust[...] = 1.0
    for (x0, y0, x1, y1), win_hole, own, size, budget in hole_windows(hole):
        win_trust = np.ones(win_hole.shape, np.float32) if trust is not None else None
        filled = _blend_window(photo[y0:y1, x0:x1], win_hole, size, SHADING_DEPTH * np.hypot(h, w), budget, own,
                               win_trust)
        if trust is not None:
            trust[y0:y1, x0:x1][own] = win_trust[own]
        if fade > 0:  # the copies' detail faded, the surface's grain (not theirs) laid back where it went flat
            filled = match_grain(photo[y0:y1, x0:x1],
                                 fade_with_depth(filled, win_hole, fade, FADE_MAX * float(np.hypot(h, w))), win_hole)
        out[y0:y1, x0:x1][own] = filled[own]
    return cap_colours(photo, out, hole)


def fade_with_depth(filled: np.ndarray, hole: np.ndarray, fade: float, most: float) -> np.ndarray:
    """``filled`` (h, w, 3) uint8 with each pixel of ``hole`` (h, w) bool replaced by its mean over a Gaussian
    ``fade`` times its distance into the hole wide (pixels; at most ``most``), so that the copies keep their
    detail at the hole's edge, where they continue the surface beside them, and fade into their local colour
    deeper in, where a copy's detail is a guess at where the surface's lines and spots lie."""
    depth = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_L2, 5)
    want = np.clip(depth * fade, 0.0, max(most, 0.5))
    sigmas = [0.0]
    while sigmas[-1] < want.max():
        sigmas.append(max(1.0, 2.0 * sigmas[-1]))
    if len(sigmas) == 1:
        return filled
    src = filled.astype(np.float32)
    stack = [src] + [cv2.GaussianBlur(src, (0, 0), s) for s in sigmas[1:]]
    i = np.clip(np.searchsorted(sigmas, want), 1, len(sigmas) - 1)
    lo, hi = np.float32(sigmas)[i - 1], np.float32(sigmas)[i]
    a = np.clip((want - lo) / (hi - lo), 0.0, 1.0)[..., None]
    out = np.zeros_like(src)
    for k in range(1, len(sigmas)):
        at = (i == k)[..., None]
        out = np.where(at, stack[k - 1] * (1.0 - a) + stack[k] * a, out)
    return np.where(hole[..., None], np.clip(out + 0.5, 0, 255), filled).astype(np.uint8)


def _blend_window(img: np.ndarray, hole: np.ndarray, size: int, depth: float, budget: float,
                  own: np.ndarray | None = None, trust: np.ndarray | None = None) -> np.ndarray:
    """The blend fill of ``hole`` in the window ``img`` (h, w, 3) RGB; ``size``, ``depth``, ``budget`` and ``own``
    as the exemplar's window takes them; ``trust`` (h, w) float32, when given, receives :func:`fill_blend`'s."""
    coarse, offsets, unfilled = shift_map(img, hole, budget, own)
    src = img.astype(np.float32)
    known = ~hole
    src_low = cv2.GaussianBlur(src, (0, 0), LIKENESS_SIGMA)
    border = known & within(hole, max(8.0, TYPICAL_REACH * size))
    frequency = _colour_frequency(src_low, border)
    # the smooth fill from the surface on the hole's border alone: what is rare there (a bottle beside the hole)
    # takes no part, nor what lies farther out (the dark room around a lit panel)
    surface = (border & ~odd_border(cv2.cvtColor(img, cv2.COLOR_RGB2BGR), hole)).astype(np.float32)
    smooth = smooth_fill(src, surface * np.clip(frequency(src_low) / TYPICAL, 0.0, 1.0))
    smooth_low = cv2.GaussianBlur(smooth, (0, 0), LIKENESS_SIGMA)
    sigma = max(1.5, SEAM_SIGMA * size)
    ys, xs = np.nonzero(hole)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    box = (slice(y0, y1), slice(x0, x1))
    # deep in a large hole the smooth fill is a guess (the mean of a wall and a floor): trust it less there
    depth_in = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_L2, 5)[box]
    likeness = LIKENESS * (1.0 + depth_in / (LIKENESS_DEPTH * float(np.hypot(*hole.shape))))
    acc = smooth[box] * SMOOTH_WEIGHT
    weight = np.full((y1 - y0, x1 - x0), SMOOTH_WEIGHT, np.float32)
    d = offsets[ys, xs]
    found = d[:, 0] != NO_SHIFT
    h, w = hole.shape
    # where no shift was read back, shift-map's own reduced result (upsampled) is laid like one more copy,
    # except where it left its pixels unfilled
    rest = ~found & ~unfilled[ys, xs]
    # each shift as one integer (dy, then dx, in order) and each pixel's layer by it: np.unique over rows sorts
    # structured records, ten times the time of a flat sort, and a pass over all pixels per shift is as many
    code = (d[:, 0].astype(np.int64) << 32) + d[:, 1].astype(np.int64)
    shifts, first, which = np.unique(np.where(found, code, np.iinfo(np.int64).max), return_index=True,
                                     return_inverse=True)
    which = which.reshape(-1)
    layers = [(d[i, 0], d[i, 1], which == k) for k, i in enumerate(first) if found[i]]
    if rest.any():
        layers.append((None, None, rest))
    known8 = known.astype(np.uint8)
    trusted = np.zeros_like(weight)
    smoothed = blur_over(src, known.astype(np.float32), TRUST_NOISE) if trust is not None else None
    for dy, dx, pick in layers:
        chose = np.zeros((h, w), np.float32)
        chose[ys[pick], xs[pick]] = 1.0
        near = blur(chose, sigma)
        reach = _reach(near[box])
        if reach is None:
            continue
        # a copy weighs nothing where it has not spread: it is laid, and its likeness read, only where it has, on a
        # part of the window grown so that the low-pass there is the whole window's, to the bit (a 12 MP photo's
        # working copy lays some thirty copies, each over a fraction of its hole)
        r0, r1, c0, c1 = reach
        a0, a1 = max(0, y0 + r0 - LOW_REACH), min(h, y0 + r1 + LOW_REACH)
        b0, b1 = max(0, x0 + c0 - LOW_REACH), min(w, x0 + c1 + LOW_REACH)
        inner = (slice(y0 + r0 - a0, y0 + r1 - a0), slice(x0 + c0 - b0, x0 + c1 - b0))
        if dy is None:
            copy, valid = coarse[a0:a1, b0:b1].astype(np.float32), hole[a0:a1, b0:b1].copy()
        else:  # the copy laid over the part: each pixel takes the pixel (dy, dx) from it, where known
            shift = np.float32([[1, 0, dx + b0], [0, 1, dy + a0]])
            copy = cv2.warpAffine(src, shift, (b1 - b0, a1 - a0), flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                                  borderMode=cv2.BORDER_CONSTANT)
            valid = cv2.warpAffine(known8, shift, (b1 - b0, a1 - a0), flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                                   borderMode=cv2.BORDER_CONSTANT) > 0
        spread = near[y0 + r0:y0 + r1, x0 + c0:x0 + c1] * valid[inner]
        low = cv2.GaussianBlur(copy * valid[..., None], (0, 0), LIKENESS_SIGMA)
        low /= np.maximum(cv2.GaussianBlur(valid.astype(np.float32), (0, 0), LIKENESS_SIGMA), 1e-3)[..., None]
        low = low[inner]
        unlike = np.linalg.norm(low - smooth_low[y0 + r0:y0 + r1, x0 + c0:x0 + c1], axis=-1) / likeness[r0:r1, c0:c1]
        wk = spread * np.exp(-unlike ** 2) * np.clip(frequency(low) / TYPICAL, 0.0, 1.0)
        acc[r0:r1, c0:c1] += copy[inner] * wk[..., None]
        weight[r0:r1, c0:c1] += wk
        if trust is not None:
            tried = 1.0 if dy is None else shift_trust(src, known, chose, dy, dx, size, smoothed)
            trusted[r0:r1, c0:c1] += wk * tried
    if trust is not None:  # the smooth fill is a mean already: nothing of it to distrust
        trust[box] = np.where(hole[box], (trusted + SMOOTH_WEIGHT) / weight, 1.0)
    out = img.copy()
    # the copies' share of the fill, beside the smooth fill's: their grain and structure, less their guesses
    laid = smooth[box] + COPY_SHARE * (acc / weight[..., None] - smooth[box])
    out[box] = np.where(hole[box][..., None], np.clip(laid + 0.5, 0, 255), img[box]).astype(np.uint8)
    out = match_shading(img, out, hole, max(3.0, SHADING_SIGMA * size), depth, SHADING_TRUST)
    return match_grain(img, out, hole)


def shift_trust(src: np.ndarray, known: np.ndarray, chose: np.ndarray, dy: int, dx: int, size: int,
                smooth: np.ndarray | None = None) -> float:
    """How far a copy shifted by (``dy``, ``dx``) can be trusted to continue the surface in step, 0-1, read on
    the known surface beside the hole pixels that chose it (``chose`` (h, w) float32 1 there; ``src`` (h, w, 3)
    float32, ``known`` (h, w) bool): where the shift maps that surface onto itself (a copy along a ripple, by a
    whole period of tiles) it errs by ``r``, the mean colour difference (levels) between each known pixel there and
    the one the shift brings to it; a smooth fill errs about ``m`` there, the surface's mean difference from its
    own local mean over the hole's scale (a Gaussian :data:`TRUST_MEAN` of ``size``, the hole's
    narrower side in pixels, wide: a smooth fill's colour deep in the hole is the border's mean that far around),
    and more deeper in, where the border's mean says less: the copy is trusted while r stays under
    :data:`TRUST_RATIO` times m, and less, steeply, beyond. Held as two guesses whose errors are
    independent. A copy out of step (tiles in perspective, ripples that bend)
    errs more than the mean, and its lines and spots fall between the true ones. ``smooth``: ``src`` low-passed
    over ``known`` by :data:`TRUST_NOISE`, when the caller has it."""
    h, w = known.shape
    reach = max(TRUST_MIN, TRUST_REACH * float(np.hypot(h, w)))
    ys, xs = np.nonzero(chose)
    g = int(np.ceil(reach)) + 2
    a0, a1, b0, b1 = max(0, ys.min() - g), min(h, ys.max() + 1 + g), max(0, xs.min() - g), min(w, xs.max() + 1 + g)
    near = cv2.distanceTransform((chose[a0:a1, b0:b1] <= 0).astype(np.uint8), cv2.DIST_L2, 5) <= reach
    # compared after a small low-pass over the known surface: the render's noise and the finest grain are no step
    if smooth is None:  # the caller trying many shifts on one window passes it once
        smooth = blur_over(src, known.astype(np.float32), TRUST_NOISE)
    here = smooth[a0:a1, b0:b1]
    shift = np.float32([[1, 0, dx + b0], [0, 1, dy + a0]])
    there = cv2.warpAffine(smooth, shift, (b1 - b0, a1 - a0), flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                           borderMode=cv2.BORDER_CONSTANT)
    both = known[a0:a1, b0:b1] & near & (cv2.warpAffine(known.astype(np.uint8), shift, (b1 - b0, a1 - a0),
                                                      flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                                                      borderMode=cv2.BORDER_CONSTANT) > 0)
    if both.sum() < TRUST_PIXELS:
        return 1.0
    r = float(np.abs(there - here).mean(-1)[both].mean())
    local = blur_over(here, known[a0:a1, b0:b1].astype(np.float32), max(2.0, TRUST_MEAN * size))
    m = float(np.abs(here - local).mean(-1)[both].mean())
    return 1.0 / (1.0 + (r / max(TRUST_RATIO * m, 1e-6)) ** 4)


def _reach(spread: np.ndarray) -> tuple[int, int, int, int] | None:
    """(row0, row1, col0, col1): the smallest box of ``spread`` (h, w) float32 holding every pixel above 0; None
    when there is none."""
    rows, cols = np.flatnonzero(spread.any(axis=1)), np.flatnonzero(spread.any(axis=0))
    if rows.size == 0:
        return None
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _colour_frequency(low: np.ndarray, ring: np.ndarray):
    """A function of colours (..., 3) float32 → (...) float32: how common each is among the pixels ``ring``
    (h, w) bool of ``low`` (h, w, 3) float32, as the share of those pixels in its bin (and the bins next to it, of
    :data:`COLOUR_BIN` levels a side) over the share a typical one of them sees in its own."""
    from scipy.ndimage import uniform_filter

    n = 256 // COLOUR_BIN
    index = lambda c: (np.clip(c, 0, 255).astype(np.int64) // COLOUR_BIN) @ np.int64([n * n, n, 1])  # noqa: E731
    if not ring.any():
        return lambda c: np.ones(c.shape[:-1], np.float32)
    hist = np.bincount(index(low[ring]), minlength=n ** 3).astype(np.float32) / float(ring.sum())
    hist = uniform_filter(hist.reshape(n, n, n), size=3, mode="constant").ravel() * 27.0
    typical = float(hist[index(low[ring])].mean())
    return lambda c: hist[index(c)] / max(typical, 1e-9)


def smooth_fill(img: np.ndarray, known: np.ndarray) -> np.ndarray:
    """(h, w, 3) float32: ``img`` (h, w, 3) float32 where ``known`` (h, w) float32 is 1, and elsewhere a smooth
    interpolation of the pixels it weighs (push-pull: weighted averages at halving sizes, each size's gaps
    filled from the next coarser one, blended in by how much of it is known)."""
    known = np.asarray(known, np.float32)
    levels = []
    value, weight = img * known[..., None], known
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
    return np.where(known[..., None] >= 1.0, img, filled).astype(np.float32)


def cap_colours(photo: np.ndarray, filled: np.ndarray, hole: np.ndarray, cap: float = COLOUR_CAP) -> np.ndarray:
    """``filled`` (H, W, 3) uint8 with each pixel of ``hole`` (H, W) bool that lies farther than ``cap`` (RGB
    distance, levels) from every colour of its surroundings in ``photo`` (:func:`~.pixels.nearest_surrounding`)
    moved straight towards the nearest of those colours until it is ``cap`` from it."""
    hole = np.asarray(hole, bool)
    if not hole.any() or hole.all():
        return filled
    # the surroundings are the photo's, the colours weighed the fill's
    image = np.where(hole[..., None], filled, photo)
    nearest, dist = nearest_surrounding(image, hole)
    far = hole & (dist > cap) & np.isfinite(dist)
    if not far.any():
        return filled
    out = filled.copy()
    here, near = filled[far].astype(np.float32), nearest[far]
    out[far] = np.clip(np.round(near + (here - near) * (cap / dist[far])[:, None]), 0, 255).astype(np.uint8)
    return out
