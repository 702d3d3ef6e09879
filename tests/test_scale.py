"""Real sizes: the label table, the robust scale fit, --size, and the VLM's sizes."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physomni_usd.align.scale import fit_scale, parse_sizes
from physomni_usd.errors import InputError
from physomni_usd.materials.parse import parse_reply
from physomni_usd.sizes import SIZES, size_prior

from .conftest import cli


def test_table_covers_everyday_objects_and_reads_labels_as_words():
    assert sum(p.votes for p in SIZES) >= 60
    assert size_prior("coin").longest_m == pytest.approx(0.024)
    assert size_prior("Red_Cups").keyword == "cup"
    assert size_prior("tower_left").keyword == "tower"
    assert size_prior("rubber whale").longest_m < 0.5  # a toy, not a 15 m animal
    assert size_prior("card").keyword == "card" and size_prior("car").keyword == "car"
    assert not size_prior("sand").votes and size_prior("gizmo") is None


def test_scale_is_the_robust_mean_of_the_votes_and_ignores_an_outlier():
    names = ["coin_0", "pencil_1", "cup_2", "lighter_3"]
    labels = ["coin", "pencil", "cup", "lighter"]
    truth = 0.05  # the scene came out 20 times too large ...
    measured = [0.024 / truth * 1.1, 0.19 / truth * 0.95, 0.11 / truth, 0.08 / truth * 30]  # ... and one is absurd
    fit = fit_scale(names, labels, measured)
    assert fit.source == "priors"
    assert fit.factor == pytest.approx(truth, rel=0.08)
    assert [v["inlier"] for v in fit.votes] == [True, True, True, False]


def test_user_sizes_win_then_camera_height_then_priors_then_a_1_m_camera():
    fit = fit_scale(["coin_0", "cup_1"], ["coin", "cup"], [0.5, 1.0], {"coin_0": 0.025})
    assert fit.source == "size" and fit.factor == pytest.approx(0.05)
    assert fit_scale(["cup_0"], ["cup"], [1.0], None, camera_height_m=0.4).source == "camera-height"
    assert fit_scale(["x_0"], ["gizmo"], [1.0]).source == "default"
    assert fit_scale(["x_0"], ["gizmo"], [1.0]).factor == 1.0


def test_size_options_are_checked():
    objects = [("cup_0", "cup"), ("cup_1", "cup"), ("box_2", "box")]
    assert parse_sizes(["cup=0.1"], objects) == {"cup_0": 0.1, "cup_1": 0.1}
    assert parse_sizes(["box_2=0.5"], objects) == {"box_2": 0.5}
    for bad in ("cup", "cup=abc", "cup=-1", "cup=1e9", "plate=0.2"):
        with pytest.raises(InputError, match="--size"):
            parse_sizes([bad], objects)


def test_vlm_sizes_are_parsed_with_units_and_range_checked():
    reply = json.dumps({"objects": [
        {"index": 0, "material": "rigid", "size_m": "8 cm"},
        {"index": 1, "material": "rigid", "size_m": 0.25},
        {"index": 2, "material": "rigid", "size": 5000},
        {"index": 3, "material": "rigid", "size_m": "big"}]})
    config = parse_reply(reply, 4)
    assert [o.size_m for o in config.objects] == [pytest.approx(0.08), 0.25, None, None]
    assert sum("size" in w for w in config.warnings) == 2


def _longest(report, name):
    return max(next(o for o in report["objects"] if o["name"] == name)["size_m"])


def test_build_scales_the_scene_from_the_labels_and_from_size(tmp_path, photo):
    masks = ["--mask", f"{photo['cup']}:cup", "--mask", f"{photo['box']}:box"]
    cli("build", photo["photo"], "-o", tmp_path / "a", "-q", *masks, check=True)
    report = json.loads((tmp_path / "a" / "report.json").read_text())
    scale = report["shot"]["scale"]
    assert scale["source"] == "priors" and len(scale["votes"]) == 2
    # a cup and a box of about the same size in the photo: the cup's scale (a box comes in every size), or where
    # the two read scales more than 3x apart their compromise; either way between their priors
    assert 0.11 * 0.95 < _longest(report, "cup_0") < 0.4
    assert report["shot"]["camera_height_m"] == pytest.approx(scale["camera_height_m"])

    cli("build", photo["photo"], "-o", tmp_path / "b", "-q", *masks, "--size", "cup=0.12", check=True)
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    assert report["shot"]["scale"]["source"] == "size"
    assert _longest(report, "cup_0") == pytest.approx(0.12, rel=0.01)

    proc = cli("build", photo["photo"], "-o", tmp_path / "c", "-q", *masks, "--size", "saucer=0.1")
    assert proc.returncode == 2 and "--size" in proc.stderr and "saucer" in proc.stderr
    assert not (tmp_path / "c" / "scene.usda").exists()
    assert math.isfinite(scale["factor"]) and np.isfinite(report["shot"]["camera_height_m"])


def test_a_label_made_in_every_size_votes_only_where_no_narrower_one_does():
    # a card (8.6 cm) measured 0.1 and a box measured 0.1: the card's scale, not a compromise with a carton's
    fit = fit_scale(["card_0", "box_1"], ["card", "box"], [0.1, 0.1])
    assert fit.factor == pytest.approx(0.86)
    assert fit.votes[1]["inlier"] is False and fit.votes[0]["inlier"] is True
    # boxes alone still vote
    assert fit_scale(["box_0"], ["box"], [0.1]).factor == pytest.approx(4.0)
    # ... unless the narrower one is off them by more than the disagreement factor (a failed lift): all vote
    odd = fit_scale(["card_0", "box_1", "box_2"], ["card", "box", "box"], [1.8, 0.5, 0.4])
    assert odd.factor > 2 * 0.086 / 1.8 and "broad" not in odd.votes[1]  # not the card's 0.048 alone
