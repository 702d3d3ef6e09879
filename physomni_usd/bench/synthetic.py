"""Synthetic scenes with known truth: primitives on a textured ground under a known camera.

:func:`make_scene` returns the photo, the masks (visible parts, occlusion
included), the true meshes in world coordinates and the true camera;
:func:`make_stack` the scenes of a holistic scene — objects resting on objects,
hiding one another, piled, or seen straight down (:data:`STACKS`);
:func:`write_inputs` writes what a reconstruction model would hand over —
each mesh in its own frame, with a pose in OpenCV camera coordinates carrying
rotation, scale and translation noise — so that ``build --meshes`` can be run
on it and compared with the truth.
"""

from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass

import cv2
import numpy as np
import trimesh

from .. import rotations
from ..geometry.camera import PinholeCamera


@dataclass
class SyntheticScene:
    photo: np.ndarray  # (H, W, 3) uint8
    masks: list[np.ndarray]
    labels: list[str]
    meshes: list[trimesh.Trimesh]  # world, true
    camera: PinholeCamera


def _objects(kind: str, rng) -> list[tuple[str, trimesh.Trimesh]]:
    out = [("box", trimesh.creation.box((0.30, 0.25, 0.20))),
           ("can", trimesh.creation.cylinder(0.09, 0.30, sections=32)),
           ("block", trimesh.creation.box((0.20, 0.20, 0.35)))]
    if kind == "tall":  # dense vertical structures: a wall panel and a standing figure
        out += [("wall", trimesh.creation.box((1.2, 0.06, 1.0))),
                ("figure", trimesh.creation.capsule(height=0.9, radius=0.12, count=[24, 24]))]
    return out


def make_scene(kind: str = "tabletop", width: int = 320, height: int = 240, fov_deg: float = 55.0,
               pitch_deg: float = 25.0, seed: int = 0, roll_deg: float = 0.0, count: int | None = None,
               lift: dict | None = None) -> SyntheticScene:
    """``roll_deg`` tilts the camera about its view axis (the ground looks sloped in the photo); ``count``
    keeps the first objects only; ``lift`` raises named objects off the ground (metres)."""
    rng = np.random.default_rng(seed)
    camera = PinholeCamera(width, height, fov_deg, pitch_deg, (0.0, 0.0, 1.2))
    if roll_deg:
        r = camera.world_from_camera
        roll = trimesh.transformations.rotation_matrix(np.radians(roll_deg), r[:, 2])[:3, :3]
        camera = PinholeCamera.from_pose(width, height, fov_deg, camera.origin, roll @ r)
    placed = []
    spots = [(-0.45, 2.0), (0.0, 2.3), (0.45, 1.9), (0.0, 3.1), (-0.6, 2.8)]
    for (label, mesh), (x, y) in list(zip(_objects(kind, rng), spots))[:count]:
        m = mesh.copy()
        m.apply_transform(trimesh.transformations.rotation_matrix(rng.uniform(-0.6, 0.6), [0, 0, 1]))
        m.apply_translation([x + rng.uniform(-0.05, 0.05), y, -m.bounds[0][2] + (lift or {}).get(label, 0.0)])
        placed.append((label, m))
    # the truth itself must not interpenetrate: nudge random placements apart
    from ..align.penetration import resolve_penetration

    offsets, _ = resolve_penetration([m.vertices for _, m in placed], [m.faces for _, m in placed], gap=0.005)
    for (_, m), o in zip(placed, offsets):
        m.apply_translation(o)
    photo, masks = render_truth(camera, [m for _, m in placed], rng)
    return SyntheticScene(photo, masks, [label for label, _ in placed], [m for _, m in placed], camera)


#: The holistic scenes of :func:`make_stack`: name → (camera distance to the scene's middle m, pitch °).
STACKS = {"cup_saucer_spoon": (0.32, 35.0), "three_boxes": (0.9, 30.0), "bowl_of_spheres": (0.42, 45.0),
          "tray_of_parts": (0.5, 90.0)}


def _stack_objects(kind: str, rng) -> list[tuple[str, trimesh.Trimesh]]:
    """Labelled meshes resting where they rest (z up, the ground at 0, the scene's middle over the origin)."""
    turn = lambda m, a: m.apply_transform(trimesh.transformations.rotation_matrix(a, [0, 0, 1]))  # noqa: E731
    if kind == "cup_saucer_spoon":  # the spoon lies in the saucer's ring, beside the cup
        saucer = trimesh.creation.cylinder(0.075, 0.02, sections=64)
        saucer.apply_translation([0, 0, 0.01])
        cup = trimesh.creation.cylinder(0.04, 0.095, sections=48)
        cup.apply_translation([0, 0, 0.02 + 0.0475])
        spoon = trimesh.creation.box((0.09, 0.014, 0.005))
        spoon.apply_translation([0.0, -0.057, 0.0225])
        turn(spoon, 0.5)
        return [("cup", cup), ("saucer", saucer), ("spoon", spoon)]
    if kind == "three_boxes":  # each smaller box on the one below it, a little turned
        out, z = [], 0.0
        for label, (sx, sy, sz) in (("box", (0.34, 0.26, 0.14)), ("box", (0.26, 0.20, 0.11)),
                                    ("box", (0.18, 0.14, 0.09))):
            m = trimesh.creation.box((sx, sy, sz))
            turn(m, rng.uniform(-0.25, 0.25))
            m.apply_translation([rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), z + sz / 2])
            out.append((label, m))
            z += sz
        return out
    if kind == "bowl_of_spheres":  # a bowl (1 cm walls, 6 cm deep) holding three balls that rise above its rim
        profile = [[0.0, 0.0], [0.09, 0.0], [0.12, 0.06], [0.11, 0.06], [0.085, 0.01], [0.0, 0.01]]
        bowl = trimesh.creation.revolve(profile, sections=64)
        out = [("bowl", bowl)]
        for k in range(3):
            a = 2 * np.pi * k / 3 + 0.3
            ball = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
            ball.apply_translation([0.04 * np.cos(a), 0.04 * np.sin(a), 0.01 + 0.03 + 1e-4])
            out.append(("ball", ball))
        return out
    if kind == "tray_of_parts":  # four identical flat rectangular parts on a thin tray, seen straight down
        tray = trimesh.creation.box((0.40, 0.30, 0.015))
        tray.apply_translation([0, 0, 0.0075])
        out = [("tray", tray)]
        for (x, y), a in zip([(-0.1, -0.07), (0.1, -0.07), (-0.1, 0.07), (0.1, 0.07)], rng.uniform(-0.5, 0.5, 4)):
            part = trimesh.creation.box((0.12, 0.04, 0.006))
            turn(part, a)
            part.apply_translation([x, y, 0.015 + 0.003])
            out.append(("part", part))
        return out
    raise ValueError(f"no stacked scene named {kind!r} (known: {', '.join(STACKS)})")


def make_stack(kind: str, width: int = 480, height: int = 360, fov_deg: float = 55.0,
               seed: int = 0) -> SyntheticScene:
    """One of :data:`STACKS` under a level-rolled camera at its distance and pitch, looking at the scene's middle."""
    rng = np.random.default_rng(seed)
    distance, pitch = STACKS[kind]
    placed = _stack_objects(kind, rng)
    middle_z = 0.5 * max(m.bounds[1][2] for _, m in placed)
    p = np.radians(pitch)
    camera = PinholeCamera(width, height, fov_deg, pitch,
                           (0.0, -distance * np.cos(p), middle_z + distance * np.sin(p)))
    photo, masks = render_truth(camera, [m for _, m in placed], rng)
    return SyntheticScene(photo, masks, [label for label, _ in placed], [m for _, m in placed], camera)


def render_truth(camera: PinholeCamera, meshes: list[trimesh.Trimesh], rng=None):
    """A shaded photo and the visible masks, by painting faces far to near (the painter's algorithm)."""
    rng = rng or np.random.default_rng(0)
    h, w = camera.height, camera.width
    uu, vv = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    ground = camera.ground_points(uu, vv)
    checker = ((np.floor(ground[..., 0] * 4) + np.floor(ground[..., 1] * 4)) % 2)
    sky = ~np.isfinite(ground[..., 0])
    photo = np.where(sky[..., None], 190.0, np.where(checker[..., None] > 0, 150.0, 95.0)) * np.array([1.0, 0.9, 0.75])
    photo = np.nan_to_num(photo, nan=190.0)
    ids = np.full((h, w), -1, np.int32)
    colours = rng.uniform(40, 230, (len(meshes), 3))
    light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    faces = []
    for i, m in enumerate(meshes):
        uv, depth = camera.project(m.vertices)
        for f, n in zip(m.faces, m.face_normals):
            if (depth[f] > 0).all():
                faces.append((float(depth[f].mean()), i, uv[f], 0.35 + 0.65 * max(float(n @ light), 0.0)))
    faces.sort(key=lambda x: -x[0])
    img = photo.astype(np.float32)
    for _, i, pts, shade in faces:
        poly = np.round(pts * 16).astype(np.int32)
        cv2.fillConvexPoly(img, poly, tuple(float(c) for c in colours[i] * shade), shift=4)
        cv2.fillConvexPoly(ids, poly, int(i), shift=4)
    img += rng.normal(0, 3, (h, w, 1))
    masks = [ids == i for i in range(len(meshes))]
    return np.clip(img, 0, 255).astype(np.uint8), masks


def write_inputs(scene: SyntheticScene, folder, rot_deg: float = 0.0, scale_noise: float = 0.0,
                 trans_noise: float = 0.0, seed: int = 0) -> dict:
    """Photo, masks, meshes in their own frames and a noisy ``poses.json``; returns the CLI arguments."""
    rng = np.random.default_rng(seed)
    folder = pathlib.Path(folder)
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(scene.photo, cv2.COLOR_RGB2BGR))
    world_to_cam = scene.camera.world_from_camera.T
    poses, mask_args = {}, []
    for label, mesh, mask in zip(scene.labels, scene.meshes, scene.masks):
        cv2.imwrite(str(folder / f"{label}.png"), mask.astype(np.uint8) * 255)
        mask_args += ["--mask", f"{folder / label}.png:{label}"]
        # the mesh in a frame of its own: rotated, scaled, centred anywhere
        own_rot = rotations.random(rng)
        own_scale = float(rng.uniform(0.5, 2.0))
        own_shift = rng.normal(0, 0.3, 3)
        cam_pts = (mesh.vertices - scene.camera.origin) @ world_to_cam.T  # true, OpenCV camera coordinates
        local = ((cam_pts - cam_pts.mean(0)) @ own_rot) * own_scale + own_shift
        # the exact pose back to camera: p_cam = s R p_local + t
        r = own_rot
        s = 1.0 / own_scale
        t = cam_pts.mean(0) - s * own_shift @ r.T
        # a reconstruction model's noise
        axis = rng.normal(size=3)
        r = rotations.axis_angle(axis, np.radians(rot_deg)) @ r
        s *= 1.0 + rng.choice([-1, 1]) * scale_noise
        t = t + rng.normal(size=3) / np.sqrt(3) * trans_noise * np.linalg.norm(t)
        name = f"{label}.ply"
        trimesh.Trimesh(local, mesh.faces, process=False).export(str(folder / "meshes" / name))
        w, x, y, z = (float(c) for c in rotations.to_wxyz(r))
        poses[label] = {"mesh": name, "rotation_wxyz": [w, x, y, z], "translation": t.tolist(), "scale": s}
    (folder / "meshes" / "poses.json").write_text(json.dumps(poses, indent=2))
    return {"photo": folder / "photo.png", "mask_args": mask_args, "meshes": folder / "meshes",
            "fov": scene.camera.fov_deg}


__all__ = ["STACKS", "SyntheticScene", "make_scene", "make_stack", "render_truth", "write_inputs"]
