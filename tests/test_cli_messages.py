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
