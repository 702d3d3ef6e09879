"""The whole chain on a synthetic photo: files, validation, Newton import, rest, penetration, frame 0."""

from __future__ import annotations

import json

import imageio.v2 as imageio
import numpy as np
import pytest
from pxr import Usd

from physomni_usd.metrics import max_penetration, ssim, world_meshes
from physomni_usd.perceive.masks import read_photo
from physomni_usd.validate import validate_stage

from .conftest import cli


def test_run_writes_the_layout(shot):
    d = shot["dir"]
    for name in ("shot.usda", "scene.usda", "physics.usda", "sim.usdc", "edits.usda", "video.mp4", "report.json"):
        assert (d / name).is_file(), name
    stage = Usd.Stage.Open(str(shot["shot"]))
    root = stage.GetRootLayer()
    assert list(root.subLayerPaths) == ["./edits.usda", "./sim.usdc", "./physics.usda", "./scene.usda"]


def test_rigid_run_never_imports_torch(shot):
    assert "TORCH_IMPORTED=False" in shot["proc"].stderr


def test_report_has_per_stage_times(shot):
    report = json.loads((shot["dir"] / "report.json").read_text())
    for stage in ("build", "simulate", "render"):
        assert report["stages"][stage]["total_seconds"] > 0
    assert {o["label"] for o in report["objects"]} == {"cup", "box"}
    materials = report["stages"]["estimate"]["objects"]
    assert materials["cup_0"]["material"] == "rigid" and materials["cup_0"]["params"]["density"]["value"] == 700
    assert all(v["source"] == "rules" for m in materials.values() for v in m["params"].values())


def test_validate_passes(shot):
    findings = validate_stage(shot["shot"])
    assert [f for f in findings if f.severity == "error"] == []
    proc = cli("validate", shot["shot"])
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_newton_add_usd_loads_the_rigid_bodies(shot):
    import newton

    builder = newton.ModelBuilder()
    result = builder.add_usd(str(shot["shot"]), load_visual_shapes=False)
    bodies = sorted(result["path_body_map"])
    assert bodies == ["/World/Objects/box_1", "/World/Objects/cup_0"]
    assert all(m > 0 for m in builder.body_mass)


def test_objects_end_at_rest_on_the_ground_without_interpenetration(shot):
    stage = Usd.Stage.Open(str(shot["shot"]))
    end = stage.GetEndTimeCode()
    assert end == 30  # 1.5 s at 20 fps: frames 0..30
    worst = max(max_penetration(world_meshes(stage, t)) for t in range(int(end) + 1))
    assert worst <= 0.002, f"meshes interpenetrate by {worst * 1000:.1f} mm"
    final = world_meshes(stage, end)
    for name, mesh in final.items():
        assert abs(mesh.vertices[:, 2].min()) <= 0.005, name
    # at rest: the last two frames barely differ
    before = world_meshes(stage, end - 1)
    for name in final:
        assert np.abs(final[name].vertices - before[name].vertices).max() < 0.002, name


def test_push_moves_the_box_along_x(shot):
    stage = Usd.Stage.Open(str(shot["shot"]))
    attr = stage.GetPrimAtPath("/World/Objects/box_1").GetAttribute("xformOp:translate")
    start, end = np.array(attr.Get(0)), np.array(attr.Get(stage.GetEndTimeCode()))
    assert end[0] - start[0] > 0.01


def test_frame_zero_reproduces_the_photo(shot):
    frame0 = imageio.get_reader(str(shot["dir"] / "video.mp4")).get_data(0)
    photo = read_photo(shot["photo"])
    h, w = photo.shape[:2]
    assert ssim(frame0[:h, :w], photo) >= 0.9


@pytest.mark.parametrize("layer", ["scene.usda", "physics.usda"])
def test_each_generated_layer_validates(shot, layer):
    assert [f for f in validate_stage(shot["dir"] / layer) if f.severity == "error"] == []


def test_only_moving_prims_get_time_samples(shot):
    from pxr import Sdf

    sim = Sdf.Layer.FindOrOpen(str(shot["dir"] / "sim.usdc"))
    assert sim.GetPrimAtPath("/World/Objects/box_1")  # pushed
    assert not sim.GetPrimAtPath("/World/Objects/cup_0")  # left alone: it rests where it stands
    assert not sim.GetPrimAtPath("/World/Camera") and not sim.GetPrimAtPath("/World/Ground")
