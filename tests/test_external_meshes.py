"""``build --meshes``: posed meshes from a reconstruction model, aligned on the ground and to their masks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pxr import Usd

from physomni_usd.align.external import visible_silhouettes
from physomni_usd.bench.synthetic import make_scene, write_inputs
from physomni_usd.metrics import mask_iou, max_penetration, world_meshes
from physomni_usd.metrics.alignment import support_violation_rate
from physomni_usd.rendering.stage import read_camera
from physomni_usd.geometry.camera import PinholeCamera

from .conftest import cli


def _built_camera(stage, w, h):
    cam = read_camera(stage, Usd.TimeCode(0), w, h)
    fov = np.degrees(2 * np.arctan(0.5 * h / cam.fy))
    return PinholeCamera.from_pose(w, h, fov, cam.origin, cam.axes.T)


@pytest.fixture(scope="module")
def noisy_build(tmp_path_factory):
    scene = make_scene("tabletop", seed=1)
    folder = tmp_path_factory.mktemp("external")
    args = write_inputs(scene, folder / "in", rot_deg=4.0, scale_noise=0.10, trans_noise=0.03, seed=2)
    out = folder / "shot"
    cli("build", args["photo"], "-o", out, "--meshes", args["meshes"], "--fov", f"{args['fov']:.6f}", "-q",
        *args["mask_args"], check=True)
    return scene, out


def test_noisy_meshes_match_their_masks(noisy_build):
    scene, out = noisy_build
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    meshes = world_meshes(stage, 0)
    names = sorted(meshes, key=lambda n: int(n.rsplit("_", 1)[1]))
    camera = _built_camera(stage, scene.camera.width, scene.camera.height)
    seen = visible_silhouettes([meshes[n].vertices for n in names], [meshes[n].faces for n in names], camera)
    ious = [mask_iou(s, m) for s, m in zip(seen, scene.masks)]
    assert min(ious) >= 0.85, ious


def test_noisy_meshes_stand_on_the_ground_apart(noisy_build):
    _, out = noisy_build
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    meshes = world_meshes(stage, 0)
    assert support_violation_rate(list(meshes.values())) == 0.0
    assert max_penetration(meshes) <= 1e-3
    report = json.loads((out / "report.json").read_text())
    assert report["shot"]["alignment"]["plane"]["method"].startswith("agmf")
    assert report["shot"]["alignment"]["fov_source"] == "user"  # --fov placed the meshes


def test_pose_file_naming_an_unknown_label_is_refused(tmp_path):
    scene = make_scene("tabletop", seed=3)
    args = write_inputs(scene, tmp_path / "in", seed=4)
    poses = json.loads((args["meshes"] / "poses.json").read_text())
    poses["ghost"] = poses["box"]
    (args["meshes"] / "poses.json").write_text(json.dumps(poses))
    proc = cli("build", args["photo"], "-o", tmp_path / "out", "--meshes", args["meshes"], *args["mask_args"])
    assert proc.returncode == 2 and "'ghost'" in proc.stderr and "Traceback" not in proc.stderr


def test_broken_meshes_are_repaired(tmp_path):
    """A mesh with flipped normals and a hole still builds, and the report says what was repaired."""
    import trimesh

    scene = make_scene("tabletop", seed=5)
    args = write_inputs(scene, tmp_path / "in", seed=6)
    path = args["meshes"] / "box.ply"
    mesh = trimesh.load(str(path), process=False)
    broken = trimesh.Trimesh(mesh.vertices, mesh.faces[1:][:, ::-1], process=False)  # a hole, inside out
    broken.export(str(path))
    out = tmp_path / "out"
    cli("build", args["photo"], "-o", out, "--meshes", args["meshes"], "-q", *args["mask_args"], check=True)
    report = json.loads((out / "report.json").read_text())
    notes = {o["label"]: o["notes"] for o in report["objects"]}
    assert notes["box"] and any("hole" in n or "normals" in n or "hull" in n for n in notes["box"])


def _build_scene(tmp_path, scene, **noise):
    args = write_inputs(scene, tmp_path / "in", seed=9, **noise)
    out = tmp_path / "shot"
    cli("build", args["photo"], "-o", out, "--meshes", args["meshes"], "--fov", f"{args['fov']:.6f}", "-q",
        *args["mask_args"], check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    meshes = world_meshes(stage, 0)
    names = sorted(meshes, key=lambda n: int(n.rsplit("_", 1)[1]))
    camera = _built_camera(stage, scene.camera.width, scene.camera.height)
    seen = visible_silhouettes([meshes[n].vertices for n in names], [meshes[n].faces for n in names], camera)
    return [meshes[n] for n in names], [mask_iou(s, m) for s, m in zip(seen, scene.masks)], camera


def test_one_object_alone(tmp_path):
    meshes, ious, _ = _build_scene(tmp_path, make_scene("tabletop", seed=7, count=1), rot_deg=4.0)
    assert len(meshes) == 1 and min(ious) >= 0.85
    assert abs(meshes[0].vertices[:, 2].min()) < 1e-6


def test_sloped_view_still_finds_the_ground(tmp_path):
    scene = make_scene("tabletop", seed=8, roll_deg=12.0)
    meshes, ious, camera = _build_scene(tmp_path, scene)
    true_up = scene.camera.world_from_camera.T @ np.array([0.0, 0.0, 1.0])
    got_up = camera.world_from_camera.T @ np.array([0.0, 0.0, 1.0])
    assert np.degrees(np.arccos(np.clip(true_up @ got_up, -1, 1))) < 2.0
    assert min(ious) >= 0.85 and support_violation_rate(meshes) == 0.0


def test_object_floating_in_the_photo_is_set_down(tmp_path):
    scene = make_scene("tabletop", seed=10, lift={"can": 0.3})
    meshes, _, _ = _build_scene(tmp_path, scene)
    assert support_violation_rate(meshes) == 0.0  # every object stands on the ground, the can included
