"""A scene checked before it is simulated: findings after build and in validate, and a fast, named failure."""

from __future__ import annotations

import json
import shutil
import time

import pytest
from pxr import Usd

from .conftest import cli

EDITS = """#usda 1.0
over "World" {{
    over "Objects" {{
        over "{name}" {{
{body}
        }}
    }}
}}
"""


@pytest.fixture(scope="module")
def built(tmp_path_factory, photo):
    out = tmp_path_factory.mktemp("checked")
    cli("build", photo["photo"], "-o", out, "-q", "--mask", f"{photo['cup']}:cup", "--mask", f"{photo['box']}:box",
        check=True)
    return out


def _copy_with_edits(built, tmp_path, name, body):
    shot = tmp_path / "shot"
    shutil.copytree(built, shot)
    (shot / "edits.usda").write_text(EDITS.format(name=name, body=body))
    return shot


def _translate(shot, name):
    stage = Usd.Stage.Open(str(shot / "scene.usda"))
    return tuple(stage.GetPrimAtPath(f"/World/Objects/{name}").GetAttribute("xformOp:translate").Get())


def test_a_built_scene_is_checked_and_validates(built):
    report = json.loads((built / "report.json").read_text())
    assert isinstance(report["stages"]["build"]["checks"], list)
    assert not [c for c in report["stages"]["build"]["checks"] if c["severity"] == "error"]
    proc = cli("validate", built / "shot.usda")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_two_objects_deep_inside_each_other_fail_fast_naming_them(built, tmp_path):
    x, y, z = _translate(built, "cup_0")
    shot = _copy_with_edits(built, tmp_path, "box_1", f"            double3 xformOp:translate = ({x}, {y}, {z})")
    before = (shot / "sim.usdc").read_bytes()
    t0 = time.perf_counter()
    proc = cli("simulate", shot / "shot.usda", "--seconds", "1")
    seconds = time.perf_counter() - t0
    assert proc.returncode == 1
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "inside" in lines[0] and "cup_0" in lines[0] and "box_1" in lines[0], proc.stderr
    assert (shot / "sim.usdc").read_bytes() == before
    print(f"failed in {seconds:.1f} s")  # the issue asks for ≤ 60 s; a benchmark, not an assertion
    # the line the guard prints when it gives up names the same cause
    from physomni_usd.physics.diagnose import failure_line
    from physomni_usd.usd import layers

    line = failure_line(layers.open_shot(shot), "simulation diverged at frame 2")
    assert line.startswith("simulation diverged at frame 2; likely cause: box_1 starts") and "inside cup_0" in line


def test_an_absurd_size_in_edits_fails_validate_and_simulate(built, tmp_path):
    body = ('            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:orient", "xformOp:scale"]\n'
            "            float3 xformOp:scale = (400, 400, 400)")
    shot = _copy_with_edits(built, tmp_path, "cup_0", body)
    proc = cli("validate", shot / "shot.usda")
    assert proc.returncode == 1
    assert any("cup_0" in line and "label suggests" in line and line.startswith("error")
               for line in proc.stdout.splitlines()), proc.stdout
    before = (shot / "sim.usdc").read_bytes()
    proc = cli("simulate", shot / "shot.usda", "--seconds", "1")
    assert proc.returncode == 1
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "cup_0 is" in lines[0] and "label suggests" in lines[0], proc.stderr
    assert (shot / "sim.usdc").read_bytes() == before


def test_kilometre_sized_objects_do_not_pass_validate_nor_build(built, tmp_path, photo):
    # build refuses what simulate would refuse: one line naming the object, exit 1, nothing written
    out = tmp_path / "km"
    proc = cli("build", photo["photo"], "-o", out, "-q", "--mask", f"{photo['cup']}:gizmo", "--size", "gizmo=5000")
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error")]
    assert proc.returncode == 1 and len(lines) == 1 and "gizmo_0 is 5 km" in lines[0], proc.stderr
    assert "simulate would refuse" in lines[0] and not out.exists()
    # a layer that makes an object kilometres large fails validate
    body = ('            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:orient", "xformOp:scale"]\n'
            "            float3 xformOp:scale = (50000, 50000, 50000)")
    shot = _copy_with_edits(built, tmp_path, "cup_0", body)
    proc = cli("validate", shot / "shot.usda")
    assert proc.returncode == 1 and "kilometres" in proc.stdout, proc.stdout


def test_a_build_whose_mass_simulate_refuses_ends_in_one_line_and_leaves_the_folder_as_it_was(tmp_path, photo):
    # a cup said to be 300 m is the size the user gave (no size finding), but it weighs more than anything a
    # photo of objects holds: simulate refuses that mass, so build must not write it and exit 0
    out = tmp_path / "heavy"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    proc = cli("build", photo["photo"], "-o", out, "-q", "--mask", f"{photo['cup']}:cup", "--size", "cup=300")
    lines = [line for line in proc.stderr.splitlines() if line.startswith("error")]
    assert proc.returncode == 1 and len(lines) == 1, proc.stderr
    assert "cup_0 weighs" in lines[0] and "simulate would refuse" in lines[0], proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
