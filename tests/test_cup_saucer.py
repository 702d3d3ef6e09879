"""A cup on its saucer with a spoon in the saucer, from the three *visible* masks a user or a segmenter gives:
build finds who hides whom, completes the saucer behind them, paints its hidden part from its own surface,
and reports what each object stands on and how far from it it starts."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from physomni_usd.bench.synthetic import render_truth
from physomni_usd.geometry.camera import PinholeCamera

from .conftest import TRUTH_CAMERA
from .conftest import cup_saucer_truth as _truth


@pytest.fixture(scope="module")
def cup_on_saucer(cup_saucer_build):
    """The session's build (tests/conftest.py's ``cup_saucer_build``), with the saucer's full outline."""
    out, masks = cup_saucer_build["out"], cup_saucer_build["masks"]
    whole = render_truth(TRUTH_CAMERA, _truth()[:1])[1][0]  # the saucer's full outline, nothing in front
    return {"out": out, "photo": cup_saucer_build["photo"], "whole": whole, "saucer": masks[0], "cup": masks[1],
            "spoon": masks[2], "report": json.loads((out / "report.json").read_text())}


def test_the_order_and_the_completed_area_are_in_the_report(cup_on_saucer):
    report = cup_on_saucer["report"]
    order = {(o["front"], o["behind"]): o["kept"] for o in report["stages"]["build"]["occlusion"]}
    assert ("cup_1", "saucer_0") in order and ("spoon_2", "saucer_0") in order
    assert not any(behind == "cup_1" for _, behind in order)
    assert order[("cup_1", "saucer_0")] >= 0.9 and order[("spoon_2", "saucer_0")] >= 0.9  # the meshes keep it
    saucer = report["objects"][0]
    assert saucer["occluded_by"] == ["cup_1", "spoon_2"] and saucer["completed"]["how"] == "ellipse"
    hidden = cup_on_saucer["whole"] & (cup_on_saucer["cup"] | cup_on_saucer["spoon"])
    assert saucer["completed"]["pixels"] >= 0.9 * hidden.sum()
    assert "occluded_by" not in report["objects"][1]


def test_the_saucers_texture_is_whole_and_its_own_colour_behind_the_cup(cup_on_saucer):
    out, whole = cup_on_saucer["out"], cup_on_saucer["whole"]
    rgba = cv2.cvtColor(cv2.imread(str(out / "textures" / "saucer_0.png"), cv2.IMREAD_UNCHANGED), cv2.COLOR_BGRA2RGBA)
    ys, xs = np.nonzero(whole)
    pad = 8  # object_texture's margin around the mask
    x0, y0 = max(0, xs.min() - pad), max(0, ys.min() - pad)
    under_cup = whole & cup_on_saucer["cup"]
    ys, xs = np.nonzero(under_cup)
    alpha = rgba[ys - y0, xs - x0, 3]
    assert (alpha > 0).mean() >= 0.9  # the saucer's texture covers where the cup stands
    colour = rgba[ys - y0, xs - x0, :3].astype(int)
    photo = cup_on_saucer["photo"].astype(int)
    saucer = np.median(photo[cup_on_saucer["saucer"]], axis=0)
    cup = np.median(photo[cup_on_saucer["cup"]], axis=0)
    # the saucer's own colour, not the cup's
    assert np.median(np.abs(colour - saucer).max(1)) < 0.5 * np.abs(cup - saucer).max()


def test_each_object_reports_what_it_stands_on_and_its_start_clearance(cup_on_saucer):
    starts = [o["start"] for o in cup_on_saucer["report"]["objects"]]
    assert [s["support"] for s in starts] == ["ground", "saucer_0", "saucer_0"]
    assert starts[0]["clearance_m"] == pytest.approx(0.0, abs=1e-4)
    assert all(set(s) == {"support", "clearance_m", "overlap_m"} for s in starts)


def test_no_object_starts_more_than_2mm_inside_another_or_above_its_support(cup_on_saucer):
    for o in cup_on_saucer["report"]["objects"]:
        assert o["start"]["overlap_m"] <= 0.002, o["name"]
        assert -0.002 <= o["start"]["clearance_m"] <= 0.002, o["name"]


def test_the_saucers_mesh_covers_its_whole_outline(cup_on_saucer):
    from pxr import Usd

    from physomni_usd.metrics.geometry import world_meshes
    from physomni_usd.rendering.stage import read_photo_camera_matrix

    stage = Usd.Stage.Open(str(cup_on_saucer["out"] / "shot.usda"))
    m = read_photo_camera_matrix(stage)  # USD camera: rows are its x, y (up) and z (backward) axes
    axes = np.stack([m[0, :3], -m[1, :3], -m[2, :3]], 1)
    fov = cup_on_saucer["report"]["shot"]["fov_deg"]
    camera = PinholeCamera.from_pose(320, 240, fov, m[3, :3], axes / np.linalg.norm(axes, axis=0))
    saucer = world_meshes(stage, stage.GetStartTimeCode())["saucer_0"]
    seen = render_truth(camera, [saucer])[1][0]
    whole = cup_on_saucer["whole"]
    assert (seen & whole).sum() >= 0.9 * whole.sum()


def test_with_the_cup_gone_the_saucer_shows_where_it_stood(cup_on_saucer):
    from pxr import Gf, Usd, UsdGeom

    from physomni_usd.rendering.video import ShotRenderer

    stage = Usd.Stage.Open(str(cup_on_saucer["out"] / "shot.usda"))
    with Usd.EditContext(stage, stage.GetSessionLayer()):  # the cup pushed 1 m aside, off the saucer
        op = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Objects/cup_1")).GetOrderedXformOps()[0]
        op.Set(op.Get() + Gf.Vec3d(1.0, 0.0, 0.0))
    frame = ShotRenderer(stage).frame(float(stage.GetStartTimeCode())).astype(int)
    plate = cv2.cvtColor(cv2.imread(str(cup_on_saucer["out"] / "textures" / "plate.png")), cv2.COLOR_BGR2RGB)
    photo = cup_on_saucer["photo"].astype(int)
    where = cup_on_saucer["whole"] & cup_on_saucer["cup"]
    where = cv2.erode(where.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0  # away from the edges
    saucer = np.median(photo[cup_on_saucer["saucer"]], axis=0)
    off_saucer = np.abs(frame[where] - saucer).max(1)
    off_table = np.abs(frame[where] - plate[where].astype(int)).max(1)
    assert where.sum() > 200
    assert (off_saucer < off_table).mean() >= 0.9  # saucer colour, not the table's
