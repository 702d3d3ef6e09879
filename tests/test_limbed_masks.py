"""Masks a person would accept from a box: a thing with legs leaves out the ground between them, lit or in its
own shadow; a mask that is likely wrong (ground-coloured, or a round outline with holes) says so, naming the
object and the fix."""

from __future__ import annotations

import cv2
import numpy as np

from physomni_usd.perceive.masks import box_spec, is_limbed, mask_from_box, mask_quality

from .conftest import cli

H, W = 240, 200
BOX = (48, 30, 152, 226)
GAP = (slice(150, 210), slice(95, 105))  # grass between the legs


def player(shirt=(200, 40, 40), legs=(30, 30, 120), shadow=0.55):
    """A standing figure, legs apart, on grass, with its shadow under and between its legs: (photo, truth)."""
    rng = np.random.default_rng(0)
    img = np.zeros((H, W, 3), np.float32)
    img[:90] = (150, 180, 220)
    img[90:] = (60, 130, 50)
    img += rng.normal(0, 3, (H, W, 1))
    body = np.zeros((H, W), np.uint8)
    cv2.circle(body, (100, 50), 14, 1, -1)
    cv2.rectangle(body, (80, 64), (120, 130), 1, -1)
    cv2.line(body, (84, 130), (66, 215), 1, 12)
    cv2.line(body, (116, 130), (134, 215), 1, 12)
    cv2.line(body, (80, 70), (58, 120), 1, 9)
    cv2.line(body, (120, 70), (142, 120), 1, 9)
    truth = body > 0
    under = np.zeros((H, W), np.uint8)
    cv2.ellipse(under, (100, 200), (45, 30), 0, 0, 360, 1, -1)
    img[(under > 0) & ~truth] *= shadow
    img[truth] = shirt
    lower = truth.copy()
    lower[:130] = False
    img[lower] = legs
    img[truth] += rng.normal(0, 3, (int(truth.sum()), 1))
    return np.clip(img, 0, 255).astype(np.uint8), truth


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


def test_a_player_s_box_leaves_out_the_grass_between_the_legs():
    photo, truth = player()
    got = mask_from_box(photo, box_spec(BOX, "football player"), 0)
    assert got.mask[GAP].sum() == 0 and _iou(got.mask, truth) > 0.97, got.quality
    assert got.quality["warning"] is None
    # the same box for a thing without limbs keeps GrabCut's cut, shadow and all: the label decides
    plain = mask_from_box(photo, box_spec(BOX, "statue"), 0)
    assert plain.mask[GAP].sum() > 0.5 * truth[GAP].size
    assert is_limbed("players") and is_limbed("Dog_2") and not is_limbed("ball") and not is_limbed(None)


def test_a_limbed_mask_that_stays_ground_coloured_names_the_click_off():
    # the figure dressed in the ground's own colour, in shade: nothing can be told apart, so it is said
    photo, _ = player(shirt=(33, 72, 28), legs=(33, 72, 28))
    got = mask_from_box(photo, box_spec(BOX, "dog"), 0)
    warning = got.quality["warning"] or ""
    assert "colour of the ground" in warning and "click off" in warning and "--mask" in warning, got.quality


def test_a_round_outline_with_holes_warns_and_names_the_object(tmp_path):
    disk = np.zeros((160, 200), np.uint8)
    cv2.circle(disk, (100, 80), 32, 1, -1)
    holed = disk.copy()
    for a in np.linspace(0, 2 * np.pi, 6)[:-1]:  # a ball's dark panels at its rim, left out
        cv2.circle(holed, (int(100 + 24 * np.cos(a)), int(80 + 24 * np.sin(a))), 8, 0, -1)
    photo = np.full((160, 200, 3), 120, np.uint8)
    photo[disk > 0] = 230
    photo[(disk > 0) & (holed == 0)] = 20
    assert mask_quality(photo, disk > 0)["warning"] is None
    assert "holes or bites" in mask_quality(photo, holed > 0)["warning"]
    square = np.zeros_like(disk)
    square[40:120, 60:140] = 1
    square[70:90, 60:80] = 0  # a notch in a square: not round, not this warning
    assert "holes" not in (mask_quality(photo, square > 0)["warning"] or "")
    cv2.imwrite(str(tmp_path / "photo.png"), photo)
    cv2.imwrite(str(tmp_path / "ball.png"), holed * 255)
    proc = cli("build", tmp_path / "photo.png", "-o", tmp_path / "shot", "--mask", f"{tmp_path / 'ball.png'}:ball")
    said = [ln for ln in proc.stderr.splitlines() if ln.startswith("warning: mask of ball_0")]
    assert len(said) == 1 and "click on the missing parts" in said[0], proc.stderr
