"""A mask's warnings are for a box or clicks gone wrong, not for an object hidden in part by another: exact masks
of a ball behind a cup and of a box behind a box of the same card get none once the other masks are known
(``qualify_among``), and the same masks with nothing in front to explain them keep theirs."""

from __future__ import annotations

import json

import cv2
import numpy as np

from physomni_usd.perceive.masks import ObjectMask, mask_quality, qualify_among


def _table():
    """A 240×320 grey-green table, lit from the left, with fine grain."""
    rng = np.random.default_rng(2)
    y, x = np.mgrid[:240, :320].astype(np.float32)
    light = 1.0 - 0.001 * x
    img = np.stack([150 * light, 160 * light, 140 * light], -1) + rng.normal(0, 3, (240, 320, 1))
    return img


def _file_object(photo, mask, index, label):
    o = ObjectMask(label, index, mask, f"file:{label}.png")
    o.quality = dict(mask_quality(photo, mask), method="file")
    return o


def _ball_behind_a_cup(cup_in_front: bool):
    """A red ball (a disc of radius 40) and, when ``cup_in_front``, a white cup over its right third, the ball's
    mask its visible part; else the cup stands beside it and the ball's mask has the same bite where the ball
    shows (the part a box's cut missed)."""
    img = _table()
    y, x = np.mgrid[:240, :320]
    ball = (x - 120) ** 2 + (y - 120) ** 2 < 40 ** 2
    cup = np.zeros((240, 320), bool)
    if cup_in_front:
        cup[90:180, 135:200] = True
    else:
        cup[90:180, 235:300] = True
    bite = np.zeros((240, 320), bool)
    bite[90:180, 135:200] = True
    img[ball & ~(cup if cup_in_front else np.zeros_like(cup))] = (200, 40, 40)
    img[cup] = (235, 235, 230)
    photo = np.clip(img, 0, 255).astype(np.uint8)
    return photo, ball & ~bite, cup


def test_a_ball_hidden_in_part_by_a_cup_in_front_gets_no_warning_and_a_bitten_ball_keeps_its_own():
    for in_front in (True, False):
        photo, ball, cup = _ball_behind_a_cup(in_front)
        objects = [_file_object(photo, ball, 0, "ball"), _file_object(photo, cup, 1, "cup")]
        alone = objects[0].quality
        assert alone["round_missing"] > 0.06 and "round" in alone["warning"], alone  # a bite, the cup unknown
        qualify_among(photo, objects)
        if in_front:
            assert objects[0].quality["warning"] is None, objects[0].quality
            assert objects[0].quality["round_missing"] < 0.06
        else:  # the ball shows where its mask is bitten: nothing in front explains the bite
            assert objects[0].quality["warning"] == alone["warning"], objects[0].quality


def _box_behind_a_box(other_in_front: bool):
    """Two boxes of the same brown card; the back one's mask is its visible L (the front box covers its lower
    right), or, without the front box, the same L drawn over the table (the front box's place shows table)."""
    img = _table()
    back = np.zeros((240, 320), bool)
    back[60:160, 80:200] = True
    front = np.zeros((240, 320), bool)
    front[110:200, 140:260] = True
    rng = np.random.default_rng(3)
    card = np.float32([170, 130, 90]) + rng.normal(0, 4, (240, 320, 1))
    seen = back & ~front
    img[seen] = card[seen]
    if other_in_front:
        img[front] = card[front] * 0.97
    photo = np.clip(img, 0, 255).astype(np.uint8)
    return photo, seen, front


def test_a_box_behind_a_box_of_the_same_card_does_not_look_like_background():
    photo, back, front = _box_behind_a_box(True)
    objects = [_file_object(photo, back, 0, "box"), _file_object(photo, front, 1, "box")]
    alone = objects[0].quality
    assert alone["background_like"] > 0.25 and "background" in alone["warning"], alone  # the front box's card
    qualify_among(photo, objects)
    assert objects[0].quality["warning"] is None and objects[0].quality["background_like"] < 0.1, objects[0].quality


def test_a_mask_of_the_tables_colour_still_looks_like_background_beside_other_objects():
    photo, back, front = _box_behind_a_box(True)
    table = np.zeros(back.shape, bool)
    table[20:50, 200:300] = True  # a patch of table, masked as if it were an object
    objects = [_file_object(photo, table, 0, "card"), _file_object(photo, back, 1, "box"),
               _file_object(photo, front, 2, "box")]
    warning = objects[0].quality["warning"]
    assert warning and "background" in warning
    qualify_among(photo, objects)
    assert objects[0].quality["warning"] == warning


def test_build_names_no_warning_for_a_ball_behind_a_cup(tmp_path):
    from tests.conftest import cli

    photo, ball, cup = _ball_behind_a_cup(True)
    cv2.imwrite(str(tmp_path / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    for name, m in (("ball", ball), ("cup", cup)):
        cv2.imwrite(str(tmp_path / f"{name}.png"), m.astype(np.uint8) * 255)
    proc = cli("build", tmp_path / "photo.png", "-o", tmp_path / "shot", "--mask", f"{tmp_path / 'ball.png'}:ball",
               "--mask", f"{tmp_path / 'cup.png'}:cup")
    assert proc.returncode == 0, proc.stderr
    assert "warning: mask of ball_0" not in proc.stderr, proc.stderr
    report = json.loads((tmp_path / "shot" / "report.json").read_text())
    assert report["objects"][0]["mask_quality"]["warning"] is None
    assert report["objects"][0]["mask_quality"]["round_missing"] < 0.06
