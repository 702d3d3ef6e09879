"""Bad input ends with one clear line and a non-zero exit, no traceback, and nothing half-written."""

from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest

from .conftest import cli
from .test_edits import EDIT


def _assert_one_line_error(proc, *needles):
    assert proc.returncode != 0
    lines = [ln for ln in proc.stderr.splitlines() if ln and not ln.startswith(("TORCH_IMPORTED", "Warp"))]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: ")
    assert "Traceback" not in proc.stderr + proc.stdout
    for needle in needles:
        assert needle in lines[0], lines[0]


def _snapshot(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_missing_photo(tmp_path):
    proc = cli("build", tmp_path / "nope.png", "-o", tmp_path / "out", "--mask", tmp_path / "m.png")
    _assert_one_line_error(proc, "photo not found")
    assert not (tmp_path / "out" / "scene.usda").exists()


def test_unreadable_photo(tmp_path, photo):
    bad = tmp_path / "photo.png"
    bad.write_bytes(b"this is not an image")
    proc = cli("build", bad, "-o", tmp_path / "out", "--mask", photo["cup"])
    _assert_one_line_error(proc, "cannot read")


def test_mask_of_another_size(tmp_path, photo):
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.full((10, 10), 255, np.uint8))
    proc = cli("build", photo["photo"], "-o", tmp_path / "out", "--mask", small)
    _assert_one_line_error(proc, "resolution")


def test_empty_mask(tmp_path, photo):
    empty = tmp_path / "empty.png"
    cv2.imwrite(str(empty), np.zeros((180, 240), np.uint8))
    proc = cli("build", photo["photo"], "-o", tmp_path / "out", "--mask", empty)
    _assert_one_line_error(proc, "empty")


def test_box_off_the_image(tmp_path, photo):
    proc = cli("build", photo["photo"], "-o", tmp_path / "out", "--box", "200,10,400,100:thing")
    _assert_one_line_error(proc, "not inside")


def test_unknown_push_label(tmp_path, photo):
    proc = cli("run", photo["photo"], "-o", tmp_path / "out", "--mask", photo["cup"], "--push", "ghost=1,0,0")
    _assert_one_line_error(proc, "ghost", "known: cup")
    assert not (tmp_path / "out" / "scene.usda").exists()


def test_output_directory_that_is_a_file(tmp_path, photo):
    target = tmp_path / "out"
    target.write_text("precious")
    proc = cli("build", photo["photo"], "-o", target, "--mask", photo["cup"])
    _assert_one_line_error(proc, "not a directory")
    assert target.read_text() == "precious"


@pytest.mark.parametrize("args, needle", [
    (["--fov", "0"], "fov"),
    (["--camera-height", "-1"], "height"),
    (["--seconds", "-2"], "seconds"),
])
def test_absurd_parameters(tmp_path, photo, args, needle):
    proc = cli("run", photo["photo"], "-o", tmp_path / "out", "--mask", photo["cup"], *args)
    _assert_one_line_error(proc, needle)


def test_no_objects(tmp_path, photo):
    proc = cli("build", photo["photo"], "-o", tmp_path / "out")
    _assert_one_line_error(proc, "no objects")


def test_broken_layer_stops_simulate_and_keeps_files(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    (folder / "physics.usda").write_text("#usda 1.0\nover \"World\" { this is not usd }\n")
    before = _snapshot(folder)
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.2")
    _assert_one_line_error(proc, "physics.usda")
    assert _snapshot(folder) == before


def test_absurd_density_in_edits_is_refused(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    (folder / "edits.usda").write_text(EDIT.format(name="cup_0", body="float physics:density = -5"))
    before = _snapshot(folder)
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.2")
    _assert_one_line_error(proc, "/World/Objects/cup_0", "physics:density")
    assert _snapshot(folder) == before


def test_missing_shot(tmp_path):
    proc = cli("simulate", tmp_path / "shot.usda")
    _assert_one_line_error(proc, "no shot")
