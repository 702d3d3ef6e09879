"""``bench look``: what a person sees, per bundled example, as a contact sheet and the figures behind it.

Each example is built as its example.json says (photo, masks or boxes, sizes,
pushes), simulated for its seconds, and rendered as the product renders it
(``ShotRenderer``, the photo's camera, longer side ``size``). The sheet holds,
left to right: the photo, frames 0, middle and last, the last frame under
``--camera orbit-left``, and the live preview's opening view as headless
Chromium shows it (where Playwright and a Chromium are installed).

The figures, on the last frame, for each object that left the part of the plate
that replaces it and its contact shadow in the photo (the *revealed* area, the
pixels where the plate differs from the photo that touch the object, no object
in front of them now; at least :data:`MIN_REVEALED` pixels). They are read on
the last frame rendered without the moved objects' new contact shadows: what an
object leaves behind is the plate (its old shadow gone with it), while the
shadow it casts where it now stands, darkest right beside it, hugs the area it
left and would read as the fill's grain, outline and colour; where an object has moved
only part of the way the renderer fades it over (a few pixels), the frame there is
partly the photo still, and the figures are read on its plate (:func:`_left_fully`) over the area the
frame no longer shows as the photo (an object nudged under a pixel of the fade reveals nothing). Each is also given
as the frame shows it, shadows and all (``*_as_shown``, ``colour_difference_plain``):

* ``gradient_ratio``: mean gradient magnitude inside the revealed area (its
  border left out) over that of a ring around it (the plate's surface nearby,
  without any object of the photo or of the frame): 1 where the fill carries the
  surface's texture, near 0 for a flat patch. Target 0.6–1.6.
* ``border_ratio``: mean gradient magnitude along the revealed area's border
  over the ring's: above 1 where an outline shows. Target ≤ 1.3.
* ``colour_difference``: the largest difference of the channels' means, revealed
  area against the ring's colour near each of its pixels (:func:`ring_colour_near`:
  the mean of the ring pixels no farther from that pixel than its nearest ring
  pixel plus the ring's width, a pixel across the bands in which the ring's colour
  changes counting up to four times one along them), in 0–255 levels. Target ≤ 8. An area that
  straddles two surfaces (a backdrop and the floor below it) is compared with
  each surface where it lies: the plain mean of a ring that an object cuts, in
  other proportions of the two than the area holds, is not what the area should
  look like (the cloth's towel: 53 % backdrop, its ring 45 %; 15 levels apart by
  plain means, 1.9 by local ones). Without the shadows, because pixel by pixel the
  shadow of an object now beside the area, darker next to it than a ring's width
  out, would read as the fill's colour (a sweet's crescent: 9.2 with them, 3.1
  without). For a ring of one colour and no shadow the two are the same.
* ``colour_difference_plain``: the largest difference of the channels' means,
  area against the ring's plain mean, on the frame as shown: the figure as it
  was, reported beside the target one; ``gradient_ratio_as_shown`` and
  ``border_ratio_as_shown`` likewise.

"An object in this frame" is any pixel whose ray meets an opaque texel of a mesh
(``FrameState.face``: a slab's transparent back or cut-outs, the ground seen between
a wheel's spokes, is no object; taken as one, the bundled motorcycle's plate read as
covered over 30,000 pixels it showed) and any pixel the particles are drawn over
(``FrameState.particle_alpha``: water, sand).

With ``--truth-scenes N`` the fill is also held against the truth: generated scenes rendered with their objects
and without them, each fill's error against the empty render in the revealed area and its colours against
the surroundings' (:func:`fill_truth_figure`); and what a moved object looks like from a novel view: each
scene built from its visible masks and each object's silhouette from ±45° held against the truth render's
(:func:`novel_view_figure`, IoU, the limit ``bench general``'s).

Frame 0 against the photo (PSNR, dB) and the preview's opening view against the
photo (SSIM on grey) are reported beside them, and, under ``--camera orbit-left``
at the last frame, each object's widest wall of stretched or repeated pixels
(:func:`orbit_walls`, a fraction of the frame's width; target ≤ :data:`MAX_WALL`)
and how much the wide plate's margins mirror the photo
(``metrics.mirror_similarity``: near 1 for a mirror, near 0 otherwise).
"""

from __future__ import annotations

import json
import pathlib
import socket
import subprocess
import sys
import tempfile
import threading

import cv2
import numpy as np

from ..errors import InputError
from ..settings import BuildSettings
from ..texture.fill import contact_shadow, feather_px, kept_edge_px
from ..texture.sides import copy_sources
from .limits import LOOK

#: Revealed areas smaller than this many pixels (at the rendered size) say nothing and are not measured.
MIN_REVEALED = 60
#: Width of the ring around a revealed area, as a fraction of the frame's diagonal (at least 6 pixels).
RING = 0.025
#: Height in pixels of each picture on a contact sheet.
TILE_HEIGHT = 240
#: The most that :func:`ring_grain` lets a ring pixel across the surface's bands count farther than one along them.
MAX_ANISOTROPY = 4.0
#: The targets the figures are held to (issue "what a person sees").
TARGETS = {"gradient_ratio": (0.6, 1.6), "border_ratio": (0.0, 1.3), "colour_difference": (0.0, 8.0)}


def photo_masks(renderer) -> list[np.ndarray | None]:
    """Per object of ``renderer`` (a ShotRenderer), (H, W) bool at the frame's size: where the photo shows
    it (its texture's photo crop, opaque), None for an object not placed in the photo."""
    out = []
    sx, sy = getattr(renderer, "to_frame", (1.0, 1.0))
    for o in renderer.objects:
        if o.origin is None:
            out.append(None)
            continue
        a = o.texture[:, : o.texture.shape[1] // 2 if o.two_sided else None, 3]
        x0, y0 = o.origin
        m = cv2.warpAffine(a, np.float32([[sx, 0, x0 * sx], [0, sy, y0 * sy]]), (renderer.width, renderer.height),
                           flags=cv2.INTER_LINEAR)
        out.append(m >= 128)
    return out


def _disk(r: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def plate_holes(renderer, masks: list[np.ndarray | None]) -> list[np.ndarray | None]:
    """Per object, (H, W) bool: the pixels of the plate that replace it and its contact shadow (where the
    plate differs from the photo, in the parts that touch the object's mask, nearer to it than to any other
    object); its mask alone for shots without the photo."""
    photo, plate = getattr(renderer, "photo", None), getattr(renderer, "plate", None)
    owner = getattr(renderer, "owner", None)
    if photo is None or plate is None or owner is None:
        return list(masks)
    differs = (np.abs(np.asarray(plate, np.float32) - photo).max(-1) > 1.5).astype(np.uint8)
    n, labels = cv2.connectedComponents(differs, connectivity=8)
    out = []
    for k, m in enumerate(masks):
        if m is None:
            out.append(None)
            continue
        touching = np.unique(labels[(cv2.dilate(m.astype(np.uint8), _disk(2)) > 0) & (labels > 0)])
        out.append(m | (np.isin(labels, touching) & (owner == k)))
    return out


#: A pixel "differs from frame 0" where a channel changed by more than this many levels (issue "what a person
#: sees": outside what moved, where it stood and its shadow, no pixel may).
STILL_LEVELS = 30
#: Width in frame pixels of the edge kept beside each moved object's silhouette now: its anti-aliased rim.
STILL_EDGE = 2


def still_changes(renderer, t: float, levels: float = STILL_LEVELS,
                  dilation: float | None = None) -> tuple[int, np.ndarray, list[str]]:
    """Where frame ``t`` of ``renderer`` (a ShotRenderer through the photo's camera) differs from its first frame
    by more than ``levels`` (any channel) although nothing there moved: the count, those pixels ((H, W) bool)
    and the paths of the objects that moved.

    Changes are allowed over each moved object's silhouette now (the faces its pixels see) and an edge of
    :data:`STILL_EDGE` pixels around it; where it stood (its part of the photo, :func:`photo_masks`) with the
    contact shadow the photo shows under it there (``texture.fill.contact_shadow``, as the plate finds it
    beside the masks widened by ``dilation``, the build's default when None), and the edge and seam around those over which the plate
    replaces the object's rim and fades into the photo (``texture.fill.kept_edge_px`` + ``feather_px``); and
    wherever its contact shadow darkens the frame now (the frame rendered again without contact shadows tells
    where). Every other pixel is of an object in place or of the world behind, and should be frame 0's,
    however the plate was filled."""
    dilation = BuildSettings().plate_dilation if dilation is None else dilation
    reuse = renderer.reuse_still
    renderer.reuse_still = False  # every frame drawn in full: its state holds the faces each pixel sees
    try:
        start = float(renderer.stage.GetStartTimeCode())
        first = renderer.render(start)[0]
        image, state = renderer.render(t)
        settings = renderer.settings
        renderer.settings = settings.model_copy(update={"shadow_strength": 0.0})
        try:
            unshaded = renderer.render(t)[0]
        finally:
            renderer.settings = settings
    finally:
        renderer.reuse_still = reuse
    moved = renderer._moved_since_start(state.camera, state.points, [])[0] if state.points is not None else []
    moved_k = [k for k in range(len(renderer.objects)) if moved[k] > 0]
    h, w = image.shape[:2]
    rim = kept_edge_px((h, w)) + feather_px((h, w))
    allowed = np.abs(image.astype(np.int16) - unshaded.astype(np.int16)).max(-1) > 0
    masks = photo_masks(renderer)
    lum = cv2.cvtColor(first, cv2.COLOR_RGB2Lab)[..., 0].astype(np.float32)
    # the shadows are sought beside the masks widened as the plate widens them (BuildSettings.plate_dilation)
    placed = [m for m in masks if m is not None]
    widened = (cv2.dilate(np.any(placed, axis=0).astype(np.uint8), _disk(round(dilation * np.hypot(h, w)))) > 0
               if placed else None)
    # the object each pixel shows: the caster's opaque hit, not the first face on the ray (a moved slab's
    # transparent back between its spokes is no silhouette of it)
    obj = (np.where(covered(state), renderer.face_object[np.maximum(state.face, 0)], -1)
           if getattr(state, "face", None) is not None else np.full((h, w), -1))
    for k in moved_k:
        allowed |= cv2.dilate((obj == k).astype(np.uint8), _disk(STILL_EDGE)) > 0
        if masks[k] is not None:
            stood = masks[k] | contact_shadow(lum, masks[k], widened)
            allowed |= cv2.dilate(stood.astype(np.uint8), _disk(rim)) > 0
    changed = np.abs(image.astype(np.int16) - first.astype(np.int16)).max(-1) > levels
    where = changed & ~allowed
    return int(where.sum()), where, [renderer.objects[k].path for k in moved_k]


def ring_colour_near(image: np.ndarray, area: np.ndarray, ring: np.ndarray, width: float,
                     chunk: int = 1024) -> np.ndarray:
    """(N, 3) float32: for each of the N pixels of ``area`` ((H, W) bool, row-major order), the mean colour of
    ``image`` (H, W, 3) over the pixels of ``ring`` ((H, W) bool, not empty) no farther from it than its
    nearest ring pixel plus ``width`` pixels, with distances across the direction in which the ring's colour
    changes most stretched by how strongly it prefers that direction (:func:`ring_grain`).

    One ring width past the nearest: far enough to average the surface's grain and noise, near enough that a
    pixel of an area straddling two surfaces takes the surface beside it, not the mix of the whole ring. An
    object that cuts the ring beside an area's pixel leaves it the ring nearest to it, whatever surface that
    is: where one surface of the area has no ring pixel beside it at all, its pixels are compared with the
    other surface. Stretched, because surfaces in a photo lie in bands (a backdrop over a floor, a floor
    darkening towards the camera): in the water example the floor just under the horizon lay 28-46 px below the
    backdrop's ring and 57-59 px from the floor's beside the area, and by plain distance the fill that continues
    the floor row by row read 16.0 levels off, 0.4 counted along the bands. A ring with no preferred
    direction (grain alone) is measured as before; one of vertical stripes is compared along the stripes."""
    py, px = (a.astype(np.float32) for a in np.nonzero(area))
    qy, qx = (a.astype(np.float32) for a in np.nonzero(ring))
    colours = image[ring].reshape(-1, 3).astype(np.float32)
    (ay, ax), (by, bx), k = ring_grain(image, ring, width)
    out = np.empty((len(py), 3), np.float32)
    for s in range(0, len(py), chunk):  # N × M distances at once would not fit for large areas
        dy, dx = py[s:s + chunk, None] - qy[None], px[s:s + chunk, None] - qx[None]
        # across the direction the ring's colour changes most, a pixel apart counts k times as far
        d2 = (k * (dy * ay + dx * ax)) ** 2 + (dy * by + dx * bx) ** 2
        reach = np.sqrt(d2.min(1, keepdims=True)) + width
        near = (d2 <= reach * reach).astype(np.float32)
        out[s:s + chunk] = (near @ colours) / near.sum(1, keepdims=True)
    return out


def ring_grain(image: np.ndarray, ring: np.ndarray, width: float) -> tuple:
    """The direction in which the colour of ``image`` (H, W, 3) over ``ring`` ((H, W) bool) changes most, as a
    unit (y, x) vector, the direction across it, and how strongly the change prefers it: the square root of
    the ratio of the two eigenvalues of the structure tensor of the ring's lightness (low-passed over the
    ring alone at ``width`` / 2 pixels, so that noise is no direction), within [1, :data:`MAX_ANISOTROPY`]."""
    grey = cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2GRAY).astype(np.float32)
    r = ring.astype(np.float32)
    sigma = max(1.0, width / 2.0)
    low = cv2.GaussianBlur(grey * r, (0, 0), sigma) / np.maximum(cv2.GaussianBlur(r, (0, 0), sigma), 1e-3)
    gy, gx = cv2.Sobel(low, cv2.CV_32F, 0, 1, ksize=3), cv2.Sobel(low, cv2.CV_32F, 1, 0, ksize=3)
    inner = cv2.erode(ring.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # the ring's edge is no change
    if not inner.any():
        return (1.0, 0.0), (0.0, 1.0), 1.0
    j = np.array([[np.sum(gy[inner] ** 2), np.sum(gy[inner] * gx[inner])],
                  [np.sum(gy[inner] * gx[inner]), np.sum(gx[inner] ** 2)]], np.float64)
    vals, vecs = np.linalg.eigh(j)  # ascending
    k = float(np.clip(np.sqrt(vals[1] / max(vals[0], 1e-9)), 1.0, MAX_ANISOTROPY))
    return (float(vecs[0, 1]), float(vecs[1, 1])), (float(vecs[0, 0]), float(vecs[1, 0])), k


def _left_fully(renderer, state, unshaded: np.ndarray) -> np.ndarray:
    """``unshaded`` (a frame of ``renderer`` rendered from ``state`` without contact shadows) with the plate shown
    in full wherever the object that owns the pixel has moved only part of the way the renderer fades it over
    (``rendering.video``: from ``IN_PLACE_PX`` to ``IN_PLACE_PX + REVEAL_PX`` pixels from where the photo shows it): there the
    frame is by design that much the photo still, its own contact shadow at the old place fading out as the
    moved object's new one fades in, and the photo's shadow read as the fill would be the photo's, not the
    plate's (the desk's cap, knocked 1.6 px at 480: the frame there 0.57 of the photo and 0.43 of the plate, its
    shadow's remnant 3.3x the wood's gradient and 28 levels darker, where the plate itself is 0.85x and 2.1).
    Only for the figures: a frame that is all but the photo (an object nudged under a pixel of the fade) has
    revealed nothing, which the caller decides on the frame as rendered. Unchanged for a renderer that cannot
    say how far its objects moved, or where every object moved fully or not at all."""
    plate, owner = getattr(renderer, "plate", None), getattr(renderer, "owner", None)
    moved_since = getattr(renderer, "_moved_since_start", None)
    if plate is None or owner is None or moved_since is None or state.points is None:
        return unshaded
    moved = moved_since(state.camera, state.points, [])[0]
    partly = (moved > 0.0) & (moved < 1.0)
    if not partly.any():
        return unshaded
    here = partly[owner] & ~covered(state)  # the background, not an object drawn over it
    out = unshaded.copy()
    out[here] = np.clip(np.asarray(plate, np.float32)[here] + 0.5, 0, 255).astype(np.uint8)
    return out


def covered(state) -> np.ndarray:
    """(H, W) bool: where ``state``'s frame shows an object's mesh, not what lies behind it: the caster's
    opaque hit (``FrameState.face``), not the first face on the ray (a slab's transparent back between a
    wheel's spokes hid 30,000 px of the plate from the measure)."""
    return state.face >= 0


def revealed_figures(renderer, image: np.ndarray, state, unshaded: np.ndarray | None = None) -> list[dict]:
    """The figures of the module's docstring for each object whose part of the plate (:func:`plate_holes`)
    ``image`` (a frame of ``renderer``, rendered from ``state``) shows with no object in front of it.
    ``unshaded``, the same frame rendered without contact shadows, tells where the frame shows the photo (a
    moved object's shadow over one still in place darkens the photo there, and reveals nothing of its plate),
    and the targets' figures are read on it: what an object leaves behind is the plate, and the shadow it casts
    where it is now, darkest right beside it, hugs the area it left (a sweet nudged by a few pixels leaves a
    crescent inside its own new shadow, whose fall-off read as the fill's grain: 2.5× the ring's gradient as
    shown, 0.95× without); an object moved only part of the way has its figures read on its plate
    (:func:`_left_fully`) over the area the frame as rendered no longer shows as the photo. The same figures on ``image`` as shown are given beside them (``*_as_shown``)."""
    h, w = image.shape[:2]
    masks = plate_holes(renderer, photo_masks(renderer))
    placed = [m for m in masks if m is not None]
    if not placed or state.mesh_face is None:
        return []
    drawn = covered(state)
    particles = getattr(state, "particle_alpha", None)
    if particles is not None:  # particles are no faces: without them the water's own pixels read as revealed
        drawn = drawn | (particles > 0)
    now = cv2.dilate(drawn.astype(np.uint8), _disk(2)) > 0  # any object in this frame
    near_now = cv2.dilate(now.astype(np.uint8), _disk(3)) > 0  # and its edge's own gradient
    photo = getattr(renderer, "photo", None)
    # where the frame as rendered still shows the photo (an object in place), nothing was revealed: decided
    # before the plate is put in for partly moved objects, or one nudged under a pixel of the fade (the frame
    # there all but the photo) would have its whole plate hole read as revealed
    rendered = image if unshaded is None else unshaded
    as_photo = (np.abs(rendered.astype(np.float32) - photo).max(-1) <= 1.5 if photo is not None
                else np.zeros((h, w), bool))
    shown = image if unshaded is None else _left_fully(renderer, state, unshaded)
    photo_any = cv2.dilate(np.any(placed, axis=0).astype(np.uint8), _disk(2)) > 0
    def gradient(img):
        grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32)
        return np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3))

    grad, grad_as_shown = gradient(shown), gradient(image)
    ring_px = max(6, int(round(RING * np.hypot(w, h))))
    out = []
    for k, m in enumerate(masks):
        if m is None:
            continue
        revealed = m & ~now & ~as_photo
        if revealed.sum() < MIN_REVEALED:
            continue
        r8 = revealed.astype(np.uint8)
        inner = cv2.erode(r8, _disk(2)) > 0
        ring = (cv2.dilate(r8, _disk(ring_px)) > 0) & ~photo_any & ~now
        # the seam between the fill and the surface around it: the area's edge where the ring meets it (not
        # where an object stands now or stood in the photo)
        border = ((cv2.dilate(r8, _disk(1)) > 0) & ~(cv2.erode(r8, _disk(1)) > 0)
                  & (cv2.dilate(ring.astype(np.uint8), _disk(2)) > 0) & ~near_now)
        if inner.sum() < MIN_REVEALED // 2 or ring.sum() < MIN_REVEALED or not border.any():
            continue
        g_ring = max(float(grad[ring].mean()), 1e-6)
        g_ring_as_shown = max(float(grad_as_shown[ring].mean()), 1e-6)
        # the contact shadow of an object now beside the area darkens the area more than the ring farther
        # out: paired pixel by pixel that falloff would count as the fill's colour (the plain mean mixes it away)
        local = np.abs(shown[inner].reshape(-1, 3).mean(0) - ring_colour_near(shown, inner, ring, ring_px).mean(0))
        plain = np.abs(image[inner].reshape(-1, 3).mean(0) - image[ring].reshape(-1, 3).mean(0))
        out.append({"object": renderer.objects[k].path, "revealed_px": int(revealed.sum()),
                    "gradient_ratio": round(float(grad[inner].mean()) / g_ring, 3),
                    "border_ratio": round(float(grad[border].mean()) / g_ring, 3),
                    "colour_difference": round(float(local.max()), 2),
                    "gradient_ratio_as_shown": round(float(grad_as_shown[inner].mean()) / g_ring_as_shown, 3),
                    "border_ratio_as_shown": round(float(grad_as_shown[border].mean()) / g_ring_as_shown, 3),
                    "colour_difference_plain": round(float(plain.max()), 2)})
    return out


#: A pixel of an object whose texture, traced back to the photo pixels it came from, changes by less than this
#: many photo pixels per frame pixel in some direction shows one photo pixel smeared over more than
#: 1 / STRETCH frame pixels that way (a wall of stretched pixels); by less than this in every direction, one
#: photo pixel repeated over a patch.
STRETCH = 0.25
#: Neighbouring pixels whose sources lie more than this many photo pixels apart (per frame pixel) sit on two
#: sides of a seam of the texture, not on one stretch of surface.
SEAM = 4.0
#: The target for the widest wall of stretched or repeated pixels of any object, as a fraction of the
#: frame's width (issue "what a person sees": under --camera orbit-left).
MAX_WALL = 0.02


def source_atlas(renderer) -> np.ndarray:
    """(H_atlas, W_atlas, 2) float32: for every texel of ``renderer``'s atlas, the photo pixel (x, y) its colour
    came from — its own place for the photo crop; for the opaque copy of the unseen sides, the place
    ``texture.sides.copy_sources`` takes it from; NaN for objects not placed in the photo."""
    atlas = np.full(renderer.atlas_rgb.shape[:2] + (2,), np.nan, np.float32)
    scales = getattr(renderer, "atlas_scale", None)
    row = 0
    for k, o in enumerate(renderer.objects):
        th, tw = o.texture.shape[:2]
        # the atlas holds each texture at the frame's scale (rendering.video._at_scale)
        sx, sy = scales[k] if scales is not None else (1.0, 1.0)
        ah = round(th * sy)
        if o.origin is not None:
            cw = tw // 2 if o.two_sided else tw
            ys, xs = np.mgrid[:th, :cw].astype(np.float32)
            own = np.stack([xs + o.origin[0], ys + o.origin[1]], -1)
            if o.two_sided:
                own = np.concatenate([own, copy_sources(o.texture[:, :cw, 3] >= 128) + o.origin], 1)
            if (sx, sy) != (1.0, 1.0):
                own = cv2.resize(own, (round(own.shape[1] * sx), ah), interpolation=cv2.INTER_LINEAR)
            atlas[row:row + own.shape[0], :own.shape[1]] = own
        row += ah
    return atlas


def _longest_runs(flag: np.ndarray) -> int:
    """The longest run of True along the rows of ``flag`` (H, W) bool, in pixels."""
    if not flag.any():
        return 0
    padded = np.pad(flag.astype(np.int8), ((0, 0), (1, 1)))
    d = np.diff(padded, axis=1)
    starts, ends = np.nonzero(d == 1)[1], np.nonzero(d == -1)[1]  # row-major: they pair up in order
    return int((ends - starts).max())


def orbit_walls(renderer, state) -> list[dict]:
    """Per object seen in the frame ``state`` (a :class:`~physomni_usd.rendering.video.FrameState` of
    ``renderer``) renders: the widest wall of its stretched or repeated pixels, as a fraction of the frame's
    width (``wall_fraction``; target ≤ :data:`MAX_WALL`), and how many of its pixels are stretched and
    repeated (:data:`STRETCH`).

    Each opaque pixel of the object is traced back through its texture to the photo pixel its colour came
    from (:func:`source_atlas`); the Jacobian of that map (photo pixels per frame pixel, by differences with
    its neighbours on the same object) has a small singular value where one photo pixel is smeared across
    many frame pixels — an extrusion's side wall textured by projection along the view ray, or a fill that
    carries the silhouette's edge outward. A wall's width is its longest run along the direction it is
    smeared in (rows for a smear mostly across, columns for one mostly down). The figures are the texture's,
    wherever the frame shows it or the photo (an object in place)."""
    if state.mesh_face is None or renderer.caster is None:
        return []
    h, w = state.mesh_face.shape
    face = state.mesh_face
    hit = face >= 0
    f = np.maximum(face, 0)
    u, v = state.bary[..., 0], state.bary[..., 1]
    c = renderer.corner_px.reshape(-1, 3, 2)[f]  # (H, W, 3, 2)
    px = u[..., None] * c[..., 0, :] + v[..., None] * c[..., 1, :] + (1.0 - u - v)[..., None] * c[..., 2, :]
    mx = np.where(hit, px[..., 0] - 0.5, -10).astype(np.float32)
    my = np.where(hit, px[..., 1] - 0.5, -10).astype(np.float32)
    alpha = cv2.remap(renderer.atlas_alpha, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    src = cv2.remap(source_atlas(renderer), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=np.nan)
    obj = np.where(hit & (alpha >= 0.5) & np.isfinite(src).all(-1), renderer.face_object[f], -1)
    scale = float(np.mean(getattr(renderer, "to_frame", (1.0, 1.0))))
    src = src * scale  # photo pixels → frame pixels at the frame's scale

    def derivative(axis: int) -> np.ndarray:
        """d(source)/d(pixel) along ``axis``: forward where the next pixel continues the same surface, else
        backward (a seam between two parts of the texture is no derivative: beside a small one it would
        make the Jacobian look singular)."""
        fwd = np.full(src.shape, np.nan, np.float32)
        same = np.full(obj.shape, False)
        sl_a, sl_b = [slice(None)] * 2, [slice(None)] * 2
        sl_a[axis], sl_b[axis] = slice(None, -1), slice(1, None)
        sl_a, sl_b = tuple(sl_a), tuple(sl_b)
        fwd[sl_a] = src[sl_b] - src[sl_a]
        same[sl_a] = (obj[sl_a] == obj[sl_b]) & (obj[sl_a] >= 0) & (np.abs(fwd[sl_a]).max(-1) < SEAM)
        bwd = np.full(src.shape, np.nan, np.float32)
        back = np.full(obj.shape, False)
        back[sl_b] = same[sl_a]
        bwd[sl_b] = fwd[sl_a]
        return np.where(same[..., None], fwd, np.where(back[..., None], bwd, np.nan))

    jx, jy = derivative(1), derivative(0)  # (H, W, 2): the Jacobian's columns
    ok = (obj >= 0) & np.isfinite(jx).all(-1) & np.isfinite(jy).all(-1)
    a, b = np.nan_to_num(jx[..., 0]), np.nan_to_num(jy[..., 0])
    cc, d = np.nan_to_num(jx[..., 1]), np.nan_to_num(jy[..., 1])
    # singular values of [[a, b], [c, d]] (rows: source x, y; columns: frame x, y)
    e, g = a * a + cc * cc, b * b + d * d  # JᵀJ = [[e, k], [k, g]]
    k = a * b + cc * d
    root = np.sqrt(np.maximum((e - g) ** 2 / 4 + k * k, 0.0))
    s_min = np.sqrt(np.maximum((e + g) / 2 - root, 0.0))
    s_max = np.sqrt(np.maximum((e + g) / 2 + root, 0.0))
    # the frame direction of the smear: JᵀJ's eigenvector of the smaller eigenvalue
    vx, vy = k, ((e + g) / 2 - root) - e
    flat = (np.abs(vx) + np.abs(vy)) < 1e-12
    vx, vy = np.where(flat, g - ((e + g) / 2 - root), vx), np.where(flat, 0.0, vy)
    across = np.abs(vx) >= np.abs(vy)
    # a wall is an area: lines a pixel or two thick, where a difference straddles a seam of the texture
    # between two faces, are not one
    opened = lambda m: cv2.morphologyEx(m.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0  # noqa: E731
    repeated = opened(ok & (s_max < STRETCH))
    stretched = opened(ok & (s_min < STRETCH))
    out = []
    for i, o in enumerate(renderer.objects):
        mine = obj == i
        if not mine.any():
            continue
        si, ri = stretched & mine, repeated & mine
        run = max(_longest_runs(si & (across | ri)), _longest_runs((si & (~across | ri)).T))
        out.append({"object": o.path, "pixels": int(mine.sum()), "stretched_px": int(si.sum()),
                    "repeated_px": int(ri.sum()), "wall_fraction": round(run / w, 4)})
    return out


def within_targets(figure: dict) -> bool:
    return all(lo <= figure[k] <= hi for k, (lo, hi) in TARGETS.items())


def contact_sheet(tiles: list[tuple[str, np.ndarray | None]]) -> np.ndarray:
    """One row of labelled pictures (RGB uint8, each scaled to :data:`TILE_HEIGHT`); a missing one is grey."""
    row = []
    for label, img in tiles:
        if img is None:
            img = np.full((TILE_HEIGHT, TILE_HEIGHT, 3), 90, np.uint8)
        scale = TILE_HEIGHT / img.shape[0]
        tile = cv2.resize(img, (max(1, round(img.shape[1] * scale)), TILE_HEIGHT), interpolation=cv2.INTER_AREA)
        tile = np.ascontiguousarray(tile)
        cv2.rectangle(tile, (0, 0), (8 + 9 * len(label), 22), (0, 0, 0), -1)
        cv2.putText(tile, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        row.extend([tile, np.full((TILE_HEIGHT, 4, 3), 255, np.uint8)])
    return np.concatenate(row[:-1], axis=1)


def preview_opening(shot: pathlib.Path, timeout: float = 240.0, play: float = 0.0) -> np.ndarray | None:
    """The preview's opening view of ``shot`` as headless Chromium shows it, cut to the photo's letterboxed
    rectangle (RGB uint8, the canvas's pixels); after ``play`` seconds of playing with nothing touched where
    ``play`` > 0; None where Playwright or Chromium is not installed."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    chromium = next((p for p in ("/usr/bin/chromium", "/usr/bin/chromium-browser") if pathlib.Path(p).exists()),
                    None)
    if chromium is None:
        return None
    from ..preview.scene import photo_view
    from ..usd import layers

    view, _ = photo_view(layers.open_shot(shot))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "physomni_usd.cli", "preview", str(shot), "--port", str(port),
                             "--no-open", "--duration", str(timeout)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    ready = threading.Event()

    def read():
        for line in proc.stderr:
            if line.startswith("preview: http://"):
                ready.set()
        ready.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        if not ready.wait(timeout) or proc.poll() is not None:
            return None
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=[
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"])
            page = browser.new_page(viewport={"width": 1600, "height": 720})
            page.goto(f"http://127.0.0.1:{port}")
            page.get_by_role("button", name="Play").wait_for(timeout=120000)
            for close in page.locator("[role=alert] button").all():  # notifications are not the view
                close.click()
            if play > 0:
                page.get_by_role("button", name="Play").click(timeout=30000)
                page.get_by_role("button", name="Pause").wait_for(timeout=30000)
                page.wait_for_timeout(1000 * play)
            page.wait_for_timeout(2500)
            png = page.screenshot()
            c = page.locator("canvas").first.bounding_box()
            browser.close()
    finally:
        proc.terminate()
        proc.wait(60)
    img = cv2.cvtColor(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    scale = min(c["width"] / view.width, c["height"] / view.height)
    x0 = int(round(c["x"] + (c["width"] - view.width * scale) / 2))
    y0 = int(round(c["y"] + (c["height"] - view.height * scale) / 2))
    return img[y0:y0 + int(round(view.height * scale)), x0:x0 + int(round(view.width * scale))]


def look_example(example: pathlib.Path, work: pathlib.Path, size: int, seconds: float | None,
                 browser: bool = True) -> tuple[dict, np.ndarray]:
    """Build, simulate and render one example in ``work``; returns its figures and its contact sheet."""
    import physomni_usd as api

    from ..metrics import mirror_similarity, ssim
    from ..rendering.stage import read_wide_plate
    from ..rendering.video import ShotRenderer, render_shot
    from ..settings import REST_SECONDS, RenderSettings, SimulateSettings
    from ..usd import layers

    spec_path = example / "example.json"
    if not spec_path.is_file():
        raise InputError(f"{example} has no example.json (photo, masks or boxes, push)")
    spec = json.loads(spec_path.read_text())
    masks = [str(example / m) for m in spec.get("masks", [])]
    result = api.build(example / spec["photo"], work / "shot", masks, spec.get("boxes", []),
                       pushes=spec.get("push", []), sizes=spec.get("size", []))
    # as run.sh runs it: an example that gives no length ends once nothing has moved for a second
    given = seconds or spec.get("seconds")
    api.simulate(result.shot, SimulateSettings(rest_seconds=None if given else REST_SECONDS,
                                               **({"seconds": float(given)} if given else {})))
    settings = RenderSettings(max_size=size)
    stage = layers.open_shot(result.shot)
    renderer = ShotRenderer(stage, settings)
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    frame0 = renderer.frame(float(start))
    middle = renderer.frame(float((start + end) // 2))
    last, state = renderer.render(float(end))
    unshaded = ShotRenderer(stage, RenderSettings(max_size=size, shadow_strength=0.0)).frame(float(end))
    photo = cv2.cvtColor(cv2.imread(str(example / spec["photo"])), cv2.COLOR_BGR2RGB)
    small = cv2.resize(photo, frame0.shape[1::-1], interpolation=cv2.INTER_AREA)
    figures = {"example": example.name, "frames": end - start + 1, "width": renderer.width,
               "height": renderer.height, "push": spec.get("push", []),
               "frame0_psnr_db": round(float(cv2.PSNR(frame0, small)), 2),
               "revealed": revealed_figures(renderer, last, state, unshaded)}
    opening = preview_opening(result.shot) if browser else None
    if opening is not None:
        o = cv2.resize(opening, photo.shape[1::-1], interpolation=cv2.INTER_AREA)
        figures["preview_ssim"] = round(float(ssim(cv2.cvtColor(o, cv2.COLOR_RGB2GRAY),
                                                   cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY))), 4)
    render_shot(result.shot, work / "orbit.mp4", settings, camera="orbit-left")
    orbit_renderer = ShotRenderer(layers.open_shot(result.shot), settings)
    orbit, orbit_state = orbit_renderer.render(float(end))
    walls = orbit_walls(orbit_renderer, orbit_state)
    figures["orbit_walls"] = walls
    figures["orbit_wall_max"] = max((x["wall_fraction"] for x in walls), default=0.0)
    wide = read_wide_plate(stage)
    if wide is not None:
        figures["wide_plate_mirror"] = round(mirror_similarity(*wide), 3)
    sheet = contact_sheet([("photo", small), ("frame 0", frame0), ("middle", middle), ("last", last),
                           ("orbit-left, last", orbit), ("preview opening", opening)])
    return figures, sheet


def fill_truth_figure(n: int, seed: int, out_dir: pathlib.Path, echo=print) -> dict:
    """The fill against the truth (:mod:`.fill_truth`): ``n`` generated scenes from ``seed`` rendered with their
    objects and without them, the plate of each fill method held against the empty render in the revealed area
    (renders and plates in ``out_dir``). Returns the means per method, per scene each method's error and
    farthest colour, and the scenes where the plate's default fill errs at most as much as the better of Telea's
    and the blend's with no revealed pixel farther than :data:`~.fill_truth.FAR_LEVELS` from its surroundings'
    colours; and, under ``novel_views``, each object's silhouette from ±45° (:func:`novel_view_figure`)."""
    from .fill_truth import bench_fill_truth

    numbers = bench_fill_truth(n, seed, out_dir, echo=echo)
    keep = ("error", "error_local", "far", "far_max")
    return {"seed": seed, "n": n, "summary": numbers["summary"], "held": numbers.get("held"),
            "scenes": [{"seed": r["seed"], "layout": r["layout"], "revealed_px": r["revealed_px"],
                        "methods": {m: {k: v[k] for k in keep} for m, v in r["methods"].items()}}
                       for r in numbers["rows"]],
            "novel_views": novel_view_figure(numbers["rows"], seed, out_dir, echo)}


def novel_view_figure(rows: list[dict], seed: int, out_dir: pathlib.Path, echo=print) -> dict:
    """What a moved object looks like from a novel view: each generated scene of ``rows`` (as
    :func:`~.fill_truth.bench_fill_truth` rendered them under ``out_dir``) built from its visible masks as ``bench
    general`` builds it, and each object's silhouette from the camera orbited -45 and +45 degrees held against
    the truth render's (IoU, the lesser of the two; :func:`~.general.build_row`). A push moves an object, it does
    not change its shape: the lifted mesh is what a novel view shows of it. Returns each object's IoU and how
    many reach ``bench general``'s limit."""
    from .general import LIMITS, scene_rows

    objects = []
    for r in rows:
        index = r["index"]
        for row in scene_rows(index, seed, out_dir / f"scene_{index:03d}" / "scene", modes=("masks",), seconds=0.2,
                              echo=lambda m: None):
            if not row.get("built"):
                echo(f"scene {r['seed']}: not built ({row.get('error')}); its objects count as missing")
            for o in row["objects"]:
                iou = min(o.get("iou_left", 0.0), o.get("iou_right", 0.0))
                objects.append({"seed": r["seed"], "label": o.get("label"), "iou_novel": round(float(iou), 3)})
    limit = LIMITS["iou_novel"]
    held = sum(o["iou_novel"] >= limit for o in objects)
    echo(f"novel views: {held} of {len(objects)} objects' silhouettes from ±45° at IoU ≥ {limit:g} against the truth"
         + (f" (median {np.median([o['iou_novel'] for o in objects]):.2f})" if objects else ""))
    return {"limit": limit, "objects": objects, "held": held}


def bench_look(examples: list[pathlib.Path], out_dir: pathlib.Path, size: int = 880, seconds: float | None = None,
               browser: bool = True, echo=print, truth_scenes: int = 0, truth_seed: int = 1) -> dict:
    """A contact sheet (``out_dir/<example>.png``) and the figures of every example in ``examples``;
    returns the figures by example (also written to ``out_dir/look.json``). No ``examples``: every folder
    of ``examples/`` here that has an example.json (InputError where there is none), unless ``truth_scenes``
    is given. With ``truth_scenes`` > 0, also the fill's truth figure (:func:`fill_truth_figure`) on that many
    generated scenes from ``truth_seed``, under ``fill_truth`` (renders and plates in ``out_dir/fill_truth``)."""
    LOOK.check(size=size, seconds=seconds)  # before any work, as the command refuses them

    from .._files import make_dirs, write_json

    examples = list(examples)
    if not examples and truth_scenes <= 0:
        examples = sorted(p.parent for p in pathlib.Path("examples").glob("*/example.json"))
        if not examples:
            raise InputError("bench look: no --example given and no examples/*/example.json here")
    make_dirs(out_dir)
    out = {}
    echo(f"{'example':<12}{'frame 0 dB':>11}{'preview SSIM':>14}{'orbit wall':>11}{'mirror':>8}"
         "  revealed: px, gradient, border, colour (as shown: gradient, border, plain colour)")
    for example in examples:
        with tempfile.TemporaryDirectory(prefix="physomni-look-") as tmp:
            figures, sheet = look_example(pathlib.Path(example), pathlib.Path(tmp), size, seconds, browser)
        ok = cv2.imwrite(str(out_dir / f"{figures['example']}.png"), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
        if not ok:
            raise InputError(f"cannot write {out_dir / (figures['example'] + '.png')}")
        out[figures["example"]] = figures
        rev = "; ".join(f"{r['object'].rsplit('/', 1)[-1]} {r['revealed_px']} px, {r['gradient_ratio']:.2f}, "
                        f"{r['border_ratio']:.2f}, {r['colour_difference']:.1f} (as shown {r['gradient_ratio_as_shown']:.2f}, "
                        f"{r['border_ratio_as_shown']:.2f}, {r['colour_difference_plain']:.1f})"
                        + ("" if within_targets(r) else " (off target)") for r in figures["revealed"]) or "none"
        ssim_text = f"{figures['preview_ssim']:.3f}" if "preview_ssim" in figures else "-"
        wall = f"{100 * figures['orbit_wall_max']:.1f} %" + ("" if figures["orbit_wall_max"] <= MAX_WALL else "!")
        mirror = f"{figures['wide_plate_mirror']:.2f}" if "wide_plate_mirror" in figures else "-"
        echo(f"{figures['example']:<12}{figures['frame0_psnr_db']:>11.2f}{ssim_text:>14}{wall:>11}{mirror:>8}  {rev}")
    if truth_scenes > 0:
        out["fill_truth"] = fill_truth_figure(truth_scenes, truth_seed, out_dir / "fill_truth", echo)
    write_json(out_dir / "look.json", out)
    return out
