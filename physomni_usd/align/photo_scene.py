"""The built-in (no model) scene from a photo: camera, lifted objects, real scale, support, room.

Owns the order of the silhouette path of ``build``: the camera is estimated
from the photo (``align/cues.py``) under a unit camera height, every object
is lifted (``perceive/lift.py``), the scene's scale is fixed from the objects'
typical sizes (``align/scale.py``), objects resting on others are stood on
them (``align/support.py``), and the rest are kept apart (``align/place.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..sizes import size_prior
from ..perceive.lift import FLAT_PRIOR_RATIO, fill_holes, foot_pixel, lift_silhouette
from ..settings import BuildSettings
from ..errors import InputError
from ..geometry.camera import PinholeCamera, pick_pitch
from ..geometry.mesh import longest_dimension
from .cues import MAX_PITCH_DEG, estimate_camera
from .place import make_room, separate
from .scale import fit_scale
from .support import find_supports, root_of, support_order

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


def lift_all(masks, labels, camera: PinholeCamera, settings: BuildSettings, scale: float, supports=None,
             photo=None):
    """Each mask lifted under ``camera`` (unit height); ``scale`` turns a prior's metres into the camera's units.

    ``supports`` ({upper: (lower, how)}) stands each upper object on its lower one's top.
    """
    supports = supports or {}
    out = [None] * len(masks)
    for i in support_order(len(masks), supports):
        prior = size_prior(labels[i])
        hint = prior.height_m / scale if prior is not None and prior.height_m else None
        base = float(out[supports[i][0]].vertices[:, 2].max()) if i in supports else 0.0
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


def build_photo_scene(masks, labels, names, photo, settings: BuildSettings, user_sizes=None) -> PhotoScene:
    """Camera, meshes and placement for objects seen only as masks in ``photo``."""
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

    # objects resting on others move with them; the rest keep clear of each other
    free = [i for i in range(len(lifted)) if i not in supports]
    room, scales_free = make_room([lifted[i].vertices for i in free], [lifted[i].contact for i in free],
                                  camera.origin, settings.gap_m,
                                  fixed_depth=[lifted[i].info.get("mode") == "footprint" for i in free])
    moves_free = separate(room, settings.gap_m)
    projected = [m.vertices for m in lifted]
    depth_scales = [1.0] * len(lifted)
    moves = [np.zeros(3)] * len(lifted)
    for k, i in enumerate(free):
        projected[i], depth_scales[i], moves[i] = room[k], scales_free[k], moves_free[k]
    for i in supports:
        moves[i] = moves[root_of(i, supports)]
    verts = [v + d for v, d in zip(projected, moves)]
    info = {"variant": "silhouette", "depth_scales": [round(k, 4) for k in depth_scales],
            "moved_apart_m": [round(float(np.linalg.norm(d)), 4) for d in moves],
            "scale": fit.as_dict(camera.origin[2]), "camera": camera_info,
            "lift": [m.info for m in lifted],
            "supports": {names[i]: {"on": names[j], "seen": how} for i, (j, how) in supports.items()}}
    return PhotoScene(camera, verts, projected, [m.faces for m in lifted], [m.shape for m in lifted], info)
