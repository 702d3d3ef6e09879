"""``bench alignment``: the paper's two ablation tables, measured on synthetic scenes with known truth.

Table ``scene``: meshes handed over as a reconstruction model would (each in
its own frame; 4° rotation, 10 % scale and 3 % translation noise on the pose)
and aligned by each variant — no alignment, canonical single-object poses,
+ RANSAC ground, + AGMF ground (the full method, with the fit to the masks).
Table ``camera``: the true meshes under a perturbed initial camera, refined by
no search, the global phase only, the local phase only, and coarse-to-fine.

Metrics (see ``physomni_usd.metrics.alignment``): mask IoU of the visible
silhouettes against the true masks, the paper's box penetration rate and our
mesh penetration, support violation rate, interaction success rate over one
simulated second, centroid reprojection error in pixels, SSIM of the render
(flat object colours over the plate) against the photo, and seconds.
"""

from __future__ import annotations

import json
import platform
import time

import numpy as np
import trimesh

from ..geometry.camera import PinholeCamera
from ..align.camera_search import CameraLoss, search_camera
from ..align.external import load_poses, place_external, visible_silhouettes
from ..geometry.raycast import SilhouetteRenderer
from ..rotations import from_wxyz
from ..metrics.alignment import (box_penetration_rate, interaction_success_rate, mask_iou, mesh_penetration_rate,
                                 reprojection_px, support_violation_rate)
from ..metrics.image import ssim
from .synthetic import make_scene, write_inputs

SCENE_VARIANTS = ("none", "canonical", "ransac", "agmf")
CAMERA_VARIANTS = ("initial", "global", "local", "coarse_to_fine")
KEYS = ("table", "variant", "scene", "mask_iou", "penetration_rate", "mesh_penetration_rate",
        "support_violation_rate", "interaction_success_rate", "reprojection_px", "ssim", "seconds")


def _image_metrics(camera, verts, faces, scene):
    seen = visible_silhouettes(verts, faces, camera)
    iou = float(np.mean([mask_iou(s, m) for s, m in zip(seen, scene.masks)]))
    reproj = float(np.mean([min(reprojection_px(s, m), 1e4) for s, m in zip(seen, scene.masks)]))
    loss = CameraLoss(camera, verts, faces, scene.photo, scene.masks)
    render = loss._level(1.0)[1].copy()
    for s, c in zip(seen, loss.colours):
        render[s] = c / 255.0
    gray = lambda im: (im @ [0.299, 0.587, 0.114]).astype(np.float64)  # noqa: E731
    score = ssim(gray(render * 255.0), gray(scene.photo.astype(np.float64)))
    return iou, reproj, score


def _isr(camera, verts, faces, seconds: float = 1.0, fps: int = 20) -> float:
    """Interaction success: drop the aligned meshes under gravity with Newton and count visible frames."""
    import newton
    import warp as wp

    from .._warp import load_warp
    from ..physics.stability import StepPlan
    from ..physics.stepping import Stepper, contact_pipeline, xpbd_solver

    load_warp()
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    builder.add_ground_plane()
    bodies = []
    for v, f in zip(verts, faces):
        centre = v.mean(0)
        hull = trimesh.Trimesh(v - centre, f, process=False).convex_hull
        b = builder.add_body(xform=wp.transform(tuple(centre), wp.quat_identity()))
        builder.add_shape_convex_hull(b, mesh=newton.Mesh(hull.vertices.astype(np.float32),
                                                           hull.faces.ravel().astype(np.int32)))
        bodies.append((v - centre, f))
    model = builder.finalize(device="cpu")
    pipe, contacts = contact_pipeline(model)
    stepper = Stepper(model, xpbd_solver(model, 4), pipeline=pipe, contacts=contacts)
    plan = StepPlan(fps, 5, iterations=4)  # contacts searched every substep
    frames = []
    renderer = SilhouetteRenderer(verts, faces)  # one BVH, refitted as the bodies move
    for f in range(int(seconds * fps)):
        stepper.frame(plan, f / fps, f * plan.substeps)
        a = stepper.state
        q = a.body_q.numpy()
        moved = []
        for (local, _), xf in zip(bodies, q):
            r = from_wxyz(xf[[6, 3, 4, 5]])  # warp stores x, y, z, w
            moved.append(local @ r.T + xf[:3])
        if not np.all(np.isfinite(q)):
            return 0.0
        renderer.update(moved)
        frames.append(visible_silhouettes(moved, faces, camera, renderer))
    return interaction_success_rate(frames)


def _row(table, variant, scene_kind, **values):
    row = dict.fromkeys(KEYS)
    row.update(table=table, variant=variant, scene=scene_kind, **values)
    return row


def scene_rows(kind: str, seed: int, folder, size) -> list[dict]:
    scene = make_scene(kind, width=size[0], height=size[1], seed=seed)
    args = write_inputs(scene, folder, rot_deg=4.0, scale_noise=0.10, trans_noise=0.03, seed=seed + 100)
    entries = load_poses(args["meshes"], scene.labels)
    rows = []
    for variant in SCENE_VARIANTS:
        t0 = time.perf_counter()
        placed = place_external(entries, size[0], size[1], scene.camera.fov_deg, variant, seed=seed,
                                masks=scene.masks)
        seconds = time.perf_counter() - t0
        meshes = [trimesh.Trimesh(v, f, process=False) for v, f in zip(placed.vertices, placed.faces)]
        iou, reproj, score = _image_metrics(placed.camera, placed.vertices, placed.faces, scene)
        ground_ok = variant != "none"  # without alignment there is no ground to stand on
        rows.append(_row("scene", variant, kind, mask_iou=iou, penetration_rate=box_penetration_rate(meshes),
                         mesh_penetration_rate=mesh_penetration_rate(meshes),
                         support_violation_rate=support_violation_rate(meshes) if ground_ok else 1.0,
                         interaction_success_rate=_isr(placed.camera, placed.vertices, placed.faces)
                         if ground_ok else 0.0,
                         reprojection_px=reproj, ssim=score, seconds=seconds,
                         plane_error_deg=_plane_error(placed, scene)))
    return rows


def _plane_error(placed, scene) -> float | None:
    """Angle between the recovered ground normal and the truth, seen in the camera's frame."""
    if placed.plane is None:
        return None
    true_up_cam = scene.camera.world_from_camera.T @ np.array([0.0, 0.0, 1.0])
    got_up_cam = placed.camera.world_from_camera.T @ np.array([0.0, 0.0, 1.0])
    return float(np.degrees(np.arccos(np.clip(true_up_cam @ got_up_cam, -1.0, 1.0))))


def camera_rows(kind: str, seed: int, size, max_evals: int) -> list[dict]:
    scene = make_scene(kind, width=size[0], height=size[1], seed=seed)
    cam = scene.camera
    rng = np.random.default_rng(seed + 7)
    off = rng.normal(0, 0.08, 3)
    initial = PinholeCamera.from_pose(cam.width, cam.height, cam.fov_deg + rng.uniform(-6, 6), cam.origin + off,
                                      cam.world_from_camera)
    verts = [m.vertices for m in scene.meshes]
    faces = [m.faces for m in scene.meshes]
    rows = []
    for variant in CAMERA_VARIANTS:
        t0 = time.perf_counter()
        if variant == "initial":
            camera, curve = initial, []
        else:
            result = search_camera(initial, verts, faces, scene.photo, scene.masks, mode=variant,
                                   max_evals=max_evals, seed=seed)
            camera, curve = result.camera, result.curve
        seconds = time.perf_counter() - t0
        iou, reproj, score = _image_metrics(camera, verts, faces, scene)
        meshes = list(scene.meshes)
        rows.append(_row("camera", variant, kind, mask_iou=iou, penetration_rate=box_penetration_rate(meshes),
                         mesh_penetration_rate=mesh_penetration_rate(meshes),
                         support_violation_rate=support_violation_rate(meshes), interaction_success_rate=None,
                         reprojection_px=reproj, ssim=score, seconds=seconds,
                         loss_curve=curve[:: max(1, len(curve) // 50)]))
    return rows


def _mean_rows(rows: list[dict]) -> list[dict]:
    out = []
    for key in dict.fromkeys((r["table"], r["variant"]) for r in rows):
        group = [r for r in rows if (r["table"], r["variant"]) == key]
        row = {"table": key[0], "variant": key[1], "scenes": len(group)}
        for k in KEYS[3:] + ("plane_error_deg",):
            vals = [r[k] for r in group if r.get(k) is not None]
            row[k] = round(float(np.mean(vals)), 4) if vals else None
        out.append(row)
    return out


def bench_alignment(quick: bool = False, echo=print) -> dict:
    import tempfile

    size = (320, 240) if quick else (880, 660)
    seeds = (1, 2) if quick else (1, 2, 3, 4)
    rows = []
    with tempfile.TemporaryDirectory(prefix="physomni-align-") as tmp:
        for kind in ("tabletop", "tall"):
            for seed in seeds:
                echo(f"scene {kind} seed {seed}")
                rows += scene_rows(kind, seed, f"{tmp}/{kind}{seed}", size)
                rows += camera_rows(kind, seed, size, max_evals=200 if quick else 300)
    summary = _mean_rows(rows)
    by_kind = {}
    for kind in ("tabletop", "tall"):
        by_kind[kind] = _mean_rows([r for r in rows if r["scene"] == kind and r["table"] == "scene"])
    _print(summary, by_kind, echo)
    return {"machine": f"{platform.machine()}, {__import__('os').cpu_count()} cores", "size": list(size),
            "rows": summary, "by_scene": by_kind, "all": rows}


def _print(summary, by_kind, echo):
    head = f"{'table':<8}{'variant':<16}{'IoU':>7}{'PR':>7}{'meshPR':>8}{'SVR':>7}{'ISR':>7}{'reproj px':>11}" \
           f"{'SSIM':>7}{'plane°':>8}{'s':>8}"
    fmt = lambda v, w, p=3: f"{v:>{w}.{p}f}" if isinstance(v, (int, float)) else f"{'—':>{w}}"  # noqa: E731
    echo(head)
    for r in summary:
        echo(f"{r['table']:<8}{r['variant']:<16}{fmt(r['mask_iou'], 7)}{fmt(r['penetration_rate'], 7, 2)}"
             f"{fmt(r['mesh_penetration_rate'], 8, 2)}{fmt(r['support_violation_rate'], 7, 2)}"
             f"{fmt(r['interaction_success_rate'], 7, 2)}{fmt(r['reprojection_px'], 11, 2)}{fmt(r['ssim'], 7)}"
             f"{fmt(r.get('plane_error_deg'), 8, 2)}{fmt(r['seconds'], 8, 2)}")
    echo("ground plane error by scene (degrees): " + "; ".join(
        f"{kind}: " + ", ".join(f"{r['variant']} {r['plane_error_deg']:.2f}" for r in rows
                                if r["plane_error_deg"] is not None) for kind, rows in by_kind.items()))


def write_json(numbers: dict, path) -> None:
    from .._files import write_bytes

    rows = [{k: r.get(k) for k in ("table", "variant", "mask_iou", "penetration_rate", "support_violation_rate",
                                   "interaction_success_rate", "reprojection_px", "ssim", "seconds")}
            | {"mesh_penetration_rate": r.get("mesh_penetration_rate"), "plane_error_deg": r.get("plane_error_deg")}
            for r in numbers["rows"]]
    write_bytes(path, (json.dumps({**numbers, "rows": rows}, indent=2, default=float) + "\n").encode())
