"""Sizes that agree and a support seen face-on: identical parts on a lightbox, a whale among toys."""

from __future__ import annotations

import json
import pathlib

import cv2
import numpy as np
import pytest

from physomni_usd.align.cues import estimate_camera
from physomni_usd.align.scale import fit_scale
from physomni_usd.lift.silhouette import fill_holes, foot_pixel

from .conftest import cli

#: An L-shaped bracket with a notch, pixels: straight edges only, nothing round for the ellipse cue.
PART = np.array([[0, 0], [50, 0], [50, 14], [18, 14], [18, 40], [0, 40]], np.int32)


def lightbox(folder: pathlib.Path) -> dict:
    """Four identical flat parts photographed straight down on a light background; writes photo and masks."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    img = np.full((240, 320, 3), 235.0) + rng.normal(0, 3, (240, 320, 1))
    paths = {"photo": folder / "photo.png"}
    for k, (x, y) in enumerate([(40, 40), (200, 40), (40, 150), (200, 150)]):
        m = np.zeros((240, 320), np.uint8)
        cv2.fillPoly(m, [PART + [x, y]], 1)
        img[m > 0] = np.array([60, 65, 75]) + rng.normal(0, 4, (int(m.sum()), 1))
        paths[f"part_{k}"] = folder / f"part_{k}.png"
        cv2.imwrite(str(paths[f"part_{k}"]), m * 255)
    cv2.imwrite(str(paths["photo"]), np.clip(img, 0, 255).astype(np.uint8))
    return paths


@pytest.fixture(scope="module")
def box_photo(tmp_path_factory):
    return lightbox(tmp_path_factory.mktemp("lightbox"))


def _report(folder):
    return json.loads((folder / "report.json").read_text())


def test_identical_flat_parts_seen_straight_down_give_a_top_down_camera(box_photo):
    photo = cv2.cvtColor(cv2.imread(str(box_photo["photo"])), cv2.COLOR_BGR2RGB)
    masks = [cv2.imread(str(box_photo[f"part_{k}"]), 0) > 0 for k in range(4)]
    est = estimate_camera(photo, masks, ["part"] * 4, [foot_pixel(fill_holes(m))[1] for m in masks])
    assert est.pitch_deg >= 70.0
    same = next(c for c in est.cues if c.kind == "identical objects")
    assert same.detail["objects"] == 4 and same.pitch_deg >= 85.0
    # the parts' parallel edges alone read as a level camera; the identical parts outvote that reading
    level = [c for c in est.cues if c.kind == "vertical vanishing point" and c.pitch_deg == 0.0]
    assert all(c.weight <= 0.1 for c in level)
    # different labels are not one thing seen several times: no cue
    est = estimate_camera(photo, masks, ["part", "bolt", "nut", "washer"], [200.0] * 4)
    assert not any(c.kind == "identical objects" for c in est.cues)


@pytest.mark.parametrize("pitch", [None, 30, 60, 90])
def test_the_lightbox_builds_at_any_workable_pitch_with_parts_of_one_size(tmp_path, box_photo, pitch):
    masks = [a for k in range(4) for a in ("--mask", f"{box_photo[f'part_{k}']}:part")]
    extra = [] if pitch is None else ["--pitch", str(pitch)]
    cli("build", box_photo["photo"], "-o", tmp_path, "-q", *masks, *extra, check=True)
    report = _report(tmp_path)
    longest = [max(o["size_m"]) for o in report["objects"]]
    assert max(longest) < 1.0
    if pitch in (None, 90):  # the right pitch: the four parts come out one size
        assert max(longest) / min(longest) <= 1.3
    if pitch is None:
        assert report["shot"]["pitch_deg"] >= 70.0


def test_a_level_pitch_that_leaves_parts_above_the_horizon_builds_with_the_least_pitch_and_says_so(tmp_path,
                                                                                                    box_photo):
    masks = [a for k in range(4) for a in ("--mask", f"{box_photo[f'part_{k}']}:part")]
    proc = cli("build", box_photo["photo"], "-o", tmp_path / "s", *masks, "--pitch", "0")
    assert proc.returncode == 0, proc.stderr
    said = [ln for ln in (proc.stdout + proc.stderr).splitlines() if "--pitch 0" in ln]
    assert len(said) == 1 and "warning" in said[0] and "above the horizon" in said[0], said
    camera = _report(tmp_path / "s")["shot"]["alignment"]["camera"]
    assert camera["pitch_given_deg"] == 0.0 and camera["pitch_deg"] >= camera["min_pitch_deg"] > 0.0
    assert max(max(o["size_m"]) for o in _report(tmp_path / "s")["objects"]) < 1.0


def test_objects_of_one_label_vote_once():
    # eleven sweets measured alike and one cup: the cup's vote counts as much as all the sweets'
    names = [f"sweet_{i}" for i in range(11)] + ["cup_11"]
    labels = ["sweet"] * 11 + ["cup"]
    fit = fit_scale(names, labels, [0.015 * 2.0] * 11 + [0.11 * 1.0])
    assert fit.factor == pytest.approx(np.sqrt(0.5), rel=1e-6)  # the geometric mean of ×0.5 and ×1


def test_priors_that_disagree_choose_a_plausible_camera_and_name_the_losers():
    fit = fit_scale(["whale_0", "box_1", "car_2"], ["whale", "box", "car"], [0.2, 0.15, 0.1])
    assert len(fit.warnings) == 1
    assert "whale_0" in fit.warnings[0] and "car_2" in fit.warnings[0] and "box_1" in fit.warnings[0]
    assert fit.factor == pytest.approx(0.4 / 0.15)  # the box's reading: a camera under 3 m
    assert max(m * fit.factor for m in (0.2, 0.15, 0.1)) < 1.0
    assert any(not r["plausible"] for r in fit.readings)
    # --size still wins, and priors that agree give no warning
    assert fit_scale(["whale_0", "box_1"], ["whale", "box"], [0.2, 0.15], {"whale_0": 15.0}).source == "size"
    assert not fit_scale(["cup_0", "mug_1"], ["cup", "mug"], [0.1, 0.12]).warnings


def test_a_whale_among_toys_on_a_desk_warns_once_and_stays_table_top(tmp_path):
    rng = np.random.default_rng(2)
    img = np.clip(np.full((240, 320, 3), 150.0) + rng.normal(0, 5, (240, 320, 1)), 0, 255)
    args = []
    for name, colour, draw in (
            ("whale", (60, 90, 200), lambda m: cv2.ellipse(m, (80, 160), (45, 22), 0, 0, 360, 1, -1)),
            ("box", (200, 150, 60), lambda m: cv2.rectangle(m, (140, 120), (190, 185), 1, -1)),
            ("car", (200, 40, 40), lambda m: cv2.rectangle(m, (220, 150), (290, 185), 1, -1))):
        m = np.zeros((240, 320), np.uint8)
        draw(m)
        img[m > 0] = colour
        cv2.imwrite(str(tmp_path / f"{name}.png"), m * 255)
        args += ["--mask", f"{tmp_path / name}.png:{name}"]
    cv2.imwrite(str(tmp_path / "photo.png"), img.astype(np.uint8))
    proc = cli("build", tmp_path / "photo.png", "-o", tmp_path / "shot", *args, check=True)
    said = [line for line in (proc.stdout + proc.stderr).splitlines() if "typical sizes disagree" in line]
    assert len(said) == 1 and all(n in said[0] for n in ("whale_0", "car_2", "box_1"))
    report = _report(tmp_path / "shot")
    assert max(max(o["size_m"]) for o in report["objects"]) < 1.0
    assert report["shot"]["scale"]["warnings"] == [said[0].split("warning: ", 1)[1]]


def _two_cards():
    """A 320×240 photo of two alike cards at two heights of the frame, and their masks."""
    rng = np.random.default_rng(3)
    img = np.clip(np.full((240, 320, 3), 180.0) + rng.normal(0, 3, (240, 320, 1)), 0, 255).astype(np.uint8)
    masks = []
    for x, y in ((60, 30), (200, 180)):
        m = np.zeros((240, 320), np.uint8)
        cv2.rectangle(m, (x, y), (x + 34, y + 22), 1, -1)
        img[m > 0] = (90, 120, 200)
        masks.append(m > 0)
    return img, masks


def test_two_alike_outlines_alone_do_not_make_the_camera_look_straight_down():
    # a card on the table and its twin pinned to the wall behind show one image size at two heights: their
    # ground areas agree straight down, but a pair meets that one equation at some pitch almost whatever it is
    img, masks = _two_cards()
    est = estimate_camera(img, masks, ["card", "card"], [foot_pixel(fill_holes(m))[1] for m in masks])
    same = next(c for c in est.cues if c.kind == "identical objects")
    assert same.pitch_deg > 80.0 and same.detail["objects"] == 2  # the reading itself is still made ...
    assert same.detail.get("uncorroborated") and same.weight <= 0.05  # ... but weighs next to nothing
    assert est.pitch_deg < 80.0 and "identical objects" not in est.pitch_source
    # four such parts, as on the lightbox, still read straight down by themselves
    quad = [np.roll(m, dx, 1) for m in masks for dx in (0, 60)]
    est = estimate_camera(img, quad, ["card"] * 4, [foot_pixel(fill_holes(m))[1] for m in quad])
    four = next(c for c in est.cues if c.kind == "identical objects")
    assert four.detail["objects"] == 4 and not four.detail.get("uncorroborated") and four.weight >= 1.0


def test_a_steep_pair_counts_with_an_agreeing_cue_and_a_cut_pair_leaves_a_larger_group(monkeypatch):
    # the rule's other side: an ellipse that reads the pair's pitch lets it keep its weight, while a weak or
    # steep horizon that itself needs agreement does not vouch for it
    from physomni_usd.align import cues as cue_mod

    img, masks = _two_cards()
    feet = [foot_pixel(fill_holes(m))[1] for m in masks]
    pair = cue_mod.identical_cues(masks, ["card", "card"], 320, 240, 50.0)[0]
    assert pair.pitch_deg > 80.0
    for kind, agrees in (("ellipse", True), ("horizon line", False)):
        extra = cue_mod.Cue(kind, pair.pitch_deg - 3.0, 0.5 if agrees else cue_mod.UNCORROBORATED_WEIGHT)
        monkeypatch.setattr(cue_mod, "ellipse_cues", lambda *a, _c=extra: [_c])
        est = estimate_camera(img, masks, ["card", "card"], feet)
        same = next(c for c in est.cues if c.kind == "identical objects")
        assert bool(same.detail.get("uncorroborated")) != agrees, kind
    monkeypatch.setattr(cue_mod, "ellipse_cues", lambda *a: [])
    # a steep pair heavier than a flatter triple: once the pair is cut down, the triple is the cue
    triple = cue_mod.Cue("identical objects", 30.0, 0.4, detail={"objects": 3, "label": "coin"})
    monkeypatch.setattr(cue_mod, "identical_cues", lambda *a: [pair, triple])
    est = estimate_camera(img, masks, ["card", "card"], feet)
    same = next(c for c in est.cues if c.kind == "identical objects")
    assert same is triple
