"""The exemplar fill of a hole: shift-map copies of the surface around it, their shading matched to its border.

OpenCV xphoto's shift-map inpainting (He & Sun 2012) copies patches of the
surface around the hole into it, so the fill keeps the surface's grain instead
of the radial smear of a diffusion fill. Shift-map is slow at full
resolution, so each hole is filled in a reduced window around it; the shifts
it chose are read back from the result (every filled pixel is a copy of a
known one) and applied at full resolution. The fill's low frequencies are
then shifted by the step it makes against the photo along the hole's border,
carried inward (so a horizon the exemplar continued stays where it is), and
pulled towards a smooth interpolation of the border only where that
interpolation is flat (leaving out border pixels that are not the surface);
its fine detail is matched to the gradient of the surface around the hole
(``grain.py``).
"""

from __future__ import annotations

import cv2
import numpy as np

from .grain import match_grain, odd_border
from .pixels import INPAINT_RADIUS, blur, blur_over, colour_code, dilate, within

#: Pixels of the reduced window in which shift-map searches, and most pixels of each connected part of the hole
#: at the reduced size. Below about 10000 the shifts read back are too coarse to carry a surface's grain (a
#: desk's wood came out as a flat disc where a ball stood); 12000 fills the motorcycle's 196000-pixel
#: hole in about 2 s on one core. Each part has the whole of it, whatever the other parts: shared among them by
#: their size, a change anywhere in the hole changed every part's reduction and so its copies
#: (tests/test_fill_parts.py). A change within a part still refills all of it: 29 pixels off the tip of the
#: motorcycle's mirror (its one-part hole 88 pixels larger) changed its plate by more than 20 levels in 96,139
#: pixels; with its reduction held (156 × 105), 19 of the 11090 reduced hole pixels changed and shift-map's
#: labelling, which is global, changed 6866 of them by more than 20 levels.
EXEMPLAR_PIXELS = 150 * 150
EXEMPLAR_HOLE_PIXELS = 12000
#: Context kept around each hole for the exemplar search, as a fraction of the hole's larger side.
EXEMPLAR_CONTEXT = 0.6
#: Most distinct shifts read back from one shift-map result (it uses a few dozen dominant offsets).
MAX_SHIFTS = 128
#: Width of the low-pass by which the exemplar fill's shading is matched to its border, as a fraction
#: of the hole's narrower side (at least 3 pixels), and the depth into the hole over which that match fades
#: (1/e), as a fraction of the image diagonal (both corrections of :func:`match_shading` are smoothed by it
#: over the hole). Patches copied from elsewhere bring their own brightness
#: (a darker sky from above the rocket, a wall's colour onto the garage floor): at 0.012 the fill where the
#: rocket stood was 35 levels off the sky around it and the motorcycle's 27 off the floor; at 0.1 the
#: border's smooth colour reaches across the hole (16 and 9 levels) and the patches keep only their grain.
#: Sized by the larger side, the low-pass of a wide hole averaged its bright patches with the dark floor
#: shadow beside them and left them lit (the motorcycle's revealed floor 13 levels off its ring; by the
#: narrower side, 8.4).
SHADING_SIGMA = 0.08
SHADING_DEPTH = 0.1
#: Low-pass (Gaussian sigma, pixels of the window's copy at most 160 pixels long) with which the step the fill
#: makes against the photo is measured along the hole's border (:func:`match_shading`). The match used to
#: take the fill's low frequencies from a smooth fill of the border's colours, which across a horizon is
#: a smear of the two surfaces: where the water example's block stood the fill was 12-29 levels lighter and
#: bluer than the floor beside it in the 40 rows below the horizon, though the exemplar had copied the
#: horizon right. Matching the step instead leaves those rows within 3 levels. Measured with the fill's
#: own low-pass as wide as the shading's (:data:`SHADING_SIGMA`), a surface that brightens across the border
#: (the motorcycle's floor towards the camera) read as a step and darkened the fill (its colour 8.6 levels
#: off its ring); at 3 pixels, 3.0.
SHADING_STEP = 3.0
#: How much of the border step :func:`match_shading` carries across the hole without the fade
#: (:data:`SHADING_DEPTH`): the part beyond STEP_NOISE times the surface's own grain at the step's scale
#: (the photo's low-pass by :data:`SHADING_STEP` less one GRAIN_STEP times wider, its median spread as a
#: standard deviation over a ring around the hole; both low-passes over the known surface alone). Faded
#: whole, the step left the middle of the rocket's column, where darker sky from above had been copied, 9.7
#: levels off the sky beside it (mean over its rows above the lights, every 4th row, its largest channel;
#: 18.8 at most); carried whole, the gravel's grain under the chair was carried in as if it were a step (its
#: colour 17.0 levels off its ring, where the bench allows 15). At 3 times the grain: the column 4.0 (13.3
#: at most), the gravel 14.7 and every other bench plate case as faded; at 2 times the gravel 15.05.
GRAIN_STEP = 3.0
STEP_NOISE = 3.0
#: Patches inside the hole that never touch its border are still pulled towards the smooth fill of the
#: border's colours, where that fill changes by less than this many levels per pixel (fully where it is flat,
#: not at all from this slope up): the smear of an edge is steeper than a surface's shading. With the step
#: alone the rocket's column kept the darker sky copied into its middle (8.3 levels off its ring, 16-20 in
#: its centre rows); at 0.5 it is 7.6, the motorcycle's 1.5, and the water's rows stay within 3 levels
#: (at 1.0: 7.1, 0.3, and 5-7 levels just above the water's horizon).
SHADING_TRUST = 0.5


def hole_windows(hole: np.ndarray):
    """Each connected part of ``hole`` (H, W) bool with the window of surface around it
    (:data:`EXEMPLAR_CONTEXT` of its size, the whole photo where that window is all hole): yields the
    window ``(x0, y0, x1, y1)``, the hole in it, the part's own pixels in it, the part's narrower side in
    pixels and its budget at the reduced size (:data:`EXEMPLAR_HOLE_PIXELS`, its own: no other part changes how
    this one is filled)."""
    h, w = hole.shape
    n, labels, stats, _ = cv2.connectedComponentsWithStats(hole.astype(np.uint8), connectivity=8)
    for k in range(1, n):
        x, y, bw, bh = stats[k, :4]
        m = int(round(EXEMPLAR_CONTEXT * max(bw, bh))) + 8
        x0, y0, x1, y1 = max(0, x - m), max(0, y - m), min(w, x + bw + m), min(h, y + bh + m)
        win_hole = hole[y0:y1, x0:x1]
        if win_hole.all():
            win_hole = hole  # no surface around this part: use the whole photo
            x0, y0, x1, y1 = 0, 0, w, h
        yield (x0, y0, x1, y1), win_hole, labels[y0:y1, x0:x1] == k, min(bw, bh), float(EXEMPLAR_HOLE_PIXELS)


def fill_exemplar(photo: np.ndarray, hole: np.ndarray, sources: np.ndarray | None = None) -> np.ndarray:
    """Shift-map (exemplar) fill of ``hole``, one window per connected part of it; ``sources``: as
    :func:`~.fill.background_plate` takes it."""
    h, w = hole.shape
    out = photo.copy()
    for (x0, y0, x1, y1), win_hole, own, size, budget in hole_windows(hole):
        copied = None if sources is None else np.full((y1 - y0, x1 - x0, 2), -1, np.int32)
        filled = _exemplar_window(photo[y0:y1, x0:x1], win_hole, size, SHADING_DEPTH * np.hypot(h, w), budget,
                                  copied, own)
        out[y0:y1, x0:x1][own] = filled[own]
        if sources is not None:
            found = own & (copied[..., 0] >= 0)
            sources[y0:y1, x0:x1][found] = copied[found] + np.int32([y0, x0])
    return out


def _exemplar_window(img: np.ndarray, hole: np.ndarray, size: int, depth: float, budget: float,
                     sources: np.ndarray | None = None, own: np.ndarray | None = None) -> np.ndarray:
    """Fill ``hole`` of the window ``img`` (h, w, 3) RGB: shift-map on a copy reduced until the window's part
    ``own`` of the hole (default all of it) has at most ``budget`` pixels (and the window
    :data:`EXEMPLAR_PIXELS`), its shifts applied at full resolution; ``size`` (pixels, the hole's narrower side)
    sets the shading match's low-pass (:data:`SHADING_SIGMA`)."""
    h, w = hole.shape
    out, offsets, _ = shift_map(img, hole, budget, own)
    ys, xs = np.nonzero(hole)
    d = offsets[ys, xs]
    qy, qx = ys + d[:, 0], xs + d[:, 1]
    ok = (d[:, 0] != NO_SHIFT) & (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
    ok[ok] &= ~hole[qy[ok], qx[ok]]
    out[ys[ok], xs[ok]] = img[qy[ok], qx[ok]]
    if sources is not None:  # where each copied pixel came from, in the window (fill_exemplar moves it)
        sources[ys[ok], xs[ok]] = np.stack([qy[ok], qx[ok]], 1)
    out = match_shading(img, out, hole, max(3.0, SHADING_SIGMA * size), depth, SHADING_TRUST)
    return match_grain(img, out, hole)


def shift_map(img: np.ndarray, hole: np.ndarray, budget: float,
              own: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shift-map of ``hole`` in the window ``img`` (h, w, 3) RGB, on a copy reduced until the part ``own`` of the
    hole that the window is for (default all of it; other parts that reach into the window count for nothing, so
    that they change no part's reduction) has at most ``budget`` pixels (and the window :data:`EXEMPLAR_PIXELS`):
    the window (h, w, 3) uint8 with the hole's pixels
    the reduced result upsampled, and (h, w, 2) int64, for each pixel of the hole the offset (dy, dx) at full
    resolution of the pixel its reduced pixel copied (:func:`recover_shifts`; :data:`NO_SHIFT` where none was
    read back), 0 elsewhere; and (h, w) bool, the pixels of the hole whose reduced pixel shift-map left unfilled
    (zero in CIELAB: a pure blue in the window's result)."""
    h, w = hole.shape
    own = hole if own is None else own
    f = max(1.0, float(np.sqrt(h * w / EXEMPLAR_PIXELS)), float(np.sqrt(own.sum() / max(budget, 64.0))))
    for _ in range(4):
        sw, sh = max(8, round(w / f)), max(8, round(h / f))
        small_hole = _reduced_hole(hole, sw, sh) if f > 1 else hole
        small_own = _reduced_hole(own, sw, sh) if f > 1 else own
        if small_own.sum() <= max(budget, 64.0) * 1.1:
            break
        f *= float(np.sqrt(small_own.sum() / max(budget, 64.0)))
    fx, fy = w / sw, h / sh
    small = cv2.resize(img, (sw, sh), interpolation=cv2.INTER_AREA) if f > 1 else img
    if small_hole.all():
        small_hole = cv2.resize(hole.astype(np.uint8), (sw, sh), interpolation=cv2.INTER_NEAREST) > 0
    lab = cv2.cvtColor(small, cv2.COLOR_RGB2Lab)
    dst = lab.copy()
    cv2.xphoto.inpaint(lab, (~small_hole).astype(np.uint8) * 255, dst, cv2.xphoto.INPAINT_SHIFTMAP)
    coarse = cv2.cvtColor(dst, cv2.COLOR_Lab2RGB)
    shifts = recover_shifts(lab, dst, small_hole)
    out = img.copy()
    if f > 1:
        out[hole] = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)[hole]
    else:
        out[hole] = coarse[hole]
    ys, xs = np.nonzero(hole)
    sy = np.minimum((ys / fy).astype(int), sh - 1)
    sx = np.minimum((xs / fx).astype(int), sw - 1)
    d = shifts[sy, sx]
    offsets = np.zeros((h, w, 2), np.int64)
    none = d[:, 0] == NO_SHIFT
    offsets[ys, xs, 0] = np.where(none, NO_SHIFT, np.round(d[:, 0] * fy).astype(np.int64))
    offsets[ys, xs, 1] = np.where(none, NO_SHIFT, np.round(d[:, 1] * fx).astype(np.int64))
    unfilled = np.zeros((h, w), bool)
    unfilled[ys, xs] = ~np.any(dst[sy, sx], axis=-1) & small_hole[sy, sx]
    return out, offsets, unfilled


def _reduced_hole(hole: np.ndarray, sw: int, sh: int) -> np.ndarray:
    """``hole`` at ``sw`` × ``sh``: a reduced pixel is unknown if any full-resolution pixel under it is, and
    one more ring, so that every pixel a shift copies from at full resolution is known there too."""
    return dilate(cv2.resize(hole.astype(np.float32), (sw, sh), interpolation=cv2.INTER_AREA) > 0, 1)


def match_shading(img: np.ndarray, filled: np.ndarray, hole: np.ndarray, sigma: float, depth: float,
                   trust: float) -> np.ndarray:
    """``filled`` (h, w, 3) uint8 with the low frequencies of its ``hole`` pixels shifted so that patches
    copied from brighter or darker parts of the surface meet the hole's edge, and each other, without a seam.

    First the step the fill makes at the hole's border: per border pixel, the photo's low-pass over the
    known surface just outside it (:data:`SHADING_STEP`; border pixels that are not the surface,
    :func:`odd_border`, left out) less the fill's low-pass over the hole just inside it, carried inward by a
    smooth (Telea) fill of those steps alone. Where the fill continues the surface (a horizon, copied from
    beside the hole at its own height) the two take the same mix and the step is ~0, so nothing of the
    surface's colours is spread across the hole. Then the patches inside that never touch the border (a
    darker piece of sky in the rocket's column) are pulled towards a smooth fill of the border's colours,
    but only where that smooth fill is smooth: where it changes faster than ``trust`` levels per pixel it is
    the smear of an edge of the surface, not its shading, and the fill keeps its own colours there.
    ``sigma`` (pixels) smooths both corrections over the hole, ``depth`` (pixels) is how far into the hole
    they fade (1/e)."""
    h, w = hole.shape
    scale = min(1.0, 160.0 / max(h, w))
    size = (max(2, round(w * scale)), max(2, round(h * scale)))
    cover = cv2.resize(hole.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    small_img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    small_fill = cv2.resize(filled, size, interpolation=cv2.INTER_AREA).astype(np.float32)
    region = cover > 0
    inside = cover >= 0.999  # reduced pixels of fill alone
    odd = odd_border(cv2.cvtColor(small_img, cv2.COLOR_RGB2BGR), region)
    known = ~region & ~odd
    kk, ki = known.astype(np.float32), inside.astype(np.float32)
    wk, wi = blur(kk, SHADING_STEP), blur(ki, SHADING_STEP)
    photo_low = blur(small_img.astype(np.float32) * kk[..., None], SHADING_STEP) / np.maximum(wk, 1e-3)[..., None]
    fill_low = blur(small_fill * ki[..., None], SHADING_STEP) / np.maximum(wi, 1e-3)[..., None]
    # the border: fill pixels next to the surface, with enough of both sides under the low-pass to measure
    border = inside & within(~inside, 1.5) & (wk > 0.05) & (wi > 0.05)
    if not border.any():
        return filled
    step = photo_low - fill_low
    # spread from the border alone: the surface outside the hole has no step to give
    unknown = (~border).astype(np.uint8)
    spread = np.stack([cv2.inpaint(np.where(border, step[..., c], 0.0).astype(np.float32), unknown,
                                   INPAINT_RADIUS, cv2.INPAINT_TELEA) for c in range(3)], -1)
    # smoothed over the hole's own pixels only (outside it there is nothing to correct): a blur wider than a
    # thin hole (the rocket's column) would otherwise thin the correction by the surface it also takes in
    s = max(1.0, sigma * scale)
    r = region.astype(np.float32)
    r_blur = np.maximum(blur(r, s), 1e-3)[..., None]
    spread = blur(spread * r[..., None], s) / r_blur
    smooth = cv2.inpaint(small_img, (region | odd).astype(np.uint8), INPAINT_RADIUS,
                         cv2.INPAINT_TELEA).astype(np.float32)
    rest = blur((smooth - small_fill - spread) * r[..., None], s) / r_blur
    sm = blur(smooth, s)
    slope = np.hypot(cv2.Sobel(sm, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(sm, cv2.CV_32F, 0, 1, ksize=3)).max(-1)
    slope *= scale / 8.0  # levels per pixel of the window (a Sobel of a unit ramp is 8)
    # the part of the step beyond what the surface's own grain makes at the step's scale is a patch of
    # another brightness (the darker sky copied down the rocket's column, 25-35 levels under the sky beside
    # it): that part is carried unfaded; the rest, which on gravel or grass is the grain itself, fades.
    # Both low-passes are over the known surface alone: the hole's own pixels (dark where the normalised blur
    # has no weight) would read as grain all around it.
    wide = GRAIN_STEP * SHADING_STEP
    grain = photo_low - blur_over(small_img.astype(np.float32), kk, wide)
    ring = known & within(region, 2.0 * SHADING_STEP)
    # robust (median) so that a few bright lamps or edges in the ring do not count as the surface's grain
    noise = 1.4826 * np.median(np.abs(grain[ring]), axis=0) if ring.any() else np.zeros(3, np.float32)
    sure = np.sign(spread) * np.maximum(np.abs(spread) - STEP_NOISE * noise, 0.0)
    fade_part = spread - sure + np.clip(1.0 - slope / trust, 0.0, 1.0)[..., None] * rest
    fade_part = cv2.resize(fade_part, (w, h), interpolation=cv2.INTER_LINEAR)
    dist = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_L2, 5)
    corr = fade_part * np.exp(-dist / max(depth, 1.0))[..., None] + cv2.resize(sure, (w, h),
                                                                               interpolation=cv2.INTER_LINEAR)
    out = filled.astype(np.float32) + corr
    return np.where(hole[..., None], np.clip(out + 0.5, 0, 255), filled).astype(np.uint8)


#: Marks a reduced pixel whose shift could not be read back.
NO_SHIFT = -(1 << 30)


def recover_shifts(src: np.ndarray, dst: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """(h, w, 2) int (dy, dx): for each pixel of ``hole``, the offset of the known pixel of ``src`` that the
    shift-map result ``dst`` copied into it (:data:`NO_SHIFT` where none matches); 0 outside the hole.

    Offsets are voted for by exact colour matches between filled and known pixels; each filled pixel then
    takes the most-voted offset that reproduces it and its neighbours.
    """
    h, w = hole.shape
    shifts = np.zeros((h, w, 2), np.int64)
    hy, hx = np.nonzero(hole)
    if hy.size == 0:
        return shifts
    shifts[hy, hx] = NO_SHIFT
    key = colour_code(src)
    dkey = colour_code(dst)
    ky, kx = np.nonzero(~hole)
    kk = key[ky, kx]
    order = np.argsort(kk, kind="stable")
    kk, ky, kx = kk[order], ky[order], kx[order]
    rng = np.random.default_rng(0)
    sample = rng.choice(hy.size, min(hy.size, 3000), replace=False)
    fk = dkey[hy[sample], hx[sample]]
    lo = np.searchsorted(kk, fk, "left")
    n = np.searchsorted(kk, fk, "right") - lo
    keep = (n > 0) & (n <= 512)
    if not keep.any():
        return shifts
    counts = n[keep]
    owner = np.repeat(sample[keep], counts)
    start = np.repeat(lo[keep], counts) + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    dy = ky[start] - hy[owner]
    dx = kx[start] - hx[owner]
    code = (dy + h) * (2 * w + 1) + (dx + w)
    uniq, votes = np.unique(code, return_counts=True)
    top = uniq[np.argsort(-votes, kind="stable")[:MAX_SHIFTS]]
    best = np.full(hy.size, -1)
    best_score = np.zeros(hy.size, np.float32)
    target = dkey[hy, hx]
    for i, c in enumerate(top):
        cy, cx = int(c // (2 * w + 1) - h), int(c % (2 * w + 1) - w)
        qy, qx = hy + cy, hx + cx
        ok = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
        match = np.zeros(hy.size, bool)
        match[ok] = (~hole[qy[ok], qx[ok]]) & (key[qy[ok], qx[ok]] == target[ok])
        if not match.any():
            continue
        img = np.zeros((h, w), np.float32)
        img[hy[match], hx[match]] = 1.0
        score = cv2.boxFilter(img, -1, (3, 3), normalize=False)[hy, hx] * match
        better = score > best_score
        best[better] = i
        best_score[better] = score[better]
    found = best >= 0
    c = top[best[found]]
    shifts[hy[found], hx[found], 0] = c // (2 * w + 1) - h
    shifts[hy[found], hx[found], 1] = c % (2 * w + 1) - w
    return shifts
