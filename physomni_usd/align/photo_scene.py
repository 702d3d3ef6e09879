"""The built-in (no model) scene from a photo: camera, lifted objects, real scale, support, room.

Owns the order of the silhouette path, in two halves that ``build`` runs as
its *lift* and *place* stages. :func:`lift_photo_scene` (the built-in
lifter): the camera is estimated from the photo (``align/cues.py``) under a
unit camera height, objects resting on others are found (``align/support.py``),
every object is lifted (``lift/silhouette.py``) and the scene's scale is fixed
from the objects' typical sizes (``align/scale.py``). :func:`place_on_ground`:
objects resting on others move with them, the rest are kept apart
(``align/place.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..sizes import size_prior
from ..lift.silhouette import FLAT_PRIOR_RATIO, fill_holes, foot_pixel, lift_silhouette
from ..settings import BuildSettings
from ..errors import InputError
from ..geometry.camera import PinholeCamera, pick_pitch
from ..geometry.mesh import longest_dimension
from .cues import MAX_PITCH_DEG, estimate_camera
from .place import make_room, separate
from .scale import fit_scale
from .support import find_supports, root_of, settle_on_supports, support_order

#: Scale-and-lift rounds: an object's height from its prior depends on the scale, the scale on the lifted sizes.
SCALE_ROUNDS = 3


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


def lift_all(masks, labels, camera: PinholeCamera, settings: BuildSettings, scale: float, supports=None,
             photo=None):
    """Each mask lifted under ``camera`` (unit height); ``scale`` turns a prior's metres into the camera's units.

    ``supports`` ({upper: (lower, how)}) stands each upper object on its lower one's surface where it
    meets it (:func:`surface_under`).
    """
    supports = supports or {}
    out = [None] * len(masks)
    for i in support_order(len(masks), supports):
        prior = size_prior(labels[i])
        hint = prior.height_m / scale if prior is not None and prior.height_m else None
        base = surface_under(out[supports[i][0]], masks[i], camera) if i in supports else 0.0
        flat = bool(prior and prior.height_m and prior.height_m <= FLAT_PRIOR_RATIO * prior.longest_m)
        kwargs = dict(height_hint=hint, prior_shape=prior.shape if prior else None, flat=flat, photo=photo,
                      label=labels[i])
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
    return out


@dataclass
class GroundLift:
    """Every object lifted on the ground measured in the photo: world metres, z up, the ground at z = 0."""

    camera: PinholeCamera
    lifted: list  # lift.silhouette.LiftedMesh, one per mask, at the photo's scale
    supports: dict[int, tuple[int, str]]  # {upper: (lower, how it was seen)}
    info: dict  # the camera's cues and the scale's votes, for the report


def lift_photo_scene(masks, labels, names, photo, settings: BuildSettings, user_sizes=None) -> GroundLift:
    """Each object of ``photo`` lifted from its mask and stood, at the photo's scale, where the photo shows it
    (on the ground, or on the object it rests on)."""
    h, w = photo.shape[:2]
    cam_cfg = settings.camera
    feet = [foot_pixel(fill_holes(m))[1] for m in masks]
    est = estimate_camera(photo, masks, labels, feet, cam_cfg.fov_deg, cam_cfg.pitch_deg)
    if est.min_pitch_deg > MAX_PITCH_DEG:
        raise InputError("objects' feet are too high in the photo for any camera pitch; give --pitch and --fov")
    pitch = est.pitch_deg
    if cam_cfg.pitch_deg is not None:  # the user's, checked against the feet
        pitch = min(pick_pitch(est.fov_deg, h, feet, cam_cfg.pitch_deg), MAX_PITCH_DEG)
    camera_info = est.as_dict() | {"pitch_deg": round(pitch, 3)}
    unit = PinholeCamera(w, h, est.fov_deg, pitch, (0.0, 0.0, 1.0))

    supports = find_supports(masks)
    scale = 1.0
    fit = None
    for _ in range(SCALE_ROUNDS):
        lifted = lift_all(masks, labels, unit, settings, scale, supports, photo=photo)
        longest = [longest_dimension(m.vertices) for m in lifted]
        fit = fit_scale(names, labels, longest, user_sizes, cam_cfg.height_m)
        if abs(np.log(fit.factor / scale)) < 1e-3:
            break
        scale = fit.factor
    scale = fit.factor
    lifted = [replace(m, vertices=m.vertices * scale, contact=m.contact * scale) for m in lifted]
    camera = PinholeCamera(w, h, unit.fov_deg, unit.pitch_deg, (0.0, 0.0, scale))
    return GroundLift(camera, lifted, supports, {"scale": fit.as_dict(camera.origin[2]), "camera": camera_info})


def place_on_ground(lifted, names, gap_m: float) -> PhotoScene:
    """The scene of ``lifted`` meshes (``swappable.protocols.LiftedObject`` with ``ground`` evidence, lifted by
    :func:`lift_photo_scene`): objects resting on others move with them; the rest are made shallower, then
    moved apart, until their footprints are ``gap_m`` apart; an object left inside what holds it is raised
    onto it (``align.support.settle_on_supports``)."""
    camera = lifted[0].ground.camera
    supports = {i: o.ground.support for i, o in enumerate(lifted) if o.ground.support is not None}
    free = [i for i in range(len(lifted)) if i not in supports]
    room, scales_free = make_room([lifted[i].vertices for i in free], [lifted[i].ground.contact for i in free],
                                  camera.origin, gap_m, fixed_depth=[lifted[i].ground.fixed_depth for i in free])
    moves_free = separate(room, gap_m)
    projected = [o.vertices for o in lifted]
    depth_scales = [1.0] * len(lifted)
    moves = [np.zeros(3)] * len(lifted)
    for k, i in enumerate(free):
        projected[i], depth_scales[i], moves[i] = room[k], scales_free[k], moves_free[k]
    for i in supports:
        moves[i] = moves[root_of(i, supports)]
    verts, rise = settle_on_supports([v + d for v, d in zip(projected, moves)], [o.faces for o in lifted], supports)
    info = {"variant": "silhouette", "depth_scales": [round(k, 4) for k in depth_scales],
            "moved_apart_m": [round(float(np.linalg.norm(d)), 4) for d in moves],
            **({"raised_onto_support_m": {names[i]: round(r, 4) for i, r in enumerate(rise) if r > 0}}
               if any(rise) else {}),
            **lifted[0].ground.scene,
            "lift": [o.ground.info for o in lifted],
            "supports": {names[i]: {"on": names[j], "seen": how} for i, (j, how) in supports.items()}}
    return PhotoScene(camera, verts, projected, [o.faces for o in lifted], [o.shape for o in lifted], info)
