"""The field of view from the photo's EXIF: the 35 mm-equivalent focal length, else the focal length over the
sensor's size; --fov wins over it, it wins over the cues, an absurd value is said and left out, and the shot's
copy of the photo carries none of it."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from physomni_usd import building as build
from physomni_usd.cli import main
from physomni_usd.perceive.exif import exif_view
from physomni_usd.settings import BuildSettings, CameraSettings

EXIF_IFD = 0x8769
LIMITS = (5.0, 150.0)
HALF_DIAGONAL = 0.5 * math.hypot(36.0, 24.0)  # mm, of the 35 mm frame


def _jpeg(path, tags: dict, size=(40, 30), pixels=None):
    """A JPEG (``size`` = width, height, or the RGB ``pixels``) whose Exif IFD holds ``tags``."""
    exif = Image.Exif()
    exif[0x0112] = 6  # Orientation: rotate 90° to show; the build works on the pixels as stored all the same
    exif.get_ifd(EXIF_IFD).update(tags)
    image = Image.fromarray(pixels if pixels is not None else np.full((size[1], size[0], 3), 128, np.uint8))
    image.save(path, quality=95, exif=exif)
    return path


def test_35mm_equivalent_focal_length_gives_the_vertical_view_by_the_diagonal(tmp_path):
    # 26 mm (a phone's main camera) across the 43.27 mm diagonal is 79.5°; on a 4:3 photo its height spans
    # 3/5 of the diagonal: 2·atan(0.6·21.635/26) = 53.06°
    seen = exif_view(_jpeg(tmp_path / "a.jpg", {0xA405: 26}), 40, 30, LIMITS)
    assert seen.fov_deg == pytest.approx(53.06, abs=0.01)
    assert seen.source == "EXIF 35 mm-equivalent focal length 26 mm"
    # a 16:9 photo of the same lens shows less of its diagonal's height
    assert exif_view(_jpeg(tmp_path / "w.jpg", {0xA405: 26}, (64, 36)), 64, 36, LIMITS).fov_deg == pytest.approx(
        math.degrees(2 * math.atan(36 / math.hypot(64, 36) * HALF_DIAGONAL / 26)), abs=1e-6)


def test_focal_length_over_the_focal_plane_resolution(tmp_path):
    # 62.5 px/cm over 40 px: a 6.4 mm wide sensor, 4.8 mm high at 4:3; 4 mm lens: 2·atan(2.4/4) = 61.93°
    tags = {0x920A: 4.0, 0xA20E: 62.5, 0xA210: 3}
    seen = exif_view(_jpeg(tmp_path / "b.jpg", tags), 40, 30, LIMITS)
    assert seen.fov_deg == pytest.approx(61.93, abs=0.01)
    assert seen.source.startswith("EXIF focal length 4 mm on a 6.4 mm wide sensor")
    # the same camera's photo scaled down to half keeps its EXIF: the sensor is the written image's width
    half = exif_view(_jpeg(tmp_path / "h.jpg", {**tags, 0xA002: 40}, (20, 15)), 20, 15, LIMITS)
    assert half.fov_deg == pytest.approx(61.93, abs=0.01)
    # a focal length alone says nothing of the view
    assert exif_view(_jpeg(tmp_path / "f.jpg", {0x920A: 4.0}), 40, 30, LIMITS) is None


def test_no_or_absurd_exif_gives_no_view(tmp_path):
    assert exif_view(_jpeg(tmp_path / "n.jpg", {}), 40, 30, LIMITS) is None
    for tags in ({0xA405: 1}, {0xA405: 0}, {0x920A: 4.0, 0xA20E: 0.001, 0xA210: 3}):
        seen = exif_view(_jpeg(tmp_path / "x.jpg", tags), 40, 30, LIMITS)
        assert seen.fov_deg is None and "is ignored" in seen.warning, tags


@pytest.fixture(scope="module")
def exif_builds(tmp_path_factory, photo):
    """The synthetic photo as JPEGs carrying a 26 mm equivalent focal length, and an absurd 1 mm one, built
    without --fov and (the 26 mm one) with --fov 40."""
    folder = tmp_path_factory.mktemp("exif")
    pixels = cv2.cvtColor(cv2.imread(str(photo["photo"])), cv2.COLOR_BGR2RGB)
    h, w = pixels.shape[:2]
    masks = [f"{photo['cup']}:cup", f"{photo['box']}:box"]
    out = {}
    for name, f35, fov in (("exif", 26, None), ("given", 26, 40.0), ("absurd", 1, None)):
        path = _jpeg(folder / f"{name}.jpg", {0xA405: f35}, pixels=pixels)
        lines = []
        settings = BuildSettings(camera=CameraSettings(fov_deg=fov), settle_s=0.0)
        build.build_shot(path, folder / name, masks=masks, settings=settings, echo=lines.append)
        report = json.loads((folder / name / "report.json").read_text())
        out[name] = {"dir": folder / name, "lines": lines, "shot": report["shot"],
                     "fov_26": math.degrees(2 * math.atan(h / math.hypot(w, h) * HALF_DIAGONAL / 26))}
    return out


def test_build_takes_the_view_from_exif_and_says_so(exif_builds):
    b = exif_builds["exif"]
    assert b["shot"]["fov_deg"] == pytest.approx(b["fov_26"], abs=1e-3)
    assert b["shot"]["alignment"]["camera"]["fov_source"] == "EXIF 35 mm-equivalent focal length 26 mm"
    line = next(x for x in b["lines"] if x.startswith("align: camera"))
    assert f"field of view {b['fov_26']:.1f}° (EXIF 35 mm-equivalent focal length 26 mm)" in line


def test_fov_option_wins_over_exif(exif_builds):
    b = exif_builds["given"]
    assert b["shot"]["fov_deg"] == pytest.approx(40.0, abs=1e-3)
    assert b["shot"]["alignment"]["camera"]["fov_source"] == "user"
    assert any(x.startswith("align: camera") and "field of view 40.0° (user)" in x for x in b["lines"])


def test_an_absurd_exif_view_is_said_and_left_to_the_cues(exif_builds):
    b = exif_builds["absurd"]
    assert any(x.startswith("warning: the photo's EXIF 35 mm-equivalent focal length 1 mm") for x in b["lines"])
    assert not b["shot"]["alignment"]["camera"]["fov_source"].startswith("EXIF")
    assert 5.0 < b["shot"]["fov_deg"] < 150.0


def test_the_shots_copy_of_the_photo_carries_no_exif(exif_builds):
    copy = exif_builds["exif"]["dir"] / "inputs" / "photo.png"
    with Image.open(copy) as im:
        assert not im.getexif() and "exif" not in im.info
    assert b"eXIf" not in copy.read_bytes() and b"Exif" not in copy.read_bytes()


def test_fov_help_says_exif_is_read_without_it():
    text = " ".join(CliRunner().invoke(main, ["build", "--help"]).output.split())
    assert "--fov" in text and "EXIF" in text
