"""Force fields and controls given on the command line act in the simulated shot."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pxr import Usd

from .conftest import cli

G = 9.81


def _x_travel(folder, name, seconds):
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    attr = stage.GetPrimAtPath(f"/World/Objects/{name}").GetAttribute("xformOp:translate")
    end = stage.GetEndTimeCode()
    return np.array(attr.Get(end)) - np.array(attr.Get(0)), end


def _build(tmp_path, shot, *extra):
    out = tmp_path / "shot"
    cli("build", shot["photo"], "-o", out, "--mask", f"{shot['box']}:box", "-q", *extra, check=True)
    return out


def test_strong_wind_slides_the_box_against_friction(tmp_path, shot):
    out = tmp_path / "shot"
    cli("run", shot["photo"], "-o", out, "--mask", f"{shot['box']}:box", "-q", "--seconds", "0.5",
        "--force", "wind:direction=1,0,0,strength=30", check=True)
    move, _ = _x_travel(out, "box_0", 0.5)
    mu = 0.45  # the table's cardboard dynamic friction ('box')
    expected = 0.5 * (30 - mu * G) * 0.5 ** 2
    assert move[0] == pytest.approx(expected, rel=0.1)
    assert abs(move[1]) < 0.05 * move[0]


def test_weak_wind_does_not_beat_static_friction(tmp_path, shot):
    out = _build(tmp_path, shot, "--force", "wind:direction=1,0,0,strength=3")
    cli("simulate", out / "shot.usda", "--seconds", "0.5", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    attr = stage.GetPrimAtPath("/World/Objects/box_0").GetAttribute("xformOp:translate")
    assert attr.GetNumTimeSamples() == 0  # it never moved


def test_disabled_field_does_nothing(tmp_path, shot):
    out = _build(tmp_path, shot, "--force", "wind:direction=1,0,0,strength=30,enabled=false")
    cli("simulate", out / "shot.usda", "--seconds", "0.3", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    assert stage.GetPrimAtPath("/World/Objects/box_0").GetAttribute("xformOp:translate").GetNumTimeSamples() == 0


@pytest.mark.parametrize("spec, needle", [
    ("tornado:strength=3", "unknown force field kind"),
    ("wind:direction=1,0", "three finite numbers"),
    ("constant:direction=0,0,-1,strength=9.81", "repeats gravity"),
    ("wind:colour=red", "no parameter"),
])
def test_bad_force_specs_are_refused(tmp_path, shot, spec, needle):
    proc = cli("build", shot["photo"], "-o", tmp_path / "o", "--mask", shot["box"], "--force", spec)
    assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr


def test_fixed_object_stays_under_wind(tmp_path, shot):
    out = _build(tmp_path, shot, "--force", "wind:direction=1,0,0,strength=30", "--fix", "box")
    cli("simulate", out / "shot.usda", "--seconds", "0.3", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    assert stage.GetPrimAtPath("/World/Objects/box_0").GetAttribute("xformOp:translate").GetNumTimeSamples() == 0


def test_push_at_a_time_starts_the_motion_then(tmp_path, shot):
    out = _build(tmp_path, shot, "--push", "box=1.5,0,0@0.5", "--fps", "20")
    cli("simulate", out / "shot.usda", "--seconds", "1.0", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    attr = stage.GetPrimAtPath("/World/Objects/box_0").GetAttribute("xformOp:translate")
    x = np.array([attr.Get(t)[0] for t in range(21)])
    assert np.abs(x[:10] - x[0]).max() < 1e-3  # still before 0.5 s
    assert x[-1] - x[10] > 0.05  # moving after


def test_cloth_material_drapes_as_xpbd_cloth_with_pinning(tmp_path, shot):
    import numpy as np
    from pxr import Usd

    out = tmp_path / "shot"
    cli("build", shot["photo"], "-o", out, "--mask", f"{shot['cup']}:towel", "--mask", f"{shot['box']}:box", "-q",
        check=True)
    (out / "edits.usda").write_text('#usda 1.0\nover "World" {\n    over "Objects" {\n        over "towel_0" {\n'
                                    '            float physomni:fixTopRatio = 0.1\n        }\n    }\n}\n')
    cli("simulate", out / "shot.usda", "--seconds", "0.5", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    points = stage.GetPrimAtPath("/World/Objects/towel_0").GetAttribute("points")
    assert points.GetNumTimeSamples() == stage.GetEndTimeCode() + 1
    first, last = np.array(points.Get(0)), np.array(points.Get(stage.GetEndTimeCode()))
    assert np.isfinite(last).all()
    top = first[:, 2] >= first[:, 2].max() - 0.1 * np.ptp(first[:, 2])
    assert np.abs(last[top] - first[top]).max() < 1e-5  # pinned
    assert np.abs(last[~top] - first[~top]).max() > 0.01  # the rest hangs and moves
    report = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    assert "towel_0" in report["cloths"] and report["objects"]["towel_0"]["solver"] == "cloth"


def test_push_moves_a_cloth(tmp_path, shot):
    import numpy as np
    from pxr import Usd

    out = tmp_path / "shot"
    cli("run", shot["photo"], "-o", out, "--mask", f"{shot['cup']}:towel", "--push", "towel=2,0,0",
        "--seconds", "0.5", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    points = stage.GetPrimAtPath("/World/Objects/towel_0").GetAttribute("points")
    shift = np.array(points.Get(stage.GetEndTimeCode())).mean(0) - np.array(points.Get(0)).mean(0)
    assert shift[0] > 0.2


def test_fixed_cloth_does_not_move(tmp_path, shot):
    from pxr import Usd

    out = tmp_path / "shot"
    cli("run", shot["photo"], "-o", out, "--mask", f"{shot['cup']}:towel", "--fix", "towel", "--seconds", "0.3",
        "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    assert stage.GetPrimAtPath("/World/Objects/towel_0").GetAttribute("points").GetNumTimeSamples() == 0
