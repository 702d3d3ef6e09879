"""The background plate (the photo with the objects and their contact shadows removed) and per-object textures.

The hole left by the objects is filled by exemplar: OpenCV xphoto's shift-map
inpainting (He & Sun 2012) copies patches of the surface around the hole into
it, so the fill keeps the surface's grain instead of the radial smear of a
diffusion fill (Telea, kept as ``method="telea"`` for comparison). Shift-map
is slow at full resolution, so each hole is filled in a reduced window around
it; the shifts it chose are read back from the result (every filled pixel is
a copy of a known one) and applied at full resolution. The fill's low
frequencies are then shifted by the step it makes against the photo along the
hole's border, carried inward (so a horizon the exemplar continued stays where
it is), and pulled towards a smooth interpolation of the border only where that
interpolation is flat (leaving out border pixels that are not the surface); its
fine detail is matched to the gradient of the surface around the hole.
"""

from __future__ import annotations

import cv2
import numpy as np

#: Inpainting radius of OpenCV's Telea method, pixels.
INPAINT_RADIUS = 5
#: Longest side at which large holes are inpainted by Telea; the fill is then upsampled.
INPAINT_MAX_SIDE = 480
#: Pixels of the reduced window in which shift-map searches, and most pixels of all holes together at the
#: reduced size. Below about 10000 the shifts read back are too coarse to carry a surface's grain (a
#: desk's wood came out as a flat disc where a ball stood); 12000 fills the motorcycle's 196000-pixel
#: hole in about 2 s on one core.
EXEMPLAR_PIXELS = 150 * 150
EXEMPLAR_HOLE_PIXELS = 12000
#: Context kept around each hole for the exemplar search, as a fraction of the hole's larger side.
EXEMPLAR_CONTEXT = 0.6
#: Most distinct shifts read back from one shift-map result (it uses a few dozen dominant offsets).
MAX_SHIFTS = 128
#: Width of the low-pass by which the exemplar fill's shading is matched to its border, as a fraction
#: of the hole's narrower side (at least 3 pixels), and the depth into the hole over which that match fades
#: (1/e), as a fraction of the image diagonal (both corrections of :func:`_match_shading` are smoothed by it
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
#: makes against the photo is measured along the hole's border (:func:`_match_shading`). The match used to
#: take the fill's low frequencies from a smooth fill of the border's colours, which across a horizon is
#: a smear of the two surfaces: where the water example's block stood the fill was 12-29 levels lighter and
#: bluer than the floor beside it in the 40 rows below the horizon, though the exemplar had copied the
#: horizon right. Matching the step instead leaves those rows within 3 levels. Measured with the fill's
#: own low-pass as wide as the shading's (:data:`SHADING_SIGMA`), a surface that brightens across the border
#: (the motorcycle's floor towards the camera) read as a step and darkened the fill (its colour 8.6 levels
#: off its ring); at 3 pixels, 3.0.
SHADING_STEP = 3.0
#: How much of the border step :func:`_match_shading` carries across the hole without the fade
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
#: Border pixels left out of the smooth fill the shading is matched to (:func:`odd_border`): the band's width at
#: the reduced size (pixels) and the colour difference (CIELAB, 8-bit) from the border around them.
BORDER_BAND = 3
BORDER_OUTLIER = 30.0
#: Grain matching (:func:`match_grain`): the scale of the surface's gradient is averaged over (Gaussian sigma,
#: fraction of the window's diagonal), the detail scaled (Gaussian high-pass sigma, pixels), and the range
#: of that scaling.
GRAIN_SIGMA = 0.015
GRAIN_DETAIL = 1.5
GRAIN_GAIN = (0.3, 2.0)
GRAIN_BAND = (0.7, 1.4)
#: Most gradient (Sobel magnitude, levels) the added noise may bring: enough for the grain of paper or sky, where a
#: fill came out flat; more reads as speckle, not texture (beside a sweet's dark edge the target is 30 and more).
GRAIN_NOISE = 6.0
#: A pixel near an object's foot is in its contact shadow when it is darker than this fraction of the
#: surface's brightness around it.
SHADOW_RATIO = 0.85
#: The shadow's soft edge: pixels joined to a contact shadow and darker than this fraction of the surface
#: around them go with it, so that the fill's border lies on lit surface, not on a dark rim of penumbra.
PENUMBRA_RATIO = 0.96
#: Beyond that, the penumbra also takes pixels joined to it that are darker than the surface at all and whose
#: lightness gradient (smoothed over a pixel) is more than this many times the surface's around them. On
#: white paper a sweet's shade fades from 250 to 254 in steps of one level (a Sobel gradient of 4 against the
#: paper's 1.2); the seam that lay across those steps carried them into the plate as an outline (candy_5's
#: border 1.48× its ring, the photo's gradient on those border pixels 3.4× the ring's); taking them, 1.23×.
PENUMBRA_GRADIENT = 2.0

#: How far below an object its contact shadow may reach, as a fraction of the object's height in the photo.
SHADOW_REACH = 0.25
#: Width of the seam where the fill fades into the photo, as a fraction of the image diagonal (at least
#: 4 pixels): the hole grows by it and, across it, the plate goes from the photo to the fill. Two textures
#: that meet on one pixel show as an outline (the gradient along a desk ball's hole was 2.2× the wood's
#: around it); faded over about 5 pixels they meet without one (1.0×). At 0.006 the rocket's narrow column
#: still showed its outline (border 1.46× the sky's): its patches are steps of a sky that darkens upward,
#: and 5 pixels did not hide them; from 0.009 to 0.012 its border is 1.21× to 0.95× (0.010: 1.08×; the
#: motorcycle's 1.06×, the desk's 0.94×).
FEATHER = 0.010

METHODS = ("exemplar", "telea")


def background_plate(photo: np.ndarray, masks, dilation: float, method: str = "exemplar",
                     shadows: bool = True, sources: np.ndarray | None = None) -> np.ndarray:
    """The photo with every object (and, with ``shadows``, its contact shadow) filled in, (H, W, 3) uint8.

    ``dilation`` widens each mask by that fraction of the image diagonal, so that soft edges go too.
    Outside the hole (:func:`plate_hole`) the plate is the photo, pixel for pixel. ``sources``: (H, W, 2)
    int32, filled with -1 by the caller; the exemplar fill writes there, for each pixel of the hole it copied,
    the (y, x) of the photo's pixel it copied from (:func:`carry_plate` takes the fill's detail from there).
    """
    hole = plate_hole(photo, masks, dilation, shadows)
    return fill_hole(photo, hole, method, feather_px(photo.shape), sources)


def feather_px(shape) -> int:
    """Width in pixels of the seam :func:`plate_hole` adds around the hole of an image of ``shape`` (H, W, ...)."""
    return max(4, int(round(FEATHER * np.hypot(shape[0], shape[1]))))


def fill_hole(photo: np.ndarray, hole: np.ndarray, method: str = "exemplar", feather: int = 0,
              sources: np.ndarray | None = None) -> np.ndarray:
    """``photo`` (H, W, 3) uint8 RGB with the pixels of ``hole`` (H, W) bool filled by ``method``; with
    ``feather`` > 0 the hole's outer ``feather`` pixels blend from the photo (at its edge) to the fill.
    ``sources``: as :func:`background_plate` takes it."""
    filled = _fill_hole(photo, hole, method, sources)
    if feather <= 0 or not np.any(hole) or np.all(hole):
        return filled
    inside = cv2.distanceTransform(np.asarray(hole, np.uint8), cv2.DIST_L2, 5)
    a = np.clip(inside / (feather + 1.0), 0.0, 1.0)[..., None]
    blend = photo.astype(np.float32) * (1.0 - a) + filled.astype(np.float32) * a
    return np.where(np.asarray(hole, bool)[..., None], np.clip(blend + 0.5, 0, 255), photo).astype(np.uint8)


def _fill_hole(photo: np.ndarray, hole: np.ndarray, method: str, sources: np.ndarray | None = None) -> np.ndarray:
    if method not in METHODS:
        raise ValueError(f"unknown fill method {method!r} (known: {', '.join(METHODS)})")
    hole = np.asarray(hole, bool)
    if not hole.any():
        return photo.copy()
    if hole.all():  # nothing to copy from or to diffuse
        return np.broadcast_to(photo.reshape(-1, 3).mean(0).astype(np.uint8), photo.shape).copy()
    if method == "telea":
        return fill_telea(photo, hole)
    return fill_exemplar(photo, hole, sources)


def plate_hole(photo: np.ndarray, masks, dilation: float, shadows: bool = True) -> np.ndarray:
    """(H, W) bool: the pixels the plate replaces, every mask dilated by ``dilation`` × the diagonal,
    plus (with ``shadows``) the contact shadow found under each object (:func:`contact_shadow`), and the
    seam (:data:`FEATHER`) around all of it, over which the fill fades into the photo."""
    h, w = photo.shape[:2]
    union = np.zeros((h, w), bool)
    for m in masks:
        union |= np.asarray(m, bool)
    hole = _dilate(union, int(round(dilation * np.hypot(h, w))))
    if shadows:
        lum = cv2.cvtColor(photo, cv2.COLOR_RGB2Lab)[..., 0].astype(np.float32)
        for m in masks:
            hole |= contact_shadow(lum, np.asarray(m, bool), hole)
    return _dilate(hole, feather_px(photo.shape)) if hole.any() else hole


def contact_shadow(lum: np.ndarray, mask: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """(H, W) bool: the dark patch on the surface just under the object ``mask``.

    ``lum`` (H, W) is the photo's lightness; ``hole`` what is already removed. Candidates lie below the
    middle of the object and within :data:`SHADOW_REACH` of its height from it; a candidate is shadow
    where it is darker than :data:`SHADOW_RATIO` × the surface around it (the lightness outside the
    candidates and the hole, averaged with a Gaussian as wide as the reach), and only the dark
    patches that touch the object (through the hole) count. The shadow then grows through its penumbra
    (:data:`PENUMBRA_RATIO`, :data:`PENUMBRA_GRADIENT`), so that the hole's edge lies where the shade has
    faded into the surface.
    """
    ys, xs = np.nonzero(mask)
    if ys.size == 0:
        return np.zeros_like(mask)
    h, w = mask.shape
    height = ys.max() - ys.min() + 1
    reach = int(np.clip(SHADOW_REACH * height, 3, 0.15 * np.hypot(h, w)))
    near_all = _within(mask, reach)
    near = near_all.copy()
    near[: (ys.min() + ys.max()) // 2] = False
    band = near & ~hole
    if not band.any():
        return np.zeros_like(mask)
    known = (~(band | hole)).astype(np.float32)
    sigma = max(2.0, float(reach))
    weight = _blur(known, sigma)
    surround = _blur(lum * known, sigma) / np.maximum(weight, 1e-3)
    # a contact shadow darkens the surface smoothly: compare the lightness averaged over a few pixels, so
    # that the dark grains of a textured surface (gravel, grass) do not count
    smooth = _blur(lum, max(1.0, reach / 6.0))
    dark = band & (smooth < SHADOW_RATIO * surround) & (weight > 0.05)
    if not dark.any():
        return np.zeros_like(mask)
    dark = cv2.morphologyEx(dark.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)) > 0
    seed = _dilate(hole & near_all, 2)
    n, labels = cv2.connectedComponents((dark | seed).astype(np.uint8), connectivity=8)
    touching = np.unique(labels[seed & (labels > 0)])
    shadow = np.isin(labels, touching) & dark
    if shadow.any():  # grow it through its penumbra
        soft = band & (smooth < PENUMBRA_RATIO * surround) & (weight > 0.05)
        # and, darker than the surface at all, where its lightness still falls faster than the surface's own
        # grain: on white paper a sweet's shade fades in steps of one level, each a line the seam would show
        g = _gradient(_blur(lum, 1.0))
        surface_g = _blur(g * known, sigma) / np.maximum(weight, 1e-3)
        soft |= band & (smooth < surround) & (g > PENUMBRA_GRADIENT * surface_g) & (weight > 0.05)
        n, labels = cv2.connectedComponents((soft | shadow).astype(np.uint8), connectivity=8)
        shadow |= np.isin(labels, np.unique(labels[shadow & (labels > 0)])) & soft
    return _dilate(shadow, 2) & near


def fill_telea(photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """OpenCV Telea (diffusion) fill of ``hole``; large photos are filled smaller and upsampled."""
    h, w = hole.shape
    bgr = cv2.cvtColor(photo, cv2.COLOR_RGB2BGR)
    hole8 = hole.astype(np.uint8)
    scale = min(1.0, INPAINT_MAX_SIDE / max(h, w))
    if scale < 1.0:
        small = cv2.resize(bgr, (max(1, round(w * scale)), max(1, round(h * scale))), interpolation=cv2.INTER_AREA)
        small_hole = cv2.resize(hole8, small.shape[1::-1], interpolation=cv2.INTER_NEAREST)
        small_hole = cv2.dilate(small_hole, np.ones((3, 3), np.uint8))
        filled = cv2.resize(cv2.inpaint(small, small_hole, INPAINT_RADIUS, cv2.INPAINT_TELEA), (w, h),
                            interpolation=cv2.INTER_CUBIC)
    else:
        filled = cv2.inpaint(bgr, hole8, INPAINT_RADIUS, cv2.INPAINT_TELEA)
    out = np.where(hole[..., None], filled, bgr)
    return cv2.cvtColor(out, cv2.COLOR_BGR2RGB)


def fill_exemplar(photo: np.ndarray, hole: np.ndarray, sources: np.ndarray | None = None) -> np.ndarray:
    """Shift-map (exemplar) fill of ``hole``, one window per connected part of it; ``sources``: as
    :func:`background_plate` takes it."""
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
            win_hole = hole  # no surface around this part: use the whole photo
            x0, y0, x1, y1 = 0, 0, w, h
        copied = None if sources is None else np.full((y1 - y0, x1 - x0, 2), -1, np.int32)
        filled = _exemplar_window(photo[y0:y1, x0:x1], win_hole, min(bw, bh), SHADING_DEPTH * np.hypot(h, w),
                                  EXEMPLAR_HOLE_PIXELS * float(stats[k, 4]) / total, copied)
        own = labels[y0:y1, x0:x1] == k
        out[y0:y1, x0:x1][own] = filled[own]
        if sources is not None:
            found = own & (copied[..., 0] >= 0)
            sources[y0:y1, x0:x1][found] = copied[found] + np.int32([y0, x0])
    return out


def _exemplar_window(img: np.ndarray, hole: np.ndarray, size: int, depth: float, budget: float,
                     sources: np.ndarray | None = None) -> np.ndarray:
    """Fill ``hole`` of the window ``img`` (h, w, 3) RGB: shift-map on a copy reduced until the hole has
    at most ``budget`` pixels (and the window :data:`EXEMPLAR_PIXELS`), its shifts applied at full resolution;
    ``size`` (pixels, the hole's narrower side) sets the shading match's low-pass (:data:`SHADING_SIGMA`)."""
    h, w = hole.shape
    f = max(1.0, float(np.sqrt(h * w / EXEMPLAR_PIXELS)), float(np.sqrt(hole.sum() / max(budget, 64.0))))
    for _ in range(4):
        sw, sh = max(8, round(w / f)), max(8, round(h / f))
        small_hole = _reduced_hole(hole, sw, sh) if f > 1 else hole
        if small_hole.sum() <= max(budget, 64.0) * 1.1:
            break
        f *= float(np.sqrt(small_hole.sum() / max(budget, 64.0)))
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
    qy = ys + np.round(d[:, 0] * fy).astype(int)
    qx = xs + np.round(d[:, 1] * fx).astype(int)
    ok = (d[:, 0] != NO_SHIFT) & (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
    ok[ok] &= ~hole[qy[ok], qx[ok]]
    out[ys[ok], xs[ok]] = img[qy[ok], qx[ok]]
    if sources is not None:  # where each copied pixel came from, in the window (fill_exemplar moves it)
        sources[ys[ok], xs[ok]] = np.stack([qy[ok], qx[ok]], 1)
    out = _match_shading(img, out, hole, max(3.0, SHADING_SIGMA * size), depth, SHADING_TRUST)
    return match_grain(img, out, hole)


def odd_border(bgr: np.ndarray, hole: np.ndarray, band: int = BORDER_BAND) -> np.ndarray:
    """(h, w) bool: the pixels along the border of ``hole`` (within ``band`` pixels of it) whose
    colour stands out from the border around them by more than :data:`BORDER_OUTLIER` (CIELAB, 8-bit units)
    and twice the border's typical difference: something on the surface that is not the surface (an unnamed
    sweet beside a named one, its orange half inside the hole), which a smooth fill from the border would
    otherwise spread into the hole as a glow. ``bgr`` (h, w, 3) uint8."""
    band = ~hole & _within(hole, band)
    if band.sum() < 8:
        return np.zeros_like(hole)
    lab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab).astype(np.float32)
    sigma = max(2.0, 0.05 * float(max(hole.shape)))
    keep = band.copy()
    for _ in range(3):  # the outliers pull the reference towards them: leave them out and look again
        k = keep.astype(np.float32)
        ref = _blur_over(lab, k, sigma)
        dev = np.linalg.norm(lab - ref, axis=-1)
        typical = float(np.median(dev[band]))
        keep = band & (dev <= max(BORDER_OUTLIER, 2.0 * typical))
    return band & ~keep


def _gradient(grey: np.ndarray) -> np.ndarray:
    """(h, w) float32 Sobel gradient magnitude of ``grey`` (the measure ``bench look`` holds a fill to)."""
    return np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3))


def _spread_into(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """(h, w) float32: ``values`` averaged over ``known`` pixels (a Gaussian :data:`GRAIN_SIGMA` × the diagonal
    wide) and carried beyond them by a smooth (Telea) fill, on a copy at most 160 pixels long."""
    h, w = values.shape
    sigma = max(2.0, GRAIN_SIGMA * float(np.hypot(h, w)))
    k = known.astype(np.float32)
    local = _blur_over(values, k, sigma)
    scale = min(1.0, 160.0 / max(h, w))
    size = (max(2, round(w * scale)), max(2, round(h * scale)))
    unknown = cv2.resize((_blur(k, sigma) < 0.05).astype(np.float32), size, interpolation=cv2.INTER_AREA) > 0
    small = cv2.resize(local, size, interpolation=cv2.INTER_AREA)
    top = max(float(small[~unknown].max()) if (~unknown).any() else 1.0, 1e-3)
    small8 = np.clip(small / top * 255.0 + 0.5, 0, 255).astype(np.uint8)  # Telea takes 8 bits
    spread = cv2.inpaint(small8, unknown.astype(np.uint8), INPAINT_RADIUS, cv2.INPAINT_TELEA).astype(np.float32)
    spread = cv2.resize(spread * (top / 255.0), (w, h), interpolation=cv2.INTER_LINEAR)
    return np.where(_blur(k, sigma) < 0.05, spread, local).astype(np.float32)


def match_grain(img: np.ndarray, filled: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``filled`` (h, w, 3) uint8 with the fine detail of its ``hole`` pixels scaled so that their gradient
    matches the surface's around the hole, and grain added where the fill is flatter than that surface.

    The exemplar's patches bring the grain of wherever they came from: shelf edges copied onto a garage
    floor are busier than the floor (2× its gradient), a hole on white paper came out flatter than the
    paper's own noise (0.1×). The target, per pixel of the hole, is the mean gradient magnitude of the known
    surface near the hole's border (:data:`GRAIN_SIGMA`), carried inward by a smooth fill; the fill's detail
    (above :data:`GRAIN_DETAIL` pixels) is scaled towards it within :data:`GRAIN_GAIN`, and what a flat fill
    still lacks is made up by seeded noise of the surface's amplitude. Low frequencies (shading, colour)
    are left as they are.
    """
    hole = np.asarray(hole, bool)
    if not hole.any() or hole.all():
        return filled
    f = filled.astype(np.float32)
    grey_img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32)
    grey_f = cv2.cvtColor(filled, cv2.COLOR_RGB2GRAY).astype(np.float32)
    # the surface's gradient, away from the hole's own edge (an object's outline lies just inside it)
    reach = max(4, int(round(2 * GRAIN_SIGMA * float(np.hypot(*hole.shape)))))
    known = ~_dilate(hole, 2) & _dilate(hole, reach) & ~odd_border(cv2.cvtColor(img, cv2.COLOR_RGB2BGR), hole, reach)
    if not known.any():
        return filled
    target = _spread_into(_gradient(grey_img), known)
    inside = hole & ~_dilate(~hole, 1)
    own = _spread_into(_gradient(grey_f), inside)
    # a fill whose grain is within GRAIN_BAND of the surface's keeps it: only the flat and the busy change
    target = np.clip(own, GRAIN_BAND[0] * target, GRAIN_BAND[1] * target)
    low = cv2.GaussianBlur(f, (0, 0), GRAIN_DETAIL)
    gain = np.clip(target / np.maximum(own, 1e-3), *GRAIN_GAIN)
    out = low + (f - low) * gain[..., None]
    # grain for what scaling cannot reach (a flat fill): noise whose gradient makes up the rest, in quadrature
    missing = np.minimum(np.sqrt(np.maximum(target ** 2 - (own * gain) ** 2, 0.0)), GRAIN_NOISE)
    noise = np.random.default_rng(0).normal(0.0, 1.0, hole.shape).astype(np.float32)
    noise -= cv2.GaussianBlur(noise, (0, 0), GRAIN_DETAIL)
    noise /= max(float(_gradient(noise).mean()), 1e-6)
    out += (noise * missing)[..., None]
    # the two add only roughly in quadrature (the detail and the low-pass share some gradient): measure the
    # result and correct its detail once more
    grey_out = np.clip(out, 0, 255) @ np.float32([0.299, 0.587, 0.114])
    now = _spread_into(_gradient(grey_out.astype(np.float32)), inside)
    out = low + (out - low) * np.clip(target / np.maximum(now, 1e-3), *GRAIN_GAIN)[..., None]
    # detail beyond white (or black) folds back into range instead of clipping: white paper is mostly at 255,
    # and its grain would otherwise be cut in half
    out = np.abs(255.0 - np.abs(255.0 - out))
    return np.where(hole[..., None], np.clip(out + 0.5, 0, 255), filled).astype(np.uint8)


def _reduced_hole(hole: np.ndarray, sw: int, sh: int) -> np.ndarray:
    """``hole`` at ``sw`` × ``sh``: a reduced pixel is unknown if any full-resolution pixel under it is, and
    one more ring, so that every pixel a shift copies from at full resolution is known there too."""
    return _dilate(cv2.resize(hole.astype(np.float32), (sw, sh), interpolation=cv2.INTER_AREA) > 0, 1)


def _match_shading(img: np.ndarray, filled: np.ndarray, hole: np.ndarray, sigma: float, depth: float,
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
    wk, wi = _blur(kk, SHADING_STEP), _blur(ki, SHADING_STEP)
    photo_low = _blur(small_img.astype(np.float32) * kk[..., None], SHADING_STEP) / np.maximum(wk, 1e-3)[..., None]
    fill_low = _blur(small_fill * ki[..., None], SHADING_STEP) / np.maximum(wi, 1e-3)[..., None]
    # the border: fill pixels next to the surface, with enough of both sides under the low-pass to measure
    border = inside & _within(~inside, 1.5) & (wk > 0.05) & (wi > 0.05)
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
    r_blur = np.maximum(_blur(r, s), 1e-3)[..., None]
    spread = _blur(spread * r[..., None], s) / r_blur
    smooth = cv2.inpaint(small_img, (region | odd).astype(np.uint8), INPAINT_RADIUS,
                         cv2.INPAINT_TELEA).astype(np.float32)
    rest = _blur((smooth - small_fill - spread) * r[..., None], s) / r_blur
    sm = _blur(smooth, s)
    slope = np.hypot(cv2.Sobel(sm, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(sm, cv2.CV_32F, 0, 1, ksize=3)).max(-1)
    slope *= scale / 8.0  # levels per pixel of the window (a Sobel of a unit ramp is 8)
    # the part of the step beyond what the surface's own grain makes at the step's scale is a patch of
    # another brightness (the darker sky copied down the rocket's column, 25-35 levels under the sky beside
    # it): that part is carried unfaded; the rest, which on gravel or grass is the grain itself, fades.
    # Both low-passes are over the known surface alone: the hole's own pixels (dark where the normalised blur
    # has no weight) would read as grain all around it.
    wide = GRAIN_STEP * SHADING_STEP
    grain = photo_low - _blur_over(small_img.astype(np.float32), kk, wide)
    ring = known & _within(region, 2.0 * SHADING_STEP)
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
    key = _pack(src)
    dkey = _pack(dst)
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


def _pack(img: np.ndarray) -> np.ndarray:
    """(h, w) int64 key of each pixel's three 8-bit channels."""
    a = img.astype(np.int64)
    return (a[..., 0] << 16) | (a[..., 1] << 8) | a[..., 2]


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of float32 ``img`` by ``sigma`` pixels; wide blurs are done on a reduced copy (same result
    to within the reduction's interpolation, a fraction of the time)."""
    img = np.asarray(img, np.float32)
    k = int(sigma // 4)
    if k < 2:
        return cv2.GaussianBlur(img, (0, 0), sigma)
    h, w = img.shape[:2]
    small = cv2.resize(img, (max(1, w // k), max(1, h // k)), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / k)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


def _blur_over(img: np.ndarray, weight: np.ndarray, sigma: float) -> np.ndarray:
    """``img`` (h, w) or (h, w, C) blurred by ``sigma`` pixels over the pixels that ``weight`` (h, w) float32
    holds alone: what lies outside them (a hole, an object) takes no part in the mean."""
    total = np.maximum(_blur(weight, sigma), 1e-3)
    if img.ndim == 3:
        return _blur(img * weight[..., None], sigma) / total[..., None]
    return _blur(img * weight, sigma) / total


def _within(mask: np.ndarray, r: float) -> np.ndarray:
    """Pixels within ``r`` pixels of ``mask`` (a distance transform: fast for any ``r``)."""
    return cv2.distanceTransform((~np.asarray(mask, bool)).astype(np.uint8), cv2.DIST_L2, 5) <= r


def _dilate(mask: np.ndarray, r: int) -> np.ndarray:
    """``mask`` grown by a disc of radius ``r`` pixels."""
    if r <= 0:
        return np.asarray(mask, bool).copy()
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(np.asarray(mask, np.uint8), kernel) > 0


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


#: Rows of the photo :func:`carry_plate` works on at once: its float copies are of a strip, not of the photo.
CARRY_ROWS = 256


def carry_plate(photo: np.ndarray, work, small_photo: np.ndarray, small_plate: np.ndarray,
                sources: np.ndarray | None = None) -> np.ndarray:
    """The plate at the photo's size, (H, W, 3) uint8, from the plate filled at the working resolution.

    ``work`` is the :class:`~.working.Working` that took ``photo`` to ``small_photo``; ``small_plate`` is the
    plate of ``small_photo`` (the photo wherever it is not filled); ``sources`` what its exemplar fill copied
    from (:func:`background_plate`). Outside the working hole the plate is the photo, pixel for pixel. Inside,
    the fill's low frequencies (its shading, matched to the border at the working resolution) come from the
    small plate, upsampled, and the detail finer than a working pixel from the photo's own pixels: from where
    the exemplar copied each patch (the offset scaled up), blended across the seam (:data:`FEATHER`) into the
    photo's own detail where the working fill blends into the photo. So the fill keeps the surface's grain at
    full size for the cost of a few passes over the hole, not a search at full size.
    """
    changed = np.any(small_plate != small_photo, axis=2)
    out = photo.copy()
    if not changed.any():
        return out
    H, W = photo.shape[:2]
    fx, fy = work.fx, work.fy
    # how far each working pixel of the hole is the fill rather than the photo: the seam's own blend
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
