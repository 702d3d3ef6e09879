"""What a new user sees: options named as typed, limits in --help, a label shared by objects, the shot's own
length, progress in a log, and a video the size of the photo."""

from __future__ import annotations

import json
import re
import shutil

import click
import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Sdf, Usd, UsdPhysics

from physomni_usd.cli import main

from .conftest import cli
from .test_bad_input import _assert_one_line_error


def test_a_label_two_objects_share_names_both_and_says_so(tmp_path, photo):
    out = tmp_path / "shot"
    proc = cli("build", photo["photo"], "-o", out, "--mask", f"{photo['cup']}:toy", "--mask",
               f"{photo['box']}:toy", "--push", "toy=0.5,0,0", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    for name in ("toy_0", "toy_1"):
        velocity = UsdPhysics.RigidBodyAPI(stage.GetPrimAtPath(f"/World/Objects/{name}")).GetVelocityAttr().Get()
        assert tuple(velocity) == pytest.approx((0.5, 0, 0)), name
    said = [ln for ln in proc.stderr.splitlines() if "--push toy" in ln]
    assert len(said) == 1 and "toy_0" in said[0] and "toy_1" in said[0], proc.stderr
    cli("estimate", out / "shot.usda", "--set", "toy.density=900", "--set", "toy_1.friction=0.3", check=True)
    stage.Reload()  # the layers changed on disk
    material = lambda name: stage.GetPrimAtPath(f"/World/Materials/Physics/{name}")  # noqa: E731
    assert [material(n).GetAttribute("physics:density").Get() for n in ("toy_0", "toy_1")] == [900, 900]
    assert material("toy_1").GetAttribute("physics:staticFriction").Get() == pytest.approx(0.3)
    assert material("toy_0").GetAttribute("physics:staticFriction").Get() != pytest.approx(0.3)


@pytest.mark.parametrize("args, option, unwanted", [
    (["--pitch", "99"], "--pitch 99", "pitch_deg"),
    (["--fov", "0"], "--fov 0", "fov_deg"),
    (["--camera-height", "nan"], "--camera-height nan", "height_m"),
    (["--seconds", "nan"], "--seconds nan", "600"),
])
def test_a_refused_value_is_named_by_its_option(tmp_path, photo, args, option, unwanted):
    proc = cli("run", photo["photo"], "-o", tmp_path / "out", "--mask", photo["cup"], *args)
    _assert_one_line_error(proc, option)
    assert unwanted not in proc.stderr
    if "nan" in args:
        assert "finite" in proc.stderr


def test_an_inverted_box_is_called_inverted(tmp_path, photo):
    proc = cli("build", photo["photo"], "-o", tmp_path / "out", "--box", "200,150,100,50:thing")
    _assert_one_line_error(proc, "X1 must be greater than X0")
    assert "not inside" not in proc.stderr


def test_a_truncated_png_gives_one_line_and_no_opencv_warning(tmp_path, photo):
    truncated = tmp_path / "photo.png"
    truncated.write_bytes(photo["photo"].read_bytes()[:2000])
    proc = cli("build", truncated, "-o", tmp_path / "out", "--mask", photo["cup"])
    _assert_one_line_error(proc, "cannot read", "photo.png")
    assert "WARN" not in proc.stderr


def test_simulate_without_seconds_keeps_the_shot_length(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    root = Sdf.Layer.FindOrOpen(str(folder / "shot.usda"))
    root.endTimeCode = 4.0  # a 0.2 s shot at 20 fps
    root.Save()
    cli("simulate", folder / "shot.usda", check=True)
    report = json.loads((folder / "report.json").read_text())["stages"]["simulate"]
    assert report["frames"] == 5 and report["simulated_seconds"] == pytest.approx(0.2)


@pytest.mark.parametrize("args, settings", [
    (["--substeps", "1000", "--seconds", "600"], {"substeps": 1000, "seconds": 600.0}),  # 12 M solver steps
    (["--seconds", "0"], {"seconds": 0.0}),
    (["--mpm-steps", "0"], {"mpm_steps": 0}),
])
def test_the_api_and_the_command_simulate_the_same_length_and_refuse_the_same_values(tmp_path, shot, args,
                                                                                       settings):
    """``physomni_usd.simulate(shot)`` and ``physomni-usd simulate shot``: the library owns the rules, so both
    simulate the shot's own length, and a value one refuses the other refuses with the same line and code."""
    import physomni_usd
    from physomni_usd.failure import failure_of
    from physomni_usd.settings import SimulateSettings

    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    root = Sdf.Layer.FindOrOpen(str(folder / "shot.usda"))
    root.endTimeCode = 4.0  # a 0.2 s shot at 20 fps
    root.Save()
    by_api = physomni_usd.simulate(folder / "shot.usda")
    cli("simulate", folder / "shot.usda", "-q", check=True)
    by_command = json.loads((folder / "report.json").read_text())["stages"]["simulate"]
    assert by_api["frames"] == by_command["frames"] == 5
    assert by_api["simulated_seconds"] == pytest.approx(by_command["simulated_seconds"]) == pytest.approx(0.2)

    proc = cli("simulate", folder / "shot.usda", *args)
    with pytest.raises(Exception) as refused:
        physomni_usd.simulate(folder / "shot.usda", SimulateSettings(**settings))
    found = failure_of(refused.value)
    assert proc.returncode == found.exit_code == 2
    assert f"error: {found.message}" in proc.stderr.splitlines() and args[0] in found.message


def test_a_simulate_option_is_one_field_that_every_command_and_batch_line_takes(tmp_path):
    """Each field of ``SimulateSettings`` that carries an Option is an option of ``simulate`` and of ``run``
    (``--fps`` there is the build's), reaches the settings a ``batch`` line runs with, and names a refused
    value: nothing lists simulate's options by hand."""
    from pydantic import ValidationError

    from physomni_usd.cli.cmd_run import run_arguments
    from physomni_usd.failure import failure_of
    from physomni_usd.settings import SimulateSettings, option

    fields = {f: option(SimulateSettings, f).flag for f in SimulateSettings.model_fields
              if option(SimulateSettings, f) is not None}
    assert {"seconds", "fps", "substeps", "particle_spacing", "mpm_steps"} <= set(fields)
    for name, left_out in (("simulate", set()), ("run", {"--fps"})):
        flags = {flag for p in main.commands[name].params for flag in getattr(p, "opts", ())}
        assert set(fields.values()) - left_out <= flags, name
    given = {"seconds": "1.5", "substeps": "7", "particle_spacing": "0.02", "mpm_steps": "3"}
    args = [str(tmp_path / "photo.png"), "-o", str(tmp_path / "out")]
    settings = run_arguments(args + [a for f, v in given.items() for a in (fields[f], v)])["simulate_settings"]
    assert {f: getattr(settings, f) for f in given} == {f: type(getattr(settings, f))(v) for f, v in given.items()}
    for field in given:
        with pytest.raises(ValidationError) as refused:
            SimulateSettings(**{field: -1})
        assert failure_of(refused.value).message.startswith(f"{fields[field]} -1")


def _numeric_options(command: click.Command):
    for param in command.params:
        if isinstance(param, click.Option) and isinstance(param.type, (click.types.FloatParamType,
                                                                       click.types.IntParamType)):
            yield param


@pytest.mark.parametrize("name", ["build", "run", "simulate", "render", "estimate"])
def test_help_states_the_limits_of_every_numeric_option(name):
    command = main.commands[name]
    text = " ".join(CliRunner().invoke(main, [name, "--help"]).output.split())
    for option in _numeric_options(command):
        is_range = isinstance(option.type, (click.FloatRange, click.IntRange))
        assert is_range or "Range:" in (option.help or ""), f"{name} {option.opts[0]}"
        assert option.opts[0] in text
    limits = {"build": ["5 < value < 150", "0 ≤ value ≤ 90"], "simulate": ["0 < value ≤ 600, finite"],
              "render": ["64 ≤ value ≤ 8192"]}
    for limit in limits.get(name, []):
        assert limit in text, limit


def test_progress_is_plain_lines_at_a_modest_rate_when_not_a_terminal(shot):
    lines = shot["proc"].stderr.splitlines()  # the fixture's `run`, captured: not a terminal
    for stage, frames in (("simulate", 30), ("render", 31)):
        progress = [ln for ln in lines if re.fullmatch(rf"{stage}: frame \d+/{frames}", ln)]
        assert progress and progress[-1] == f"{stage}: frame {frames}/{frames}", lines
        assert len(progress) <= 12
    assert not any(ln.strip() in ("simulate", "render") for ln in lines), lines


def test_an_odd_width_photo_gives_a_video_cropped_to_even_sides(tmp_path, photo):
    img = cv2.imread(str(photo["photo"]))[40:131, 20:141]  # 121 × 91 around the cup
    mask = (cv2.imread(str(photo["cup"]), cv2.IMREAD_GRAYSCALE)[40:131, 20:141] > 0).astype(np.uint8) * 255
    cv2.imwrite(str(tmp_path / "odd.png"), img)
    cv2.imwrite(str(tmp_path / "cup.png"), mask)
    out = tmp_path / "shot"
    cli("build", tmp_path / "odd.png", "-o", out, "--mask", f"{tmp_path / 'cup.png'}:cup", "-q", check=True)
    cli("render", out / "shot.usda", "--still", "-q", check=True)  # built only: one frame, asked for
    reader = imageio.get_reader(str(out / "video.mp4"))
    frame = reader.get_data(0)
    reader.close()
    assert frame.shape[:2] == (90, 120)
    report = json.loads((out / "report.json").read_text())["stages"]["render"]
    assert (report["width"], report["height"]) == (120, 90)


def test_the_edits_example_in_simulate_help_is_a_layer_usd_reads():
    """The lines `simulate --help` tells a user to put in edits.usda parse as USD and author what they say."""
    from pxr import Sdf

    text = CliRunner().invoke(main, ["simulate", "--help"]).output
    block = text.split("# in shot/edits.usda", 1)[1].split("physomni-usd simulate", 1)[0]
    layer = Sdf.Layer.CreateAnonymous(".usda")
    assert layer.ImportFromString("#usda 1.0\n" + block), block
    prim = layer.GetPrimAtPath("/World/Objects/box_0")
    assert prim is not None and prim.specifier == Sdf.SpecifierOver
    assert prim.attributes["physics:density"].default == 2000


def test_a_run_says_no_ignored_value_that_nobody_authored_and_one_a_user_set(tmp_path, shot):
    """The rules gave the box a static friction unlike its dynamic one: the report lists it, the run is
    silent about it; the same value set by a user is said, once, for that object."""
    lines = shot["proc"].stderr.splitlines()
    assert not [ln for ln in lines if "is ignored" in ln or "is clamped" in ln], lines
    listed = json.loads((shot["dir"] / "report.json").read_text())["stages"]["simulate"]["ignored_parameters"]
    assert {i["source"] for items in listed.values() for i in items} <= {"rules", "default"}
    assert any(i["param"] == "static_friction" for i in listed.get("box_1", [])), listed
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    cli("estimate", folder / "shot.usda", "--set", "box.static_friction=0.9", check=True)
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.1", check=True)
    said = [ln for ln in proc.stderr.splitlines() if "is ignored" in ln]
    assert len(said) == 1 and said[0].startswith("simulate: box_1: static_friction = 0.9 is ignored"), proc.stderr


def test_one_friction_coefficient_is_said_in_simulate_help_and_the_reference():
    import pathlib

    help_text = " ".join(CliRunner().invoke(main, ["simulate", "--help"]).output.split())
    reference = " ".join((pathlib.Path(__file__).parents[1] / "docs" / "reference.md").read_text().replace("`", "").split())
    for text in (help_text, reference):
        assert "Newton's contacts use one friction coefficient, dynamic_friction" in text


def test_help_texts_say_true_things():
    top = " ".join(CliRunner().invoke(main, ["--help"]).output.split())
    assert "`estimate --set` and the preview's \"Keep settings\" add your values" in top
    build = CliRunner().invoke(main, ["build", "--help"]).output
    max_pixels = " ".join(build.split("--max-pixels", 1)[1].split("\n  -", 1)[0].split())
    assert "objects" not in max_pixels and "Refuse a larger photo" in max_pixels
    box = " ".join(build.split("--box", 1)[1].split("\n  --", 1)[0].split())
    assert "at most 64 objects" in box


def test_a_missing_required_option_is_one_line_and_exit_2(tmp_path, photo):
    proc = cli("studio", photo["photo"])
    _assert_one_line_error(proc, "studio", "'-o' / '--output'", "--help")
    assert proc.returncode == 2 and "Usage:" not in proc.stderr + proc.stdout
    proc = cli("build", photo["photo"], "-o", tmp_path / "x", "--no-such-option")
    _assert_one_line_error(proc, "--no-such-option")
    assert proc.returncode == 2 and not (tmp_path / "x").exists()


def test_a_busy_port_in_studio_says_whose_port_without_guessing(tmp_path, photo):
    import socket

    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        proc = cli("studio", photo["photo"], "-o", tmp_path / "shot", "--port", port, "--no-open",
                   "--duration", "1")
        # the studio's live preview takes the port after --port: a busy one there is named as its
        proc2 = cli("studio", photo["photo"], "-o", tmp_path / "shot", "--port", port - 1, "--no-open",
                    "--duration", "1")
    _assert_one_line_error(proc, f"--port {port}", "choose another --port")
    _assert_one_line_error(proc2, f"--port {port - 1}", f"preview's port, {port})")
    for p in (proc, proc2):
        assert p.returncode == 2 and "another preview" not in p.stderr
    assert not (tmp_path / "shot").exists()


def test_a_layer_switching_a_body_from_rigid_prints_nothing_raw(tmp_path, shot):
    """Newton's importer handed a '$'-anchored pattern to USD as a prim path (USD printed "Ill-formed
    SdfPath"); a cloth from a surface with zero-area triangles made Newton print a warning."""
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    cli("estimate", folder / "shot.usda", "--set", "cup.material=pbd_cloth", check=True)
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.1", check=True)
    assert "Warning" not in proc.stderr and "SdfPath" not in proc.stderr, proc.stderr
    assert all(ln.startswith(("simulate:", "TORCH_IMPORTED")) for ln in proc.stderr.splitlines()), proc.stderr


def test_a_cloth_leaves_out_zero_area_triangles_and_newton_warns_of_none(caplog):
    import logging
    from types import SimpleNamespace

    from physomni_usd._warp import load_newton, load_warp
    from physomni_usd.physics.cloth import add_cloth

    wp, newton = load_warp(), load_newton()
    points = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0], [0.2, 0.2, 0]], float)
    faces = np.array([[0, 1, 2], [1, 3, 2], [0, 3, 4]])  # the last lies on one line: no area
    obj = SimpleNamespace(points=points, faces=faces, params={}, fixed=False, path="/World/Objects/c",
                          volume_density=None,
                          prim=SimpleNamespace(GetAttribute=lambda name: SimpleNamespace(Get=lambda: None)))
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    with caplog.at_level(logging.WARNING):
        start, count, sheet = add_cloth(builder, obj, wp)
    assert start == 0 and count == len(sheet.particles) and builder.tri_count == len(sheet.triangles) > 0
    a, b, c = (sheet.particles[sheet.triangles[:, k]] for k in range(3))
    assert np.linalg.norm(np.cross(b - a, c - a), axis=1).min() > 0  # the collinear triangle is not among them
    assert not [r for r in caplog.records if "degenerate" in r.getMessage()]
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)  # the same faces given whole: Newton warns
    with caplog.at_level(logging.WARNING):
        builder.add_cloth_mesh(pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0,
                               vel=wp.vec3(0.0, 0.0, 0.0), vertices=[wp.vec3(*q) for q in points],
                               indices=faces.ravel().tolist(), density=1.0)
    assert [r for r in caplog.records if "degenerate" in r.getMessage()]


COMPILE_CHECK = """
import sys
from physomni_usd._warp import load_warp
wp = load_warp()
wp.config.log_level = wp.LOG_INFO  # warp's own timer: one line per module it loads, '(compiled)' or '(cached)'
from physomni_usd.cli import main
main(sys.argv[1:], prog_name="physomni-usd")
"""


@pytest.mark.slow
def test_the_compile_line_is_the_compile_s_own_time(tmp_path, shot):
    """In an empty kernel cache, simulate's 'compiled in N s' is within 20 % of what warp's own timer says its
    builds took, and not the whole simulate's time."""
    import os
    import subprocess
    import sys

    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    env = dict(os.environ, WARP_CACHE_PATH=str(tmp_path / "kernels"))
    proc = subprocess.run([sys.executable, "-c", COMPILE_CHECK, "simulate", str(folder / "shot.usda"),
                           "--seconds", "0.5"], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    said = re.search(r"physics kernels compiled in (\d+) s", proc.stderr)
    assert said, proc.stderr
    own = sum(float(ms) for ms in re.findall(r"took ([\d.]+) ms\s+\(compiled\)", proc.stdout)) / 1000
    total = json.loads((folder / "report.json").read_text())["stages"]["simulate"]["total_seconds"]
    assert own > 5, proc.stdout
    assert abs(int(said.group(1)) - own) <= 0.2 * own + 0.5, (said.group(0), own, total)
