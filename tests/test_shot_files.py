"""The shot folder stays right: the artist's layer keeps its time codes and its bytes, each stage writes only
its own layer, damaged or unwritable files are refused before any work, and a failed or smaller rebuild
leaves nothing stale behind."""

from __future__ import annotations

import json
import os
import shutil

import cv2
import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom

from physomni_usd._files import all_or_nothing, make_dirs, remove_file, write_bytes

from .conftest import cli
from .test_bad_input import _assert_one_line_error, _snapshot

#: An artist's layer with a bit of everything Sdf holds: layer metadata, a custom prim, a custom attribute
#: with time samples, a relationship, prim metadata and an over on a generated prim.
RICH_EDITS = """#usda 1.0
(
    "The artist's notes on this shot"
    customLayerData = {
        string artist = "kim"
        int revision = 7
    }
    doc = "blocking pass"
    framesPerSecond = 20
    timeCodesPerSecond = 20
)

def Xform "Extras" (
    kind = "group"
    doc = "props added by hand"
)
{
    custom double studio:weight = 2.5
    custom double studio:wobble.timeSamples = {
        10: 0.5,
        20: 1.5,
    }
    rel studio:target = </World/Objects/cup_0>
}

over "World"
{
    over "Objects"
    {
        over "cup_0" (
            customData = {
                string note = "keep me"
            }
        )
        {
            custom string studio:comment = "heavier next time"
        }
    }
}
"""


def _copy(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    return folder


def _stage(folder):
    return Usd.Stage.Open(str(folder / "shot.usda"))


# --- point 2: the artist's layer at the shot's time codes --------------------------------------------------

def test_edits_layer_has_the_shot_time_codes_so_keys_compose_at_their_frames(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    edits = Sdf.Layer.FindOrOpen(str(folder / "edits.usda"))
    assert edits.HasTimeCodesPerSecond() and edits.timeCodesPerSecond == 20  # the fixture shot runs at 20 fps
    assert edits.framesPerSecond == 20
    prim = Sdf.CreatePrimInLayer(edits, "/World/Objects/cup_0")
    attr = Sdf.AttributeSpec(prim, "studio:lift", Sdf.ValueTypeNames.Double)
    edits.SetTimeSample(attr.path, 10.0, 0.1)
    edits.SetTimeSample(attr.path, 20.0, 0.2)
    edits.Save()
    stage = _stage(folder)
    composed = stage.GetPrimAtPath("/World/Objects/cup_0").GetAttribute("studio:lift")
    assert composed.GetTimeSamples() == [10.0, 20.0]
    assert composed.Get(10) == pytest.approx(0.1) and composed.Get(20) == pytest.approx(0.2)


def test_validate_flags_a_sublayer_at_another_rate(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    edits = folder / "edits.usda"
    # keys in a layer at another rate are moved: an error
    edits.write_text('#usda 1.0\n(\n    timeCodesPerSecond = 24\n)\nover "World" {\n'
                     '    custom double studio:x.timeSamples = {\n        10: 1,\n    }\n}\n')
    proc = cli("validate", folder / "shot.usda")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert any(ln.startswith("error: edits.usda") and "24 time codes per second" in ln and "20" in ln
               for ln in proc.stdout.splitlines()), proc.stdout
    # an artist's layer with no rate and no keys yet: a warning, since keys added later would move
    edits.write_text("#usda 1.0\n")
    proc = cli("validate", folder / "shot.usda")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert any(ln.startswith("warning: edits.usda") and "none authored" in ln for ln in proc.stdout.splitlines())


# --- point 3: only `estimate --set` writes the artist's layer, through Sdf, keeping everything ----------

def _specs(layer: Sdf.Layer) -> dict:
    """Every prim and property spec of ``layer`` with its fields (values, time samples, metadata)."""
    out = {}

    def visit(path):
        spec = layer.GetObjectAtPath(path)
        if spec is None:  # a relationship target path, not a spec
            return
        out[str(path)] = {key: repr(spec.GetInfo(key)) for key in spec.ListInfoKeys()}
        if path.IsPropertyPath() and layer.ListTimeSamplesForPath(path):
            out[str(path)]["samples"] = {t: repr(layer.QueryTimeSample(path, t))
                                         for t in layer.ListTimeSamplesForPath(path)}
    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return out


def test_no_command_but_estimate_set_changes_the_artist_layer(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    edits = folder / "edits.usda"
    edits.write_text(RICH_EDITS)
    original = edits.read_bytes()
    masks = ["--mask", f"{shot['cup']}:cup", "--mask", f"{shot['box']}:box"]
    for args in (["build", shot["photo"], "-o", folder, *masks, "--fps", "20"],
                 ["estimate", folder / "shot.usda"],
                 ["simulate", folder / "shot.usda", "--seconds", "0.2"],
                 ["render", folder / "shot.usda"],
                 ["validate", folder / "shot.usda"],
                 ["run", shot["photo"], "-o", folder, *masks, "--fps", "20", "--seconds", "0.2"]):
        cli(*args, check=True)
        assert edits.read_bytes() == original, args[0]

    before = _specs(Sdf.Layer.OpenAsAnonymous(str(edits)))
    cli("estimate", folder / "shot.usda", "--set", "cup.density=800", check=True)
    after = _specs(Sdf.Layer.OpenAsAnonymous(str(edits)))
    for path, fields in before.items():  # every spec, value, time sample and metadata the artist had
        assert path in after, path
        for key, value in fields.items():
            assert after[path].get(key) == value, (path, key)
    layer = Sdf.Layer.OpenAsAnonymous(str(edits))
    assert layer.customLayerData == {"artist": "kim", "revision": 7}
    assert layer.documentation == "blocking pass" and layer.comment == "The artist's notes on this shot"
    stage = _stage(folder)
    assert stage.GetPrimAtPath("/World/Materials/Physics/cup_0").GetAttribute("physics:density").Get() == 800


def test_estimate_set_adds_the_shot_rate_to_an_artist_layer_without_one(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    edits = folder / "edits.usda"
    edits.write_text('#usda 1.0\nover "World" {\n    custom double studio:x.timeSamples = {\n'
                     '        10: 1,\n        20: 2,\n    }\n}\n')
    cli("estimate", folder / "shot.usda", "--set", "box.friction=0.8", check=True)
    layer = Sdf.Layer.OpenAsAnonymous(str(edits))
    assert layer.timeCodesPerSecond == 20 and layer.framesPerSecond == 20
    stage = _stage(folder)
    assert stage.GetPrimAtPath("/World").GetAttribute("studio:x").GetTimeSamples() == [10.0, 20.0]


# --- point 4: simulate's particles live in simulate's own layer ----------------------------------------

def test_particles_are_defined_in_the_sim_layer_and_survive_a_new_estimate(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    cli("estimate", folder / "shot.usda", "--set", "cup.material=mpm_sand", check=True)
    cli("simulate", folder / "shot.usda", "--seconds", "0.2", "--particle-spacing", "0.06", check=True)
    sim = Sdf.Layer.OpenAsAnonymous(str(folder / "sim.usdc"))
    spec = sim.GetPrimAtPath("/World/Particles/cup_0")
    assert spec and spec.specifier == Sdf.SpecifierDef and spec.typeName == "Points"
    physics_before = (folder / "physics.usda").read_bytes()
    assert b"Particles" not in physics_before
    cli("estimate", folder / "shot.usda", check=True)  # rewrites physics.usda
    stage = _stage(folder)
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Particles/cup_0"))
    assert points and points.GetPointsAttr().GetNumTimeSamples() == stage.GetEndTimeCode() + 1
    mesh = UsdGeom.Imageable(stage.GetPrimAtPath("/World/Objects/cup_0"))
    for t in range(1, int(stage.GetEndTimeCode()) + 1):  # the particles stand in for the hidden mesh
        assert mesh.ComputeVisibility(t) == "invisible" and points.ComputeVisibility(t) != "invisible"
    assert mesh.ComputeVisibility(0) != "invisible" and points.ComputeVisibility(0) == "invisible"
    assert cli("validate", folder / "shot.usda").returncode == 0


# --- point 11: damaged or missing layers are bad input -------------------------------------------------

def test_damaged_or_missing_layers_are_refused_and_nothing_is_replaced(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    good = (folder / "sim.usdc").read_bytes()
    (folder / "sim.usdc").write_bytes(good[: len(good) // 3])
    before = _snapshot(folder)
    for command in ("render", "validate"):
        proc = cli(command, folder / "shot.usda")
        assert proc.returncode == 2, proc.stderr
        _assert_one_line_error(proc, "sim.usdc", "damaged")
        assert _snapshot(folder) == before, command
    (folder / "sim.usdc").write_bytes(good)
    (folder / "physics.usda").unlink()
    before = _snapshot(folder)
    for command in ("simulate", "render", "estimate"):
        proc = cli(command, folder / "shot.usda")
        assert proc.returncode == 2, proc.stderr
        _assert_one_line_error(proc, "physics.usda", "missing")
        assert _snapshot(folder) == before, command


# --- point 12: unwritable targets are refused before any work, and a command changes all or nothing ----

def test_unwritable_targets_are_refused_before_computing(tmp_path, shot):
    # Root writes into read-only folders, so these use what stops root too: a folder, or a file, in the
    # way of what a command writes.
    folder = _copy(tmp_path, shot)
    (folder / "report.json").unlink()
    (folder / "report.json").mkdir()
    before = _snapshot(folder)
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.5")
    _assert_one_line_error(proc, "report.json")
    assert proc.returncode == 2 and "frame" not in proc.stderr  # refused before simulating
    assert _snapshot(folder) == before
    shutil.rmtree(folder / "report.json")

    # a rebuild that cannot write one texture changes nothing at all (no new plate beside an old scene)
    (folder / "textures" / "box_1.png").unlink()
    (folder / "textures" / "box_1.png").mkdir()
    before = _snapshot(folder)
    proc = cli("build", shot["photo"], "-o", folder, "--mask", f"{shot['cup']}:cup", "--mask",
               f"{shot['box']}:box", "--fps", "20")
    _assert_one_line_error(proc, "box_1.png")
    assert _snapshot(folder) == before

    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    proc = cli("render", folder / "shot.usda", "-o", blocker / "video.mp4")
    _assert_one_line_error(proc, "a_file")
    assert proc.returncode == 2


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                    reason="root writes into read-only folders; the test above covers root with files in the way")
def test_read_only_shot_folder_is_refused_before_computing(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    before = _snapshot(folder)
    os.chmod(folder, 0o555)
    try:
        proc = cli("simulate", folder / "shot.usda", "--seconds", "0.5")
    finally:
        os.chmod(folder, 0o755)
    _assert_one_line_error(proc, "not writable")
    assert proc.returncode == 2 and _snapshot(folder) == before


def test_a_failed_command_puts_every_file_back(tmp_path):
    keep = tmp_path / "keep.txt"
    keep.write_text("old")
    gone = tmp_path / "gone.txt"
    gone.write_text("mine")
    with pytest.raises(RuntimeError), all_or_nothing():
        write_bytes(keep, b"new")
        make_dirs(tmp_path / "new" / "deeper")
        write_bytes(tmp_path / "new" / "deeper" / "f.bin", b"1")
        remove_file(gone)
        assert keep.read_text() == "new" and not gone.exists()  # later steps see earlier writes
        raise RuntimeError("a stage failed")
    assert keep.read_text() == "old" and gone.read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gone.txt", "keep.txt"]


# --- point 13: failed and smaller builds leave nothing stale -------------------------------------------

def test_failed_build_and_run_leave_no_output_folder(tmp_path, photo):
    truncated = tmp_path / "mask.png"
    truncated.write_bytes(photo["cup"].read_bytes()[:60])
    for command in ("build", "run"):
        out = tmp_path / f"out_{command}" / "shot"
        proc = cli(command, photo["photo"], "-o", out, "--mask", f"{photo['box']}:box", "--mask", truncated)
        assert proc.returncode == 2, proc.stderr
        assert not (tmp_path / f"out_{command}").exists(), command


def test_rebuild_with_fewer_objects_removes_what_the_old_build_made(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    (folder / "notes.txt").write_text("mine")
    cv2.imwrite(str(folder / "textures" / "mine.png"), np.zeros((4, 4, 3), np.uint8))
    (folder / "edits.usda").write_text('#usda 1.0\nover "World" {\n    over "Objects" {\n'
                                       '        over "box_1" {\n            float physics:density = 300\n'
                                       '        }\n    }\n}\n')
    proc = cli("build", shot["photo"], "-o", folder, "--mask", f"{shot['cup']}:cup", "--fps", "20", check=True)
    assert not (folder / "textures" / "box_1.png").exists()
    assert not (folder / "inputs" / "masks" / "box_1.png").exists()
    assert not (folder / "video.mp4").exists()  # it showed the old shot
    assert (folder / "textures" / "cup_0.png").exists() and (folder / "textures" / "plate.png").exists()
    assert (folder / "notes.txt").read_text() == "mine" and (folder / "textures" / "mine.png").exists()
    warning = [ln for ln in proc.stderr.splitlines() if ln.startswith("warning: edits.usda")]
    assert len(warning) == 1 and "/World/Objects/box_1" in warning[0], proc.stderr
    report = json.loads((folder / "report.json").read_text())
    assert set(report["stages"]) == {"build", "estimate"}  # the old simulate and render sections are gone


# --- point 10 (report.json) -----------------------------------------------------------------------------

def test_damaged_report_is_moved_aside_not_lost(tmp_path, shot):
    folder = _copy(tmp_path, shot)
    (folder / "report.json").write_text('{"stages": {"build": ')
    proc = cli("estimate", folder / "shot.usda", check=True)
    assert (folder / "report.json.bad").read_text() == '{"stages": {"build": '
    assert "report.json.bad" in proc.stderr
    assert "estimate" in json.loads((folder / "report.json").read_text())["stages"]
