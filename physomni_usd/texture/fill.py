"""The background plate: the photo with the objects (and their contact shadows) removed and the hole filled.

Owns what the plate replaces (:func:`plate_hole`: the masks, widened, each object's contact shadow and a
seam around all of it) and the choice of fill (:data:`METHODS`): the faded blend (:func:`fill_faded`, the
default: the blend's copies faded into their local colour with the depth into the hole, part of their low
frequencies Telea's, the surface's grain laid back), the blend (``blend.py``: the exemplar's copies laid softly
where they meet, kept only where they look like the surface, a smooth fill elsewhere), the exemplar alone
(``exemplar.py``: patches of the surface around the hole copied into it, with hard seams) or OpenCV's Telea
diffusion (kept as ``method="telea"`` for comparison). Across the seam the fill fades into the photo; the faded
fill and the blend then keep no colour the surroundings lack (:func:`~.blend.cap_colours`, after the seam);
outside the hole the plate is the photo, pixel for pixel, and so is the hole's widening beyond the masks' edge
(:data:`KEPT_EDGE`) wherever the photo there looks like the surface around it (:func:`_world_back`). Given the
ground's camera, the faded fill fills the hole's part on the floor in a top-down view of the floor (``floor.py``),
where a pattern seen in perspective is regular, up to a wall's foot.
"""

from __future__ import annotations

import cv2
import numpy as np

from .blend import cap_colours, fill_blend
from .exemplar import fill_exemplar
from .floor import TOP_DOWN_DEG, fill_on_ground, off_floor
from .pixels import INPAINT_RADIUS, blur, blur_over, dilate, gradient, within

#: Longest side at which large holes are inpainted by Telea; the fill is then upsampled.
INPAINT_MAX_SIDE = 480
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
#: The surface's lightness around a candidate is the mean of the pixels outside the candidates and the hole
#: in a Gaussian window a reach wide, read where they make at least this share of the window; under the
#: object (between its outermost columns) where they make at least :data:`KNOWN_SHARE_UNDER`. Under a large
#: object its band and hole fill most of the window: under the motorcycle 1.4-3.4 % of it is known floor
#: (some hundreds of pixels); at 5 % there too, its floor shadow, half as light as the floor, stayed in the
#: plate and was left behind as a hard patch once the bike moved. Beside it, the floor as dark is as likely
#: another thing's shade (the bench's): taken at 1 %, and filled lit, it was 18 levels lighter than the
#: floor around it. The penumbra grows from the shadow only where the surface is read at KNOWN_SHARE: grown
#: at 1 % under the bike too it reached the dark floor right of its front wheel, and the lit fill there was
#: 9.8 levels off the floor beside it (bench look allows 8); grown at 5 % the bike's area passes
#: (tests/test_look.py) and its floor shadow still goes (tests/test_slab_texture.py).
KNOWN_SHARE = 0.05
KNOWN_SHARE_UNDER = 0.01
#: Width of the seam where the fill fades into the photo, as a fraction of the image diagonal (at least
#: 4 pixels): the hole grows by it and, across it, the plate goes from the photo to the fill. Two textures
#: that meet on one pixel show as an outline (the gradient along a desk ball's hole was 2.2× the wood's
#: around it); faded over about 5 pixels they meet without one (1.0×). At 0.006 the rocket's narrow column
#: still showed its outline (border 1.46× the sky's): its patches are steps of a sky that darkens upward,
#: and 5 pixels did not hide them; from 0.009 to 0.012 its border is 1.21× to 0.95× (0.010: 1.08×; the
#: motorcycle's 1.06×, the desk's 0.94×).
FEATHER = 0.010

#: The plate fills the hole (its sources then hold none of an object's soft edge) but shows the fill only over
#: the masks widened by this fraction of the image diagonal (at least KEPT_EDGE_MIN pixels) and the contact
#: shadows, fading back into the photo across the seam (:data:`FEATHER`) beyond them: the rest of the hole's
#: widening is the world, and filled it changed once its object moved although nothing there did. The pushed
#: motorcycle's last frame (``bench.look.still_changes``): 3,206 pixels more than 30 levels off frame 0 where
#: nothing moved with the whole widening filled (the shelves round its mirrors and handlebar, blurred), 218 with
#: the photo back where it is like the fill. Drawn as a pillow the fallen bike lies on the floor and uncovers the
#: widening beyond the seam where the fill missed the world (shelf posts, a box's edge): 809 there, 259 with the
#: photo back beyond the kept edge's seam whatever the fill (:func:`_world_back`).
KEPT_EDGE = 0.004
KEPT_EDGE_MIN = 2
#: Beyond that edge a pixel of the photo is the world where it lies off the fill by at most WORLD_LIKE[0] times
#: the spread of the photo's colours around the hole (plus WORLD_NOISE levels), and something the mask missed
#: from WORLD_LIKE[1] times: on a plain floor the bike's dark rims lie many spreads off, on busy shelves the
#: shelves' own pixels lie within one or two.
WORLD_LIKE = (1.5, 3.0)
WORLD_NOISE = 4.0
#: A pixel unlike the surface around the hole (the other side of WORLD_LIKE) stays filled out to the seam's
#: outer edge, giving way to the photo there over a ramp that ends RIM_RAMP[0] px beyond the seam's width and is
#: RIM_RAMP[1] px long (:func:`_world_back`).
RIM_RAMP = (2.5, 3.0)

#: The faded fill (:func:`fill_faded`): how wide its copies are averaged for each pixel of depth into the hole
#: (Gaussian sigma, pixels per pixel; :func:`~.blend.fade_with_depth`), and the share of its low frequencies
#: (a Gaussian FADE_LOW of the image diagonal wide) taken from Telea's fill instead. Against the true background
#: of 8 generated scenes (bench fill_truth, seed 51; mean error in the revealed area, levels; the blend 8.46,
#: Telea 8.82): faded at 0.2 with half of Telea's low frequencies 7.35 (at most the better of the two in 7
#: scenes), but the wood where the desk's ball stood went flat (gradient 0.34 of the wood's, bench look allows
#: 0.6); with the surface's grain laid back (``grain.py``) 7.56 (5 scenes), the ball's grain 0.55 and the cap's
#: strip 9.4 levels off the wood (Telea's share of the dark border beside it); at 0.1 and a quarter, 7.86
#: (5 scenes), the ball 0.62 and the cap 7.9. The grain a viewer sees costs error against the truth: it cannot
#: fall where the true grain does. Held per scene against the better of Telea and the blend (24 scenes, seeds
#: 51, 52 and 61): with a quarter of Telea's low frequencies the faded fill errs least on the mean (8.79 levels;
#: the blend 9.30, Telea 9.91) but at most the better of the two in only 11 (2 of seed 61's 8): where Telea's
#: smooth colour is the worse guess, its quarter costs the fill the few tenths by which it would beat the
#: blend. At a tenth, 8.86 and 16 (5 of 8); without it, 8.93 and 17 (6 of 8). On a fresh seed (62) a tenth
#: and a quarter both hold in 2 of 8 (mean 5.75 and 5.72; the blend 5.96, Telea 6.58), three of the misses by
#: less than 0.1 level against the blend: which of the two errs less is then a matter of tenths. Most other
#: misses are scenes where Telea errs 1-4 levels less than any copy (checks seen too obliquely to line up);
#: choosing among the three per part of the hole by trying the part's shape on known surface beside it lowered
#: the mean on seeds 51 and 52 (7.09 to 6.86) but raised it on 61 (12.2 to 12.7): the surface beside a hole
#: does not say which fill is right in it. Nor does the band of known surface around each part, taken into the
#: hole and filled with it (16 scenes of seeds 52 and 61: mean 9.30 against the faded fill's 9.06, at most the
#: better of Telea and the blend in 8 against 9, at 1.9 times the time; docs/benchmarks.md).
FADE = 0.1
FADE_LOW = 0.02
FADE_TELEA = 0.1

METHODS = ("faded", "exemplar", "telea", "blend")
#: The fill a plate takes unless told otherwise.
DEFAULT_METHOD = "faded"


def background_plate(photo: np.ndarray, masks, dilation: float, method: str = DEFAULT_METHOD,
                     shadows: bool = True, sources: np.ndarray | None = None, camera=None,
                     weight: np.ndarray | None = None) -> np.ndarray:
    """The photo with every object (and, with ``shadows``, its contact shadow) filled in, (H, W, 3) uint8.

    ``dilation`` widens each mask by that fraction of the image diagonal, so that soft edges go too.
    Outside the hole (:func:`plate_hole`) the plate is the photo, pixel for pixel. ``sources``: (H, W, 2)
    int32, filled with -1 by the caller; the exemplar fill (not the blend) writes there, for each pixel of the
    hole it copied, the (y, x) of the photo's pixel it copied from (:func:`~.carry.carry_plate` takes the fill's
    detail from there). ``camera``: the :class:`~physomni_usd.geometry.camera.PinholeCamera` over the ground
    plane, when known; the faded fill then fills the hole's part on the floor top-down (``floor.py``).
    ``weight``: (H, W) float32 given by the caller; the plate writes there each pixel's share of the fill (0
    where the plate is the photo, 1 where it is the fill alone), which :func:`~.carry.carry_plate` needs: a
    pixel the plate left as the photo may lie beside one it keeps filled (:func:`_world_back`).
    """
    hole, kept, _ = _plate_parts(photo, masks, dilation, shadows)
    feather = feather_px(photo.shape)
    wall = off_floor(photo, masks) if _top_down(method, camera) else None
    filled = fill_hole(photo, hole, method, feather, sources, camera, wall)
    share = fill_share(hole, feather)
    if kept is not None:
        filled, back = _world_back(photo, filled, hole, kept, feather)
        share *= back
    if weight is not None:
        weight[...] = share
    return filled


def _world_back(photo: np.ndarray, filled: np.ndarray, hole: np.ndarray, kept: np.ndarray,
                feather: int) -> tuple[np.ndarray, np.ndarray]:
    """``filled`` with the photo back in the part of ``hole`` beyond ``kept`` wherever the photo there is like
    the surface around the hole (within :data:`WORLD_LIKE` of its local spread of the fill): there it is the
    world, and filled it changes once its object moves although nothing there did. A pixel far off the
    surface's spread there (an object's dark rim the mask missed, its shade) stays filled, but only within the seam
    beyond ``kept``: farther out the photo is back whatever the fill. Also (H, W) float32:
    how much of ``filled`` each pixel keeps (0 where the photo is back)."""
    p = photo.astype(np.float32)
    f = filled.astype(np.float32)
    known = (~hole).astype(np.float32)
    sigma = float(max(2 * feather, 4))
    mean = blur_over(p, known, sigma)
    spread = np.sqrt(np.maximum(blur_over(p * p, known, sigma) - mean * mean, 0.0)).max(-1)
    off = np.abs(p - f).max(-1) / (spread + WORLD_NOISE)
    world = np.clip((WORLD_LIKE[1] - off) / (WORLD_LIKE[1] - WORLD_LIKE[0]), 0.0, 1.0)
    # smoothed, so that the choice follows the surface's patches rather than single pixels, but never more the
    # world than the pixel's own: smoothed alone, the floor around a 1-2 px rim the mask missed voted the rim
    # back into the plate (90 levels off a floor, it came back 71 levels off it: a ghost outline once the object
    # moved; now 12, tests/test_plate_masks.py). Narrowing the world by 2 px before smoothing also kept the rim
    # filled (20) but the shelves round the pushed motorcycle's mirrors too: still_changes 475 pixels, now 218
    world = np.minimum(world, blur(world, 1.5))
    away = cv2.distanceTransform((~kept).astype(np.uint8), cv2.DIST_L2, 5)
    a = np.clip(1.0 - away / (feather + 1.0), 0.0, 1.0)
    # a rim the mask missed lies at the mask's edge, within the seam beyond the kept edge; farther out the
    # hole's widening is there only so that the fill's sources hold none of the object's soft edge, and what
    # the fill missed there (a shelf's post, a box's edge beside the pushed motorcycle) is the world: filled,
    # it changed once its object moved although nothing there did (still_changes 809 px, limit 400). The
    # fill gives way over a short ramp centred on the seam's outer edge: stopped within one pixel it left a
    # hard seam round the motorcycle (bench look's border 1.37, 1.25 with the ramp); a ramp inside the seam
    # gave back a rim the mask missed 8 px inside (tests/test_plate_masks.py)
    reach = np.clip((feather + RIM_RAMP[0] - away) / RIM_RAMP[1], 0.0, 1.0)
    a = np.maximum(a, (1.0 - world) * reach)[..., None]
    out = p + a * (f - p)
    return (np.where(hole[..., None], np.clip(out + 0.5, 0, 255), photo).astype(np.uint8),
            np.where(hole, a[..., 0], 0.0).astype(np.float32))


def fill_share(hole: np.ndarray, feather: int) -> np.ndarray:
    """(H, W) float32: each pixel's share of the fill in :func:`fill_hole`'s seam, 0 outside ``hole``, rising
    to 1 ``feather`` pixels into it."""
    hole = np.asarray(hole, bool)
    if feather <= 0 or not hole.any() or hole.all():
        return hole.astype(np.float32)
    inside = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_L2, 5)
    return np.clip(inside / (feather + 1.0), 0.0, 1.0).astype(np.float32)


def feather_px(shape) -> int:
    """Width in pixels of the seam :func:`plate_hole` adds around the hole of an image of ``shape`` (H, W, ...)."""
    return max(4, int(round(FEATHER * np.hypot(shape[0], shape[1]))))


def kept_edge_px(shape) -> int:
    """How far in pixels beyond its masks the plate of an image of ``shape`` (H, W, ...) shows the fill whatever
    the photo there (:data:`KEPT_EDGE`); the seam into the photo (:func:`feather_px`) lies beyond it."""
    return max(KEPT_EDGE_MIN, int(round(KEPT_EDGE * np.hypot(shape[0], shape[1]))))


def fill_hole(photo: np.ndarray, hole: np.ndarray, method: str = DEFAULT_METHOD, feather: int = 0,
              sources: np.ndarray | None = None, camera=None, wall: np.ndarray | None = None) -> np.ndarray:
    """``photo`` (H, W, 3) uint8 RGB with the pixels of ``hole`` (H, W) bool filled by ``method``; with
    ``feather`` > 0 the hole's outer ``feather`` pixels blend from the photo (at its edge) to the fill.
    ``sources``, ``camera``: as :func:`background_plate` takes them; ``wall``: the pixels above a wall's foot
    (``floor.off_floor``), which the floor's top-down fill leaves to the image-plane fill."""
    filled = _fill_hole(photo, hole, method, sources, camera, wall)
    if feather <= 0 or not np.any(hole) or np.all(hole):
        return filled
    a = fill_share(hole, feather)[..., None]
    blend = photo.astype(np.float32) * (1.0 - a) + filled.astype(np.float32) * a
    out = np.where(np.asarray(hole, bool)[..., None], np.clip(blend + 0.5, 0, 255), photo).astype(np.uint8)
    # the seam mixes in the photo's pixels under the hole's edge: the cap comes after it, so that no pixel of
    # the plate's hole holds a colour its surroundings lack (Telea and the exemplar are kept as they are)
    return cap_colours(photo, out, hole) if method in ("faded", "blend") else out


def _top_down(method: str, camera) -> bool:
    """Whether ``method`` fills the floor's part of a hole top-down under ``camera`` (``floor.py``): the faded
    fill, under a known camera pitched less than ``TOP_DOWN_DEG``."""
    return method == "faded" and camera is not None and camera.pitch_deg < TOP_DOWN_DEG


def _fill_hole(photo: np.ndarray, hole: np.ndarray, method: str, sources: np.ndarray | None = None,
               camera=None, wall: np.ndarray | None = None) -> np.ndarray:
    if method not in METHODS:
        raise ValueError(f"unknown fill method {method!r} (known: {', '.join(METHODS)})")
    hole = np.asarray(hole, bool)
    if not hole.any():
        return photo.copy()
    if hole.all():  # nothing to copy from or to diffuse
        return np.broadcast_to(photo.reshape(-1, 3).mean(0).astype(np.uint8), photo.shape).copy()
    if method == "telea":
        return fill_telea(photo, hole)
    if method == "blend":
        return fill_blend(photo, hole)
    if method == "faded":
        filled = fill_faded(photo, hole)
        return fill_on_ground(photo, hole, camera, fill_faded, filled, wall) if _top_down(method, camera) else filled
    return fill_exemplar(photo, hole, sources)


def fill_faded(photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``hole`` (H, W) bool of ``photo`` (H, W, 3) uint8 RGB filled by the blend, its copies faded into their
    local mean with the depth into the hole (:data:`FADE`), and :data:`FADE_TELEA` of its low frequencies
    replaced by those of Telea's fill, more where its copies are distrusted (:func:`~.blend.shift_trust`: their
    shift does not map the surface beside them onto itself), all of them where none is trusted.

    Held against the true background a copy errs least where it continues the surface (a checked wall
    copied in step, at the hole's edge); deeper in, where its lines and spots fall between the true ones
    (bricks, sand ripples copied a little off), it errs twice where the local mean errs once. The copies'
    local colour may come from elsewhere (a ripple's shaded side), Telea's from the border all round; Telea's
    is the worse guess more often than not, so it takes a small share. What is left of the copies' detail is
    the surface's grain at the edge."""
    trust = np.ones(hole.shape, np.float32)
    faded = fill_blend(photo, hole, fade=FADE, trust=trust).astype(np.float32)
    telea = fill_telea(photo, hole).astype(np.float32)
    sigma = FADE_LOW * float(np.hypot(*hole.shape))
    low = lambda img: cv2.GaussianBlur(img, (0, 0), sigma)  # noqa: E731
    # where the copies' shifts do not map the surface beside them onto itself, their low frequencies are a
    # guess out of step: Telea's smooth colour takes them over, as far as the copies are distrusted
    share = FADE_TELEA + (1.0 - FADE_TELEA) * (1.0 - cv2.GaussianBlur(trust, (0, 0), sigma))
    out = faded + share[..., None] * (low(telea) - low(faded))
    return np.where(hole[..., None], np.clip(out + 0.5, 0, 255), photo).astype(np.uint8)


def plate_hole(photo: np.ndarray, masks, dilation: float, shadows: bool = True) -> np.ndarray:
    """(H, W) bool: the pixels the plate fills, every mask dilated by ``dilation`` × the diagonal,
    plus (with ``shadows``) the contact shadow found under each object (:func:`contact_shadow`), and the
    seam (:data:`FEATHER`) around all of it, over which the fill fades into the photo."""
    return _plate_parts(photo, masks, dilation, shadows)[0]


def _plate_parts(photo: np.ndarray, masks, dilation: float, shadows: bool
                 ) -> tuple[np.ndarray, np.ndarray | None, list[np.ndarray | None]]:
    """:func:`plate_hole`, the part of it the plate shows filled (the masks widened by :data:`KEPT_EDGE`
    and the shadows; the photo returns across a seam beyond it), None where that is the whole hole, and the
    contact shadow found under each mask (None each without ``shadows``). Each shadow is sought beside the
    hole grown by those before it, so that no two share a pixel (:func:`hole_owners` reads them from here)."""
    h, w = photo.shape[:2]
    union = np.zeros((h, w), bool)
    for m in masks:
        union |= np.asarray(m, bool)
    r = int(round(dilation * np.hypot(h, w)))
    edge = kept_edge_px(photo.shape)
    hole = dilate(union, r)
    kept = dilate(union, edge) if r > edge else None
    found: list[np.ndarray | None] = [None] * len(masks)
    if shadows:
        lum = cv2.cvtColor(photo, cv2.COLOR_RGB2Lab)[..., 0].astype(np.float32)
        for i, m in enumerate(masks):
            shadow = contact_shadow(lum, np.asarray(m, bool), hole)
            found[i] = shadow
            hole |= shadow
            if kept is not None:
                kept |= shadow
    return (dilate(hole, feather_px(photo.shape)) if hole.any() else hole), kept, found


#: How far beyond the seam round a contact shadow (:data:`FEATHER`) its caster still shares the pixels in full
#: (:func:`hole_owners`), in pixels: the renderer finds the shadow again at the frame's size, where its edge
#: falls a pixel or two from the plate's; and the ramp (pixels) beyond that over which the share fades (and over
#: which it fades where it meets the owner's own shadow), so that where the photo kept for a caster that stands
#: meets the fill of one that moved no hard edge shows.
SHARE_SLACK = 3.0
SHARE_RAMP = 3.0


def hole_owners(photo: np.ndarray, masks, dilation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pixel of ``photo`` (H, W, 3) uint8, the object (index into ``masks``, (H, W) bool each or None)
    whose part of the plate it is, and another that shares it, (H, W) int32 each, −1 for none, and how much
    it shares it, (H, W) float32 0–1: a renderer shows the plate there only once both have moved.

    The owner is the object whose mask the pixel lies in or nearest to. A contact shadow is also its
    caster's: the plate removed it with its caster (the shadows are the plate's own, :func:`_plate_parts`),
    so wherever it, or the seam the plate fades over round it, lies nearer another object, that object
    shares it with the caster: the photo's shade is right while either stands. The share is whole up to the
    seam and :data:`SHARE_SLACK` beyond it and fades over :data:`SHARE_RAMP` past that, and it fades the same
    way where it meets the owner's own shadow, which the owner alone reveals (the nearer shadow decides): a
    pushed object takes its own shade with it, and no hard edge shows where the photo kept for a caster that
    stands meets the fill of one that left. A mask and its kept edge are never shared: an object's own pixels
    leave with it.

    One sharer per pixel: where the seams of several other objects' shadows cross, the nearest shadow's
    caster shares the pixel and the others do not (their shade there shows the plate once the owner and that
    caster have moved)."""
    h, w = photo.shape[:2]
    placed = [k for k, m in enumerate(masks) if m is not None and np.any(m)]
    owner = np.full((h, w), -1, np.int32)
    sharer = np.full((h, w), -1, np.int32)
    share = np.zeros((h, w), np.float32)
    if not placed:
        return owner, sharer, share
    fitted = [np.asarray(masks[k], bool) for k in placed]
    _, _, shadows = _plate_parts(photo, fitted, dilation, True)
    seam = float(feather_px(photo.shape)) + SHARE_SLACK
    # the plate fills the masks' kept edge whatever the photo there (a rim the mask missed): it leaves with them
    kept = dilate(np.any(fitted, axis=0), kept_edge_px(photo.shape))
    dist = np.full((h, w), np.inf, np.float32)
    for k, m in zip(placed, fitted):
        d = cv2.distanceTransform((~m).astype(np.uint8), cv2.DIST_L2, 5)
        nearer = d < dist
        owner[nearer], dist[nearer] = k, d[nearer]
    casters = [(k, cv2.distanceTransform((~s).astype(np.uint8), cv2.DIST_L2, 5))
               for k, s in zip(placed, shadows) if s.any()]
    own = np.full((h, w), np.inf, np.float32)  # how far each pixel lies from its owner's own shadow
    for k, d in casters:
        mine = owner == k
        own[mine] = d[mine]
    shade = np.full((h, w), np.inf, np.float32)
    for k, d in casters:
        claim = (d < seam + SHARE_RAMP) & (d < shade) & (owner != k) & ~kept
        sharer[claim], shade[claim] = k, d[claim]
    claimed = sharer >= 0
    beyond = np.clip((seam + SHARE_RAMP - shade[claimed]) / SHARE_RAMP, 0.0, 1.0)
    # half shared where the two shadows are equally near, so that the share fades across that line too
    inner = np.clip((own[claimed] - shade[claimed]) / SHARE_RAMP + 0.5, 0.0, 1.0)
    share[claimed] = beyond * inner
    sharer[claimed & (share <= 0.0)] = -1
    return owner, sharer, share


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
    near_all = within(mask, reach)
    near = near_all.copy()
    near[: (ys.min() + ys.max()) // 2] = False
    band = near & ~hole
    if not band.any():
        return np.zeros_like(mask)
    known = (~(band | hole)).astype(np.float32)
    sigma = max(2.0, float(reach))
    weight = blur(known, sigma)
    surround = blur(lum * known, sigma) / np.maximum(weight, 1e-3)
    read_wide = weight > KNOWN_SHARE
    read = read_wide.copy()
    read[:, xs.min():xs.max() + 1] |= weight[:, xs.min():xs.max() + 1] > KNOWN_SHARE_UNDER
    # a contact shadow darkens the surface smoothly: compare the lightness averaged over a few pixels, so
    # that the dark grains of a textured surface (gravel, grass) do not count
    smooth = blur(lum, max(1.0, reach / 6.0))
    dark = band & (smooth < SHADOW_RATIO * surround) & read
    if not dark.any():
        return np.zeros_like(mask)
    dark = cv2.morphologyEx(dark.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)) > 0
    seed = dilate(hole & near_all, 2)
    n, labels = cv2.connectedComponents((dark | seed).astype(np.uint8), connectivity=8)
    touching = np.unique(labels[seed & (labels > 0)])
    shadow = np.isin(labels, touching) & dark
    if shadow.any():  # grow it through its penumbra
        soft = band & (smooth < PENUMBRA_RATIO * surround) & read_wide
        # and, darker than the surface at all, where its lightness still falls faster than the surface's own
        # grain: on white paper a sweet's shade fades in steps of one level, each a line the seam would show
        g = gradient(blur(lum, 1.0))
        surface_g = blur(g * known, sigma) / np.maximum(weight, 1e-3)
        soft |= band & (smooth < surround) & (g > PENUMBRA_GRADIENT * surface_g) & read_wide
        n, labels = cv2.connectedComponents((soft | shadow).astype(np.uint8), connectivity=8)
        shadow |= np.isin(labels, np.unique(labels[shadow & (labels > 0)])) & soft
    return dilate(shadow, 2) & near


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
