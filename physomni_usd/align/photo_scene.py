"""The built-in (no model) scene from a photo: camera, lifted objects, real scale, support, room.

Owns the order of the silhouette path, in two halves that ``build`` runs as
its *lift* and *place* stages. :func:`lift_photo_scene` (the built-in
lifter): the camera is estimated from the photo (``align/cues.py``) under a
unit camera height, objects resting on others are found (``align/support.py``)
and read against the occlusion order (``perceive/amodal.py``: what an
occluder hides is no contact, and a hidden foot reaches down behind it),
every object is lifted (``lift/silhouette.py``; what is wider than the mouth of the vessel it stands in rests
on its rim, ``lift/rim.py``) and the scene's scale is fixed
from the objects' typical sizes (``align/scale.py``). :func:`place_on_ground`:
objects resting on others move with them, the rest are kept apart
(``align/place.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from ..sizes import size_prior
from ..perceive.amodal import occlusion_order
from ..lift.silhouette import FLAT_PRIOR_RATIO, fill_holes, foot_pixel, lift_silhouette, plane_points
from ..settings import BuildSettings
from ..errors import InputError
from ..geometry.camera import PinholeCamera, pick_pitch
from ..geometry.mesh import longest_dimension
from ..geometry.resting import FOOT_CUT, contact_band, solid_com, steady_margin
from .compare import (MIN_GAIN_FRACTION, STRONG_GAIN_FRACTION, prior_terms, search_pitch, search_row, search_view,
                      score_scene)
from .cues import (ELLIPSE_IOU, FEET_CUE, FEET_WEIGHT, MAX_PITCH_DEG, estimate_camera, mask_ellipse, min_pitch,
                   row_pitch, weighted_median)
from .place import footprint, make_room, separate
from .scale import fit_scale
from .support import (TOP_BAND, find_supports, into_hollow, raise_unseen, reach_under, rests_on, riders, root_of,
                      reaching_under, settle_on_supports, support_order, supports_from_above)

#: Scale-and-lift rounds: an object's height from its prior depends on the scale, the scale on the lifted sizes.
SCALE_ROUNDS = 3
#: A cue at least this heavy (``align.cues``) confines the pitch search to CUE_WINDOW_DEG either side of the
#: cues' pitch ...
STRONG_CUE = 0.5
CUE_WINDOW_DEG = 20.0
#: ... and readings within CUE_WINDOW_DEG of it weighing less than this together (a vanishing point on fewer
#: than ten segments: a tabletop's printed lines can be five) are trusted only while the silhouettes prefer no
#: pitch more than CUE_WINDOW_DEG shallower.
TRUSTED_CUE = 1.0
#: ... and where no cue reads the pitch (the feet's least tilt alone, a default), another pitch replaces it
#: when it beats it by MIN_GAIN plus this fraction of its score, not MIN_GAIN_FRACTION: a default has no
#: reading of the photo to defend. Of 32 tuning scenes (bench general seeds 880417, 263429, 771904, 504846),
#: 26 were within 10° under MIN_GAIN_FRACTION and 28 under 0: three seen from 76°, 24° and 26° and kept near
#: the feet's 10° were set right, one seen from 13° went to 84° (from above every outline fits). Of the pitches
#: then about as good as the best, the best-scoring is taken, not the one nearest the default (search_pitch; the
#: pitch and view search, off by default, still takes the nearest).
NO_READING_GAIN_FRACTION = 0.0
#: ... while the pitch search weighs a pitch, each started from the scale of the nearest pitch weighed.
SEARCH_SCALE_ROUNDS = 2
#: ... on copies of the photo and masks whose longer side is at most this (pixels).
SEARCH_SIDE_PX = 320
#: ... unless an object's outline would keep fewer pixels than this there.
SEARCH_MIN_PX = 30


@dataclass
class PhotoScene:
    camera: PinholeCamera
    vertices: list[np.ndarray]  # placed, world metres
    projected: list[np.ndarray]  # where each was seen (texture coordinates come from these)
    faces: list[np.ndarray]
    shapes: list[str]
    info: dict


def surface_under(lower, upper_mask: np.ndarray, camera: PinholeCamera) -> float:
    """Height of ``lower``'s surface (a lifted mesh) where the object of ``upper_mask`` stands on it.

    The ray through the upper object's foot pixel is cast into the lower mesh; the lower mesh's top surface
    straight above where it enters is the height (a cup stands on the saucer's floor, not on its rim's
    height nor in front of it). A ray that misses the lower mesh takes its top, as a box on a crate does.
    """
    import trimesh

    top = float(lower.vertices[:, 2].max())
    mesh = trimesh.Trimesh(lower.vertices, lower.faces, process=False)
    u, v = foot_pixel(fill_holes(upper_mask))
    hits, _, _ = mesh.ray.intersects_location(camera.origin[None], camera.rays(u, v)[None])
    if not len(hits):
        return top
    first = hits[np.argmin(np.linalg.norm(hits - camera.origin, axis=1))]
    above = np.array([[first[0], first[1], top + 1.0]])
    down, _, _ = mesh.ray.intersects_location(above, np.array([[0.0, 0.0, -1.0]]))
    return float(down[:, 2].max()) if len(down) else top


def on_rim(lower, upper_mask: np.ndarray, camera: PinholeCamera, settings: BuildSettings, fit: bool = True):
    """The object of ``upper_mask`` lifted resting on the rim of ``lower`` where ``lower`` is a vessel, its foot
    shows in the vessel's mouth (``lift.rim.foot_in_mouth``) and it is wider than the mouth
    (``lift.rim.rests_on_rim``: a plant's foliage over its pot); None otherwise. Stood on the surface its
    foot's ray meets inside the mouth (the back wall), and as deep as the outline alone makes it, such a thing
    came out a slab standing on the pot's back rim, and fell.
    With ``fit`` false what rises above the rim keeps the height its rows were cast at, not the one whose
    silhouette matches best: the pitch search passes false (five renders per plant, per pitch and scale round)."""
    from ..lift.silhouette import LiftedMesh
    from ..lift.rim import foot_in_mouth, rests_on_rim

    if lower.shape != "vessel" or settings.lift.shape != "auto" \
            or not foot_in_mouth(lower.vertices, upper_mask, camera):
        return None
    from .compare import mask_iou, silhouette

    solid = fill_holes(upper_mask)
    found = rests_on_rim(lower.vertices, upper_mask, camera, settings.lift.rows, settings.lift.sections,
                         fits=(lambda v, f: mask_iou(silhouette(v, f, camera), solid)) if fit else None)
    if found is None:
        return None
    verts, faces, contact = found
    # what rests on the rim reaches into the mouth: the vessel is filled up to it (a pot's soil), which holds
    # it from below and weighs the vessel down; empty, a pot a tenth of its plant's mass sank its thin floor
    # into the ground under it, and the plant its thin rim
    from ..lift.footprint import fine_faces
    from ..lift.rim import filled, soil_level

    foot = float(verts[:, 2].min())
    level = soil_level(lower.vertices, foot)
    verts = verts + [0.0, 0.0, max(0.0, level - foot)]
    contact = contact + [0.0, 0.0, max(0.0, level - foot)]
    lower.vertices, lower.faces = fine_faces(*filled(lower.vertices, level), camera)
    lower.info["filled_to"] = round(level, 5)
    return LiftedMesh(verts, faces, "round", contact, foot_pixel(solid)[1],
                      {"mode": "standing", "shape": "round", "height_source": "silhouette",
                       "rests_on": "the rim of the vessel under it, round about its axis"})


def behind_what_hides_it(lower, upper_mask: np.ndarray, camera: PinholeCamera) -> bool:
    """Whether the object of ``upper_mask``, whose lower part ``lower`` (a lifted mesh) hides, stands on the
    ground behind it rather than on it: its foot (completed behind ``lower``) cast onto the ground lands
    past ``lower``'s footprint. A lime behind a lemon touches the lemon's outline only where the lemon
    hides it; a ball in a bowl, whose rim hides its bottom too, lands inside the bowl's footprint."""
    u, v = foot_pixel(fill_holes(upper_mask))
    ground = plane_points(camera, u, v, 0.0)
    if not np.all(np.isfinite(ground)):
        return False
    hull = footprint(lower.vertices).astype(np.float32)
    inside = cv2.pointPolygonTest(hull.reshape(-1, 1, 2), (float(ground[0]), float(ground[1])), False) >= 0
    return not inside


def lift_all(masks, labels, camera: PinholeCamera, settings: BuildSettings, scale: float, supports=None,
             photo=None, hides=(), visible=None, wall: bool = True, hollows: bool = True, rims: bool = True):
    """Each mask lifted under ``camera`` (unit height); ``scale`` turns a prior's metres into the camera's units.

    ``supports`` ({upper: (lower, how)}) stands each upper object on its lower one's surface where it
    meets it (:func:`surface_under`). ``hides`` holds (occluder, occluded) index pairs (the photo's
    occlusion order, ``perceive.amodal.occlusion_order``): an upper object its lower one hides stands on
    the ground behind it where its foot lands there (:func:`behind_what_hides_it`); such supports are
    dropped from ``supports``. With ``visible`` (what the photo shows of each), an object on the ground whose
    foot they hide reaches down behind them (:func:`foot_behind`). With ``wall`` false, what rests on nothing
    the masks show is read from its size alone, not held against the photo's wall line: the pitch search
    passes false, since a wall line read under each candidate pitch moved the pitch it chose (a wall scene of
    28° built at 10°). With ``hollows`` false, an object held by none of several alone is judged by their
    footprints only (:func:`balances_on`), not also by :func:`held_in_hollow`: the pitch search passes false,
    since that 3D test on the search's coarse copies dropped supports and moved the pitch it chose (a pile
    taken at 30° went back to 14°, where it fell). With ``rims`` false, what rests on a vessel's rim is not
    fitted to its outline by rendering (:func:`on_rim`'s ``fit``): the pitch search passes false, for its cost.
    """
    supports = supports or {}
    hides = set(hides)
    out = [None] * len(masks)
    started = set()

    def seen_options(i):
        """What the photo shows of ``i``, and what may hide it: every other object but those ``i`` hides (behind it,
        they are its background: a fruit's edge against the bowl it lies in is its own)."""
        if visible is None:
            return {}
        front = [np.asarray(visible[j], bool) for j in range(len(visible)) if j != i and (i, j) not in hides]
        return {"visible": visible[i], "occluders": np.any(front, axis=0) if front else None}

    def place(i):
        """Lifts ``i`` on what holds it; lifts, first, what it could rest on together with that (the
        objects around it in a pile), so its balance is judged over all of them."""
        if i in started:
            return
        started.add(i)
        if i in supports:
            place(supports[i][0])
        if i in supports and (supports[i][0], i) in hides and behind_what_hides_it(out[supports[i][0]], masks[i],
                                                                                      camera):
            supports.pop(i)
        base = surface_under(out[supports[i][0]], masks[i], camera) if i in supports else 0.0
        kwargs = _lift_options(labels[i], scale, photo) | seen_options(i)
        if i in supports and (seated := on_rim(out[supports[i][0]], masks[i], camera, settings, rims)) is not None:
            out[i] = seated
            return
        try:
            out[i] = lift_silhouette(masks[i], camera, settings.lift, base_z=base, **kwargs)
        except ValueError:
            if i not in supports:
                raise InputError(f"object {i} ({labels[i]}): its lowest pixel is above the horizon of a camera "
                                 f"pitched {camera.pitch_deg:.0f}° down; give --pitch (and --fov)") from None
            # the lower object's top stands above where this one's foot looks (a wrong pitch, a mask that
            # takes in part of the other): the object stands on the ground instead of failing the build
            supports.pop(i)
            out[i] = lift_silhouette(masks[i], camera, settings.lift, base_z=0.0, **kwargs)
            return
        if i in supports and not balances_on(out[i], out[supports[i][0]], base):
            # the lower one may only be lifted too shallow: its top, which this one hides, shows no depth
            deeper = reach_under(out[supports[i][0]], out[i], camera, base)
            if deeper is not None:
                out[supports[i][0]].vertices = deeper
        if i in supports and not balances_on(out[i], out[supports[i][0]], base):
            # a fruit in the hollow on top of a pile, a board bridging two boxes: no one object under it holds
            # its centre, the ones it touches together may. What rests on it, through others, cannot hold it.
            # One read as resting on it where it hides that one's foot may be behind it on the ground instead:
            # this one's outline covers that foot, it does not show it standing there (the back fruit of a pile,
            # its outline a disc behind the top one's, read as on that top one, left the top one two fruit to
            # stand on, and it stood a fruit's length behind the pile it hides).
            # What rests on such a one goes with it (a grape on the back fruit): it holds nothing here.
            behind = [k for k in range(len(masks)) if k in supports and supports[k][0] == i and (i, k) in hides
                      and k not in started]
            carried = {k: [m for m in riders(k, supports) if m != k] for k in behind}
            kept = {k: supports.pop(k) for k in behind}
            beside = [k for k in range(len(masks)) if k not in (i, supports[i][0]) and not rests_on(k, i, supports)
                      and not any(k in c for c in carried.values())]
            for k in beside:
                place(k)

            def holds(ks):
                others = [out[k] for k in ks if out[k] is not None]
                return balances_on(out[i], out[supports[i][0]], base, others) \
                    and (not hollows or held_in_hollow(out[i], out[supports[i][0]], others, camera, scale))

            held = holds(beside)
            for k in list(kept):
                # each that is not needed to hold it rests on it as read, lifted again after it: one truly on
                # top must not be grounded behind the pile because another candidate holds it
                without = [m for m in beside if m != k]
                if not held or holds(without):
                    supports[k] = kept.pop(k)
                    started.difference_update([k, *carried[k]])
                    beside = without if held else beside
            for k in kept if held else ():
                # standing on the ground behind it, it holds this one up: nothing may move it from under it
                out[k].info.setdefault("holds", []).append(i)
            if not held:
                # standing on the lower one's surface it would topple off it (a box on the crown of a crumpled
                # bag): the photo shows it as well standing on the ground, where it stays
                supports.pop(i)
                out[i] = lift_silhouette(masks[i], camera, settings.lift, base_z=0.0, **kwargs)
            else:
                out[i].info["held_by_several"] = True

    for i in support_order(len(masks), supports):
        place(i)
    for i in range(len(masks)) if visible is not None else ():
        if i in supports or any(j == i for j, _ in supports.values()) or out[i].info.get("holds"):
            continue
        front = in_front_of(i, masks, visible, hides)
        reached = foot_behind(masks[i], [visible[a] for a in front], [out[a] for a in front], camera)
        if reached is not None:
            out[i] = lift_silhouette(reached, camera, settings.lift, base_z=0.0,
                                     **_lift_options(labels[i], scale, photo), **seen_options(i))
            out[i].info["foot"] = "reached down behind what hides it"
    # what rests on something the masks do not show (a shelf, a wall) stands where its size agrees with the others'
    raise_unseen(out, labels, supports, camera, scale, photo=photo if wall else None,
                 masks=masks if wall else None)
    return out


def in_front_of(i: int, masks, visible, hides) -> list[int]:
    """The objects that hide ``i`` (``hides``) and those whose visible masks touch ``i``'s completed outline
    from below: what its foot could stand behind. The occlusion order misses an occluder whose outline
    meets ``i``'s along a straight cut (a box's lid under a book)."""
    solid = fill_holes(masks[i])
    reach = max(2, int(round(0.01 * solid.shape[0])))
    grown = cv2.dilate(solid.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    foot_row = foot_pixel(solid)[1]
    out = {a for a, b in hides if b == i}
    for j, m in enumerate(visible):
        if j != i and (grown & m).any() and foot_pixel(fill_holes(m))[1] > foot_row:
            out.add(j)
    return sorted(out)


def _lift_options(label: str, scale: float, photo) -> dict:
    """``lift_silhouette``'s keywords from ``label``'s typical size, at ``scale`` metres per camera unit."""
    prior = size_prior(label)
    hint = prior.height_m / scale if prior is not None and prior.height_m else None
    flat = bool(prior and prior.height_m and prior.height_m <= FLAT_PRIOR_RATIO * prior.longest_m)
    return dict(height_hint=hint, prior_shape=prior.shape if prior else None, flat=flat, photo=photo, label=label)


def foot_behind(mask: np.ndarray, occluder_masks, occluders, camera: PinholeCamera) -> np.ndarray | None:
    """``mask`` (H, W) bool reaching down, behind what hides its foot, to the ground just behind it; None when
    its foot shows, or already stands at or in front of that ground.

    Where the photo hides an object's foot, its completed outline (``perceive.amodal``) only closes what
    shows: cast onto the ground, that guessed foot can land far behind the objects in front (a book whose
    lower half two boxes hide would come out metres tall); a round one (an ellipse, a lime behind a lemon)
    is whole and keeps its foot. Of the readings the photo allows, the nearest
    is taken: the object reaches down behind its occluders to the ground just behind them (the row where
    the highest of the occluders' base vertices project), each column continued only through pixels they
    hide, so frame 0 is unchanged. ``occluder_masks``: their visible masks; ``occluders``: their lifted
    meshes under ``camera``.
    """
    if not occluders:
        return None
    solid = fill_holes(mask)
    h = solid.shape[0]
    reach = max(2, int(round(0.01 * h)))
    hidden = np.logical_or.reduce([np.asarray(m, bool) for m in occluder_masks])
    hidden = cv2.dilate(hidden.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    u, v = foot_pixel(solid)
    if not hidden[min(int(v), h - 1), min(int(u), solid.shape[1] - 1)]:
        return None
    round_ = mask_ellipse(solid)
    if round_ is not None and round_[1] >= ELLIPSE_IOU:  # a round outline completes whole: its foot is known
        return None
    back = []
    for m in occluders:
        z = m.vertices[:, 2]
        base = m.vertices[z <= z.min() + 0.02 * max(float(np.ptp(z)), 1e-9)]
        uv, depth = camera.project(base)
        if (depth > 0).any():
            back.append(float(uv[depth > 0, 1].min()))
    if not back:
        return None
    target = int(np.floor(min(back))) - 1  # just behind the farthest of them
    if target <= v:
        return None
    out = solid.copy()
    for c in np.nonzero(solid.any(axis=0))[0]:
        bottom = h - 1 - int(np.argmax(solid[::-1, c]))
        r = bottom + 1
        while r <= min(target, h - 1) and hidden[r, c] and not solid[r, c]:
            out[r, c] = True
            r += 1
    return out if foot_pixel(out)[1] > v + 1 else None


#: A lifted object stands on a rounded foot where the part of it within ``geometry.resting.FOOT_CUT`` of its
#: height above its lowest point covers, seen from above, less than this fraction of its footprint (a sphere:
#: a fifth; a box's or a board's flat bottom: all of it).
ROUNDED_FOOT = 0.25


def held_in_hollow(upper, lower, others, camera: PinholeCamera, scale: float) -> bool:
    """Whether ``upper``, stood on ``lower`` and held by none of them alone, is held among ``lower`` and
    ``others`` (lifted at unit height; ``scale`` metres per unit) as the steadying pass will find it: on a
    rounded foot (:data:`ROUNDED_FOOT`), only where that pass lowers it into their hollow
    (``align.support.into_hollow``); where none holds it, that pass moves it onto ``lower``'s top alone, a dome
    it rolls off (a lemon read as on an apple, beside a taller lemon, fell 19 cm and pushed two fruit 11-13 cm).
    A flat foot (a board over two boxes lifted at two heights) tips onto all of them: held."""
    verts = [scale * np.asarray(m.vertices, float) for m in (upper, lower, *others)]
    faces = [np.asarray(m.faces) for m in (upper, lower, *others)]
    pts = verts[0]
    low = float(pts[:, 2].min())
    # the foot and margin the steadying pass (``physics.support.steady_stacks``) judges it by
    foot = pts[pts[:, 2] <= low + contact_band(pts), :2]
    sole = pts[pts[:, 2] <= low + FOOT_CUT * float(np.ptp(pts[:, 2])), :2]
    if len(sole) >= 3 and cv2.contourArea(footprint(sole).astype(np.float32)) \
            >= ROUNDED_FOOT * cv2.contourArea(footprint(pts).astype(np.float32)):
        return True
    margin = steady_margin(foot)
    eye = scale * np.asarray(camera.origin, float)
    return into_hollow(verts, faces, {0: (1, "contact")}, 0, solid_com(pts, faces[0]), eye, margin, 0.0) is not None


def balances_on(upper, lower, base: float, others=()) -> bool:
    """Whether ``upper`` (a lifted mesh standing at height ``base`` on ``lower``) has its centre over what holds
    it: seen from above, inside the convex hull of the part of ``lower`` that reaches up to ``base`` (its
    vertices no lower than ``TOP_BAND`` of its height below ``base``) together with where each of ``others``
    (lifted meshes beside it: the fruit of a pile, the second box under a board) reaches up under ``upper``
    (their part between that band and ``upper``'s mid-height, cut to ``upper``'s footprint; one that rises past
    that middle within the footprint stands beside it): the hull of its contacts with all it rests on. Its vertices' mean stands for the centre of mass."""
    z = lower.vertices[:, 2]
    points = [lower.vertices[z >= base - TOP_BAND * max(float(np.ptp(z)), 1e-9), :2]]
    zu = upper.vertices[:, 2]
    mid = 0.5 * (float(zu.min()) + float(zu.max()))
    over = footprint(upper.vertices)
    # OpenCV's polygon intersection loses small (metre-scale) polygons: cut them in a frame where upper is ~1000
    origin, unit = over.mean(0), 1e-3 * max(float(np.ptp(over, axis=0).max()), 1e-9)
    edges = np.roll(over, -1, axis=0) - over
    for other in others:
        zo = other.vertices[:, 2]
        rel = other.vertices[:, None, :2] - over[None]
        under = (edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0] >= 0).all(axis=1)
        if (zo[under] > mid).any():
            # it rises past upper's middle where it stands under it: beside it (a wedge a banana leans on,
            # the object in front of it), not under it
            continue
        band = other.vertices[(zo >= base - TOP_BAND * max(float(np.ptp(zo)), 1e-9)) & (zo <= mid)]
        if len(band) < 3:
            continue
        area, met = cv2.intersectConvexConvex(((footprint(band) - origin) / unit).astype(np.float32),
                                              ((over - origin) / unit).astype(np.float32))
        if area > 0 and met is not None:
            points.append(met.reshape(-1, 2).astype(float) * unit + origin)
    points = np.concatenate(points)
    if len(points) < 3:
        return False
    hull = footprint(points).astype(np.float32).reshape(-1, 1, 2)
    centre = upper.vertices[:, :2].mean(0)
    return cv2.pointPolygonTest(hull, (float(centre[0]), float(centre[1])), False) >= 0


@dataclass
class GroundLift:
    """Every object lifted on the ground measured in the photo: world metres, z up, the ground at z = 0."""

    camera: PinholeCamera
    lifted: list  # lift.silhouette.LiftedMesh, one per mask, at the photo's scale
    supports: dict[int, tuple[int, str]]  # {upper: (lower, how it was seen)}
    info: dict  # the camera's cues and the scale's votes, for the report


def lift_photo_scene(masks, labels, names, photo, settings: BuildSettings, user_sizes=None,
                     visible=None) -> GroundLift:
    """Each object of ``photo`` lifted from its mask and stood, at the photo's scale, where the photo shows it
    (on the ground, or on the object it rests on).

    ``masks`` are the outlines to lift (completed behind what hides them); ``visible`` (default ``masks``)
    what the photo shows of each, from which the occlusion order is read."""
    h, w = photo.shape[:2]
    cam_cfg = settings.camera
    feet = [foot_pixel(fill_holes(m))[1] for m in masks]
    est = estimate_camera(photo, masks, labels, feet, cam_cfg.fov_deg, cam_cfg.pitch_deg, cam_cfg.fov_source)
    if est.min_pitch_deg > MAX_PITCH_DEG:
        raise InputError("objects' feet are too high in the photo for any camera pitch; give --pitch and --fov")
    pitch = est.pitch_deg
    camera_warnings = []
    if cam_cfg.pitch_deg is not None:  # the user's, checked against the feet
        given = float(cam_cfg.pitch_deg)
        if given < est.min_pitch_deg:
            # the feet above that camera's horizon could stand on no ground below it: of the cameras that
            # stand every object on the ground, the one nearest the user's is taken, and said
            given = est.min_pitch_deg + 1e-6
            camera_warnings.append(f"--pitch {cam_cfg.pitch_deg:g} puts an object's foot above the horizon, where "
                                   f"no ground below the camera can hold it; the camera is pitched {given:.1f}°, "
                                   f"the least that stands every object on the ground")
        pitch = min(pick_pitch(est.fov_deg, h, feet, given), MAX_PITCH_DEG)
    camera_info = est.as_dict() | {"pitch_deg": round(pitch, 3)}
    if camera_warnings:
        camera_info |= {"pitch_given_deg": float(cam_cfg.pitch_deg), "warnings": camera_warnings}
    hides = occlusion_order(list(visible)) if visible is not None else []
    found = find_supports(masks, hides)

    searching = True
    scales: dict[float, float] = {}  # pitch → the scale its lift settled on: a start for the pitches near it
    small = _search_copies(photo, masks, visible)  # the search weighs pitches on copies at most SEARCH_SIDE_PX

    fov = est.fov_deg

    def lift_at(p: float, f: float | None = None):
        ph, ms, vs = small if searching else (photo, masks, visible)
        unit = PinholeCamera(ph.shape[1], ph.shape[0], fov if f is None else f, p, (0.0, 0.0, 1.0))
        # the search starts each pitch from the nearest one's scale; the pitch taken is lifted as without the
        # search (from 1), so that where the cues' pitch stands the scene is the one the cues alone build
        start = scales[min(scales, key=lambda q: abs(q - p))] if scales and searching else 1.0
        out = _lift_scaled(ms, labels, names, unit, settings, found, hides, ph, vs, user_sizes, start,
                           SEARCH_SCALE_ROUNDS if searching else SCALE_ROUNDS, wall=not searching,
                           hollows=not searching, rims=not searching)
        scales[p] = out[3]
        return (unit, *out)

    if cam_cfg.pitch_deg is None and settings.render_compare:
        # the photo is the arbiter: the cues' pitch against the others, each scene lifted and compared with the
        # masks (align.compare); the cues' stands unless another explains the silhouettes clearly better
        # a pitch a strong cue reads (a vanishing point, an ellipse) is searched about, not over the whole
        # range, and gives way only to a far better one: a lift seen from straight above matches any outline,
        # so the silhouettes alone favour it
        readings = [c for c in est.cues if c.pitch_deg is not None and c.kind != FEET_CUE and c.weight > 0]
        heaviest = max((c.weight for c in readings), default=0.0)
        strong = heaviest >= STRONG_CUE
        window = CUE_WINDOW_DEG if strong else 90.0
        # readings that agree add up (four ellipses of one tray of sweets, each light, all reading straight down)
        agreeing = sum(c.weight for c in readings if abs(c.pitch_deg - pitch) <= CUE_WINDOW_DEG)
        gain = STRONG_GAIN_FRACTION if strong else MIN_GAIN_FRACTION if readings else NO_READING_GAIN_FRACTION
        # readings too light to move the weighted median (a steep horizon nothing confirms) still say which of
        # the pitches the silhouettes find as good as the best to take
        anchor = None
        if readings and heaviest < FEET_WEIGHT:
            anchor = weighted_median([c.pitch_deg for c in readings], [c.weight for c in readings])
        free_fov = settings.render_compare_fov and cam_cfg.fov_deg is None and est.fov_source.startswith("default")
        lowest = est.min_pitch_deg
        row_cue = max(readings, key=lambda c: c.weight, default=None)
        if (not free_fov and cam_cfg.fov_deg is None and est.fov_source.startswith("default") and strong
                and row_pitch(row_cue, fov, h) is not None):
            # one vanishing row reads the pitch only under a field of view nothing reads: the fields of view
            # along the curve it fixes are weighed by the silhouettes (and by the feet, which a wrong one can
            # put above the horizon)
            try:
                along = search_row(lambda p, f: _scored(lambda q: lift_at(q, f), p, small[1], labels, found),
                                   lambda f: row_pitch(row_cue, f, h), fov, lambda f: min_pitch(f, h, feet))
            except ValueError:
                along = None
            if along is not None:
                camera_info["row_search"] = along.as_dict()
            if along is not None and along.fov_deg != round(fov, 3):
                # the pitch moves with the field of view along the row: left at the default view's, the report
                # said 42° for a camera built at 27° (bench general seed 235726, scene 11)
                lowest = min_pitch(along.fov_deg, h, feet)
                camera_info |= {"fov_deg": round(along.fov_deg, 3), "cue_fov_deg": round(fov, 3),
                                "fov_source": f"render-and-compare along the row of the {row_cue.kind}",
                                "pitch_deg": round(along.pitch_deg, 3), "min_pitch_deg": round(lowest, 3)}
                fov, pitch = along.fov_deg, along.pitch_deg
        try:
            if free_fov:  # no cue reads the field of view: it is searched with the pitch (align.compare.search_view)
                feet = _feet(small[1])
                searched = search_view(lambda p, f: _scored(lambda q: lift_at(q, f), p, small[1], labels, found),
                                       pitch, fov,
                                       lambda f: max(min_pitch(f, small[0].shape[0], feet), 0.0, pitch - window),
                                       min(MAX_PITCH_DEG, pitch + window), gain_fraction=gain)
            else:
                searched = search_pitch(lambda p: _scored(lift_at, p, small[1], labels, found), pitch,
                                        max(lowest, 0.0), MAX_PITCH_DEG, gain_fraction=gain,
                                        window_deg=window if strong else None,
                                        trust_deg=CUE_WINDOW_DEG if strong and agreeing < TRUSTED_CUE else None,
                                        anchor=anchor, pick="nearest" if readings else "best")
        except ValueError:  # no pitch lifted a scene the search could score: the cues' pitch, as without it
            searched = None
            camera_info["render_compare"] = {"chosen": "cues", "skipped": "no pitch tried gave a scene"}
        if searched is not None:
            camera_info["render_compare"] = searched.as_dict()
        if searched is not None and searched.pitch_deg != round(pitch, 3):
            camera_info |= {"cue_pitch_deg": round(pitch, 3), "pitch_deg": round(searched.pitch_deg, 3),
                            "pitch_source": "render-and-compare (silhouettes, sizes, supports)"}
            pitch = searched.pitch_deg
        if searched is not None and free_fov and searched.fov_deg != round(fov, 3):
            camera_info |= {"fov_deg": round(searched.fov_deg, 3), "cue_fov_deg": round(fov, 3),
                            "fov_source": "render-and-compare (silhouettes, sizes, supports)"}
            fov = searched.fov_deg
    searching = False
    unit, lifted, supports, fit, scale = lift_at(pitch)
    lifted = [replace(m, vertices=m.vertices * scale, contact=m.contact * scale) for m in lifted]
    camera = PinholeCamera(w, h, unit.fov_deg, unit.pitch_deg, (0.0, 0.0, scale))
    return GroundLift(camera, lifted, supports, {"scale": fit.as_dict(camera.origin[2]), "camera": camera_info})


def _feet(masks) -> list[float]:
    return [foot_pixel(fill_holes(m))[1] for m in masks]


def _search_copies(photo: np.ndarray, masks, visible):
    """(photo, masks, visible) shrunk so that the longer side is at most :data:`SEARCH_SIDE_PX` (as they are
    when already no larger): the pitch search lifts the scene a dozen times, and a pitch is no finer for more
    pixels."""
    h, w = photo.shape[:2]
    f = SEARCH_SIDE_PX / max(h, w)
    if f >= 1.0:
        return photo, masks, visible
    size = (max(8, int(round(w * f))), max(8, int(round(h * f))))

    def shrink(m):
        return cv2.resize(np.asarray(m, np.uint8) * 255, size, interpolation=cv2.INTER_AREA) >= 128

    out = [shrink(m) for m in masks]
    if any(m.sum() < SEARCH_MIN_PX for m in out):  # a small thing would vanish: the search takes the photo itself
        return photo, masks, visible
    return (cv2.resize(photo, size, interpolation=cv2.INTER_AREA), out,
            None if visible is None else [shrink(m) for m in visible])


def _lift_scaled(masks, labels, names, unit: PinholeCamera, settings: BuildSettings, found, hides, photo, visible,
                 user_sizes, scale: float = 1.0, rounds: int = SCALE_ROUNDS, wall: bool = True,
                 hollows: bool = True, rims: bool = True):
    """Every mask lifted under the unit-height camera ``unit`` at the scene's scale, the scale and the lift
    agreeing (:data:`SCALE_ROUNDS`, from ``scale``): (lifted at unit height, supports kept, the scale's fit,
    its factor)."""
    fit = None
    # what the masks say rests on what, and the outlines reaching under what rests on them, do not change with
    # the scale: read once
    seen = masks if visible is None else visible
    above = supports_from_above(masks, seen, hides, unit, found)
    reached = reaching_under(masks, seen, above)
    for _ in range(rounds):
        # every round judges the supports afresh: a first round's lift, at a guessed scale, can stand a cup
        # off its saucer's back, and a support dropped then would stay dropped
        supports = dict(above)
        lifted = lift_all(reached, labels, unit, settings, scale, supports, photo=photo, hides=hides,
                          visible=visible, wall=wall, hollows=hollows, rims=rims)
        longest = [longest_dimension(m.vertices) for m in lifted]
        fit = fit_scale(names, labels, longest, user_sizes, settings.camera.height_m)
        if abs(np.log(fit.factor / scale)) < 1e-3:
            break
        scale = fit.factor
    return lifted, supports, fit, fit.factor


def _scored(lift_at, pitch: float, masks, labels, found):
    """The render-and-compare score (``align.compare.score_scene``) of the scene ``lift_at(pitch)`` lifts; None
    where none can be lifted under that pitch (a foot above its horizon, a lift that fails)."""
    try:
        unit, lifted, supports, fit, scale = lift_at(pitch)
    except (InputError, ValueError):
        return None
    size_logs, thin = prior_terms([m.vertices for m in lifted], labels, scale, [_height_read(m) for m in lifted])
    # a foot on another's face is the weakest reading of a support: a pitch that cannot keep it is not worse
    # nor is one read the other way up under this pitch (from above, the one the feet put on top is beneath:
    # ``support.supports_from_above``)
    shown = [i for i, (j, how) in found.items() if how != "foot" and supports.get(j, (None,))[0] != i]
    lost = sum(i not in supports for i in shown) / len(shown) if shown else 0.0
    return score_scene([m.vertices for m in lifted], [m.faces for m in lifted], unit, masks, size_logs, thin, lost)


def _height_read(lifted) -> bool:
    """Whether the lift read ``lifted``'s height from the photo, not from its label's typical size or its
    footprint's width (``lift.footprint``): only a height read can tell one pitch from another."""
    source = str(lifted.info.get("height_source") or "")
    return not (source.startswith("typical size") or "footprint's width" in source)


def _standing_ball(obj) -> bool:
    """Whether ``obj`` (a lifted object with ``ground`` evidence) is a ball seen standing: placing keeps its
    shape (``align.place.make_room``)."""
    return obj.ground.info.get("axis") == "ball"


def place_on_ground(lifted, names, gap_m: float) -> PhotoScene:
    """The scene of ``lifted`` meshes (``swappable.protocols.LiftedObject`` with ``ground`` evidence, lifted by
    :func:`lift_photo_scene`): objects resting on others move with them; the rest are made shallower, then
    moved apart, until their footprints are ``gap_m`` apart; an object left inside what holds it is raised
    onto it (``align.support.settle_on_supports``)."""
    camera = lifted[0].ground.camera
    supports = {i: o.ground.support for i, o in enumerate(lifted) if o.ground.support is not None}
    free = [i for i in range(len(lifted)) if i not in supports]
    room, scales_free = make_room([lifted[i].vertices for i in free], [lifted[i].ground.contact for i in free],
                                  camera.origin, gap_m, fixed_depth=[lifted[i].ground.fixed_depth for i in free],
                                  balls=[_standing_ball(lifted[i]) for i in free])
    moves_free = separate(room, gap_m)
    projected = [o.vertices for o in lifted]
    depth_scales = [1.0] * len(lifted)
    moves = [np.zeros(3)] * len(lifted)
    for k, i in enumerate(free):
        projected[i], depth_scales[i], moves[i] = room[k], scales_free[k], moves_free[k]
    for j in sorted({j for j, _ in supports.values()}):
        # objects on the same supporter (a cup and a spoon on a saucer) are kept apart as those on the ground
        # are, by making the nearer one shallower; they are not moved apart, which would take them off it
        on = [i for i in supports if supports[i][0] == j]
        if len(on) > 1:
            room_on, scales_on = make_room([lifted[i].vertices for i in on], [lifted[i].ground.contact for i in on],
                                           camera.origin, gap_m, fixed_depth=[lifted[i].ground.fixed_depth for i in on],
                                           balls=[_standing_ball(lifted[i]) for i in on], movable=False)
            for k, i in enumerate(on):
                projected[i], depth_scales[i] = room_on[k], scales_on[k]
    for i in supports:
        moves[i] = moves[root_of(i, supports)]
    verts, rise = settle_on_supports([v + d for v, d in zip(projected, moves)], [o.faces for o in lifted], supports,
                                     [o.shape == "vessel" for o in lifted], camera.origin)
    info = {"variant": "silhouette", "depth_scales": [round(k, 4) for k in depth_scales],
            "moved_apart_m": [round(float(np.linalg.norm(d)), 4) for d in moves],
            **({"raised_onto_support_m": {names[i]: round(r, 4) for i, r in enumerate(rise) if r > 0}}
               if any(r > 0 for r in rise) else {}),
            **({"lowered_into_vessel_m": {names[i]: round(-r, 4) for i, r in enumerate(rise) if r < 0}}
               if any(r < 0 for r in rise) else {}),
            **lifted[0].ground.scene,
            "lift": [o.ground.info for o in lifted],
            "supports": {names[i]: {"on": names[j], "seen": how} for i, (j, how) in supports.items()}}
    return PhotoScene(camera, verts, projected, [o.faces for o in lifted], [o.shape for o in lifted], info)
