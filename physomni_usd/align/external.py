"""Placing meshes from a reconstruction model (or a user) in one scene on the ground.

Input, per object: a mesh in its own frame and a pose in the camera's OpenCV
coordinates (x right, y down, z forward): p_cam = s·R·p_mesh + t, as
``poses.json`` gives it::

    {"cup": {"mesh": "cup.glb", "rotation_wxyz": [1, 0, 0, 0], "translation": [0.1, 0.2, 1.5], "scale": 0.3}}

Such poses are mutually inconsistent (each object's own noise), so the scene
alignment of the paper follows:

1. camera coordinates → a provisional Z-up world (camera at the origin
   looking along +Y), whose +Z is the camera's visual up: the gravity prior;
2. the ground plane by AGMF (or RANSAC, or per-object canonical poses, for the
   ablation) and the one rigid transform that puts it at z = 0, applied to the
   meshes and to the camera alike;
3. every object set down on the ground (its lowest point on z = 0);
4. each object's scale and place on the ground refined so that its visible
   silhouette matches its mask (area and centroid), scaling about its base so
   that it stays on the ground;
5. interpenetration resolved on the meshes (horizontal moves only).
"""

from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass, field

import numpy as np
import trimesh

from ..errors import InputError
from ..rotations import from_wxyz
from ..geometry.camera import PinholeCamera
from .ground import Plane, agmf_plane, apply, canonical_pose, ground_transform, ransac_plane
from .penetration import resolve_penetration

#: OpenCV camera axes → provisional world (x right, y forward, z up).
CAMERA_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
VARIANTS = ("none", "canonical", "ransac", "agmf")


@dataclass
class PlacedScene:
    camera: PinholeCamera
    vertices: list[np.ndarray]  # world, after every step
    faces: list[np.ndarray]
    projected: list[np.ndarray]  # world positions the photo was seen at (texture projection)
    plane: Plane | None
    info: dict = field(default_factory=dict)


def load_poses(folder, labels: list[str]) -> list[tuple[trimesh.Trimesh, np.ndarray, np.ndarray, float, list[str]]]:
    """Meshes and poses for ``labels`` (mask order) from ``folder/poses.json``; one clear line on any problem."""
    out = []
    for mesh, wxyz, t, s in read_poses(folder, labels):
        mesh, notes = repair_mesh(trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=True))
        out.append((mesh, from_wxyz(wxyz), np.asarray(t, float), s, notes))
    return out


def read_poses(folder, labels: list[str]) -> list[tuple[trimesh.Trimesh, tuple, np.ndarray, float]]:
    """(mesh as read, rotation_wxyz as written, translation (3,), scale) of each of ``labels`` (mask order)
    from ``folder/poses.json`` and its meshes; one clear line on any problem."""
    folder = pathlib.Path(folder)
    path = folder / "poses.json"
    if not path.is_file():
        raise InputError(f"--meshes {folder}: no poses.json in it")
    try:
        poses = json.loads(path.read_text())
    except ValueError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(poses, dict):
        raise InputError(f"{path}: expected an object mapping each label to its pose")
    unknown = sorted(set(poses) - set(labels))
    if unknown:
        raise InputError(f"{path} names {', '.join(map(repr, unknown))}, which no --mask label matches "
                         f"(labels: {', '.join(labels)})")
    out = []
    for label in labels:
        if label not in poses:
            raise InputError(f"{path} has no pose for {label!r}")
        entry = poses[label]
        try:
            mesh_file = folder / entry["mesh"]
            wxyz = tuple(float(x) for x in entry.get("rotation_wxyz", [1, 0, 0, 0]))
            r = from_wxyz(wxyz)
            t = np.asarray(entry.get("translation", [0, 0, 0]), float).reshape(3)
            s = float(entry.get("scale", 1.0))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{path}: the pose of {label!r} is malformed ({exc}); expected mesh, rotation_wxyz, "
                             "translation, scale") from None
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(t)) and np.isfinite(s) and s > 0):
            raise InputError(f"{path}: the pose of {label!r} has non-finite values or a scale ≤ 0")
        if t[2] <= 0:
            raise InputError(f"{path}: {label!r} is behind the camera (translation z = {t[2]:g} ≤ 0)")
        out.append((_load_mesh(mesh_file), wxyz, t, s))
    return out


def posed_entries(lifted):
    """(mesh, rotation (3, 3), translation (3,), scale, notes) of each lifted object
    (``swappable.protocols.LiftedObject``), its mesh repaired (:func:`repair_mesh`): what
    :func:`place_external` takes."""
    out = []
    for o in lifted:
        mesh, notes = repair_mesh(trimesh.Trimesh(np.asarray(o.vertices, float), np.asarray(o.faces), process=True))
        out.append((mesh, from_wxyz(o.rotation_wxyz), np.asarray(o.translation, float).reshape(3),
                    float(o.scale), list(o.notes) + notes))
    return out


def _load_mesh(path: pathlib.Path) -> trimesh.Trimesh:
    if not path.is_file():
        raise InputError(f"mesh not found: {path}")
    try:
        mesh = trimesh.load(str(path), force="mesh", process=True)
    except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds
        raise InputError(f"cannot read mesh {path.name}: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"{path.name} holds no triangles")
    return mesh


def read_mesh(path: pathlib.Path) -> tuple[trimesh.Trimesh, list[str]]:
    """A triangle mesh from OBJ, GLB, PLY, …, with normals made consistent and simple holes filled."""
    return repair_mesh(_load_mesh(path))


def repair_mesh(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, list[str]]:
    """``mesh`` with simple holes filled and normals made consistent (in place), and what was done."""
    notes = []
    if not mesh.is_watertight:
        trimesh.repair.fill_holes(mesh)
        notes.append("holes filled" if mesh.is_watertight else "not watertight: its convex hull is its collider")
    if not mesh.is_winding_consistent or (mesh.is_watertight and mesh.volume < 0):
        trimesh.repair.fix_normals(mesh)
        notes.append("normals made consistent")
    return mesh, notes


def visible_silhouettes(vertex_sets, faces, camera: PinholeCamera, renderer=None) -> list[np.ndarray]:
    """Visible masks (H, W) bool of meshes from ``camera``, nearer objects hiding farther ones.

    Rendered by the warp ray caster; pass a :class:`~physomni_usd.geometry.raycast.SilhouetteRenderer`
    already holding these meshes to reuse its BVH.
    """
    from ..geometry.raycast import SilhouetteRenderer

    renderer = renderer or SilhouetteRenderer(vertex_sets, faces)
    ids = renderer.render(camera)
    return [ids == i for i in range(len(vertex_sets))]


def fit_to_masks(vertex_sets, faces, masks, camera: PinholeCamera, rounds: int = 4):
    """Scale each object about its base and slide it on the ground until its visible silhouette has its
    mask's area and centroid. Returns the new vertex sets and the per-object (scale, shift) applied."""
    from ..geometry.raycast import SilhouetteRenderer

    verts = [np.asarray(v, float).copy() for v in vertex_sets]
    total_scale = np.ones(len(verts))
    total_shift = np.zeros((len(verts), 3))
    renderer = SilhouetteRenderer(verts, faces)
    for _ in range(rounds):
        renderer.update(verts)
        seen = visible_silhouettes(verts, faces, camera, renderer)
        for i, (v, sil, mask) in enumerate(zip(verts, seen, masks)):
            if not sil.any() or not mask.any():
                continue
            base = np.array([v[:, 0].mean(), v[:, 1].mean(), 0.0])
            k = float(np.clip(np.sqrt(mask.sum() / sil.sum()), 0.5, 2.0))
            ys, xs = np.nonzero(sil)
            ty, tx = np.nonzero(mask)
            du, dv = tx.mean() - xs.mean(), ty.mean() - ys.mean()
            uv, _ = camera.project(base[None])
            target = camera.ground_points(uv[0, 0] + du, uv[0, 1] + dv)
            shift = (target - base) if np.all(np.isfinite(target)) else np.zeros(3)
            shift[2] = 0.0
            verts[i] = (v - base) * k + base + shift
            total_scale[i] *= k
            total_shift[i] += shift
    return verts, {"scale": total_scale.round(4).tolist(), "shift_m": np.round(total_shift, 4).tolist()}


def surface_samples(vertex_sets, faces, seed: int = 0, total: int = 5000, per_object: int = 400):
    """Points spread over each mesh's surface: ``total`` shared by area, at least ``per_object`` each."""
    areas = [trimesh.Trimesh(v, f, process=False).area for v, f in zip(vertex_sets, faces)]
    out = []
    for k, (v, f, a) in enumerate(zip(vertex_sets, faces, areas)):
        count = max(per_object, int(total * a / max(sum(areas), 1e-12)))
        pts, _ = trimesh.sample.sample_surface(trimesh.Trimesh(v, f, process=False), count, seed=seed + k)
        out.append(np.vstack([pts, v]))
    return out


def place_external(entries, width: int, height: int, fov_deg: float, variant: str = "agmf", seed: int = 0,
                   gap: float = 0.002, masks: list[np.ndarray] | None = None) -> PlacedScene:
    """Run the scene alignment ``variant`` ('none', 'canonical', 'ransac', 'agmf') on posed meshes."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown alignment variant {variant!r}")
    seen = []
    faces = []
    for mesh, r, t, s, _ in entries:
        cam_pts = s * np.asarray(mesh.vertices) @ r.T + t
        seen.append(cam_pts @ CAMERA_TO_WORLD.T)
        faces.append(np.asarray(mesh.faces))
    cam_rot = CAMERA_TO_WORLD.copy()  # columns: camera x, y, z in the provisional world
    position = np.zeros(3)
    plane = None
    if variant in ("ransac", "agmf"):
        # both fits see points spread over the surfaces (area-weighted, seeded), as a point cloud would be
        samples = surface_samples(seen, faces, seed)
        plane = agmf_plane(samples, [0, 0, 1]) if variant == "agmf" else ransac_plane(samples, [0, 0, 1],
                                                                                         seed=seed)
        m = ground_transform(plane)
        seen = [apply(m, v) for v in seen]
        cam_rot = m[:3, :3] @ cam_rot
        position = m[:3, :3] @ position + m[:3, 3]
    projected = [v.copy() for v in seen]
    verts = [v.copy() for v in seen]
    if variant == "canonical":
        verts = [apply(canonical_pose(v), v) + [v[:, 0].mean(), v[:, 1].mean(), 0.0] for v in verts]
    elif variant in ("ransac", "agmf"):
        verts = [v - [0.0, 0.0, v[:, 2].min()] for v in verts]  # set each object down on the ground
    if variant in ("ransac", "agmf") and masks is not None:
        camera0 = PinholeCamera.from_pose(width, height, fov_deg, position, cam_rot)
        verts, fit = fit_to_masks(verts, faces, masks, camera0)
        info_fit = fit
    else:
        info_fit = None
    resolved = True
    if variant != "none":
        offsets, resolved = resolve_penetration(verts, faces, gap)
        verts = [v + o for v, o in zip(verts, offsets)]
    camera = PinholeCamera.from_pose(width, height, fov_deg, position, cam_rot)
    info = {"variant": variant, "plane": None if plane is None else
            {"normal": plane.normal.round(6).tolist(), "method": plane.method, "anchors": plane.inliers},
            "penetration_resolved": resolved, "mesh_notes": [e[4] for e in entries], "mask_fit": info_fit}
    return PlacedScene(camera, verts, faces, projected, plane, info)
