"""A fill's fine detail matched to the surface around its hole, and the border pixels that are not that surface.

Patches copied from elsewhere bring the grain of wherever they came from; :func:`match_grain` scales the
fill's detail (and adds seeded noise where it is flat) so that its gradient is the surface's.
:func:`odd_border` finds what lies on the hole's border but is not the surface (another object's edge), so
that no smooth fill spreads it inward.
"""

from __future__ import annotations

import cv2
import numpy as np

from .pixels import INPAINT_RADIUS, blur, blur_over, dilate, gradient, within

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


def odd_border(bgr: np.ndarray, hole: np.ndarray, band: int = BORDER_BAND) -> np.ndarray:
    """(h, w) bool: the pixels along the border of ``hole`` (within ``band`` pixels of it) whose
    colour stands out from the border around them by more than :data:`BORDER_OUTLIER` (CIELAB, 8-bit units)
    and twice the border's typical difference: something on the surface that is not the surface (an unnamed
    sweet beside a named one, its orange half inside the hole), which a smooth fill from the border would
    otherwise spread into the hole as a glow. ``bgr`` (h, w, 3) uint8."""
    band = ~hole & within(hole, band)
    if band.sum() < 8:
        return np.zeros_like(hole)
    lab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab).astype(np.float32)
    sigma = max(2.0, 0.05 * float(max(hole.shape)))
    keep = band.copy()
    for _ in range(3):  # the outliers pull the reference towards them: leave them out and look again
        k = keep.astype(np.float32)
        ref = blur_over(lab, k, sigma)
        dev = np.linalg.norm(lab - ref, axis=-1)
        typical = float(np.median(dev[band]))
        keep = band & (dev <= max(BORDER_OUTLIER, 2.0 * typical))
    return band & ~keep


def _spread_into(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """(h, w) float32: ``values`` averaged over ``known`` pixels (a Gaussian :data:`GRAIN_SIGMA` × the diagonal
    wide) and carried beyond them by a smooth (Telea) fill, on a copy at most 160 pixels long."""
    h, w = values.shape
    sigma = max(2.0, GRAIN_SIGMA * float(np.hypot(h, w)))
    k = known.astype(np.float32)
    local = blur_over(values, k, sigma)
    scale = min(1.0, 160.0 / max(h, w))
    size = (max(2, round(w * scale)), max(2, round(h * scale)))
    unknown = cv2.resize((blur(k, sigma) < 0.05).astype(np.float32), size, interpolation=cv2.INTER_AREA) > 0
    small = cv2.resize(local, size, interpolation=cv2.INTER_AREA)
    top = max(float(small[~unknown].max()) if (~unknown).any() else 1.0, 1e-3)
    small8 = np.clip(small / top * 255.0 + 0.5, 0, 255).astype(np.uint8)  # Telea takes 8 bits
    spread = cv2.inpaint(small8, unknown.astype(np.uint8), INPAINT_RADIUS, cv2.INPAINT_TELEA).astype(np.float32)
    spread = cv2.resize(spread * (top / 255.0), (w, h), interpolation=cv2.INTER_LINEAR)
    return np.where(blur(k, sigma) < 0.05, spread, local).astype(np.float32)


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
    known = ~dilate(hole, 2) & dilate(hole, reach) & ~odd_border(cv2.cvtColor(img, cv2.COLOR_RGB2BGR), hole, reach)
    if not known.any():
        return filled
    target = _spread_into(gradient(grey_img), known)
    inside = hole & ~dilate(~hole, 1)
    own = _spread_into(gradient(grey_f), inside)
    # a fill whose grain is within GRAIN_BAND of the surface's keeps it: only the flat and the busy change
    target = np.clip(own, GRAIN_BAND[0] * target, GRAIN_BAND[1] * target)
    low = cv2.GaussianBlur(f, (0, 0), GRAIN_DETAIL)
    gain = np.clip(target / np.maximum(own, 1e-3), *GRAIN_GAIN)
    out = low + (f - low) * gain[..., None]
    # grain for what scaling cannot reach (a flat fill): noise whose gradient makes up the rest, in quadrature
    missing = np.minimum(np.sqrt(np.maximum(target ** 2 - (own * gain) ** 2, 0.0)), GRAIN_NOISE)
    noise = np.random.default_rng(0).normal(0.0, 1.0, hole.shape).astype(np.float32)
    noise -= cv2.GaussianBlur(noise, (0, 0), GRAIN_DETAIL)
    noise /= max(float(gradient(noise).mean()), 1e-6)
    out += (noise * missing)[..., None]
    # the two add only roughly in quadrature (the detail and the low-pass share some gradient): measure the
    # result and correct its detail once more
    grey_out = np.clip(out, 0, 255) @ np.float32([0.299, 0.587, 0.114])
    now = _spread_into(gradient(grey_out.astype(np.float32)), inside)
    out = low + (out - low) * np.clip(target / np.maximum(now, 1e-3), *GRAIN_GAIN)[..., None]
    # detail beyond white (or black) folds back into range instead of clipping: white paper is mostly at 255,
    # and its grain would otherwise be cut in half
    out = np.abs(255.0 - np.abs(255.0 - out))
    return np.where(hole[..., None], np.clip(out + 0.5, 0, 255), filled).astype(np.uint8)
