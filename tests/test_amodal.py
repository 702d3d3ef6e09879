"""Occlusion order and amodal completion from visible masks: a cup standing on its saucer hides the saucer's
middle; the saucer is completed behind it, outline and colour, from its own visible pixels."""

from __future__ import annotations

import cv2
import numpy as np

from physomni_usd.perceive.amodal import complete, occlusion_order
from physomni_usd.texture.hidden import complete_texture

H, W = 160, 220


def _cup_on_saucer():
    saucer = np.zeros((H, W), np.uint8)
    cv2.ellipse(saucer, (110, 110), (80, 24), 0, 0, 360, 1, -1)
    cup = np.zeros((H, W), np.uint8)
    cv2.rectangle(cup, (80, 40), (140, 112), 1, -1)
    cv2.ellipse(cup, (110, 112), (30, 8), 0, 0, 360, 1, -1)
    whole = saucer > 0
    cup = cup > 0
    return whole & ~cup, cup, whole


def test_the_cup_hides_the_saucer_and_side_by_side_objects_hide_nothing():
    saucer, cup, _ = _cup_on_saucer()
    assert occlusion_order([saucer, cup]) == [(1, 0)]
    left = np.zeros((H, W), bool)
    left[40:120, 20:100] = True
    right = np.zeros((H, W), bool)
    right[50:120, 100:180] = True
    assert occlusion_order([left, right]) == []


def test_the_saucer_is_completed_behind_the_cup_as_an_ellipse():
    saucer, cup, whole = _cup_on_saucer()
    done = complete([saucer, cup])
    assert done[0].occluders == [1] and done[0].how == "ellipse"
    iou = (done[0].amodal & whole).sum() / (done[0].amodal | whole).sum()
    assert iou > 0.97
    assert not (done[0].amodal & ~(saucer | cup)).any()  # only behind the cup, never over the background
    assert done[1].how == "whole" and (done[1].amodal == cup).all()
    assert done[0].hidden_pixels(saucer) == int((done[0].amodal & ~saucer).sum()) > 0.9 * (whole & cup).sum()


def test_the_hidden_part_takes_the_saucers_colour_not_the_cups():
    saucer, cup, _ = _cup_on_saucer()
    photo = np.full((H, W, 3), 90, np.uint8)
    photo[saucer] = (230, 230, 210)
    photo[cup] = (200, 40, 40)
    done = complete([saucer, cup])
    painted = complete_texture(photo, saucer, done[0].amodal)
    hidden = done[0].amodal & ~saucer
    assert np.abs(painted[hidden].astype(int) - (230, 230, 210)).max() <= 2
    assert (painted[~hidden] == photo[~hidden]).all()


def test_the_hulls_points_give_the_hull_of_every_pixel():
    """The convex hull is taken over the mask's outer contours' corners (fast), not its every pixel: same hull,
    scattered parts, holes and single pixels included."""
    import cv2

    from physomni_usd.perceive.amodal import hull_points

    rng = np.random.default_rng(1)
    for _ in range(50):
        m = cv2.GaussianBlur(rng.random((60, 80)).astype(np.float32), (0, 0), 2) > 0.52
        m[rng.integers(60), rng.integers(80)] = True  # a lone pixel, wherever it falls
        every, corners = np.zeros(m.shape, np.uint8), np.zeros(m.shape, np.uint8)
        cv2.fillConvexPoly(every, cv2.convexHull(cv2.findNonZero(m.astype(np.uint8))), 1)
        cv2.fillConvexPoly(corners, cv2.convexHull(hull_points(m)), 1)
        assert np.array_equal(every, corners)
    assert hull_points(np.zeros((5, 5), bool)) is None


def test_a_sliver_seen_between_the_fruit_in_front_of_it_is_hidden_by_them_and_hides_none():
    # a fruit behind three others shows only a sliver between them: their closures take in a rim of its pixels
    # along their round outlines, a few hundredths of so small a mask, which hid the order (issue 38, part 3)
    def disc(c, r):
        m = np.zeros((240, 320), np.uint8)
        cv2.circle(m, c, r, 1, -1)
        return m > 0

    front = [disc((185, 180), 23), disc((228, 175), 23), disc((203, 137), 23)]
    sliver = disc((196, 150), 21) & ~np.logical_or.reduce(front)
    order = occlusion_order(front + [sliver])
    assert sliver.sum() < 0.2 * front[0].sum()
    assert {(0, 3), (2, 3)} <= set(order), order
    assert not [pair for pair in order if pair[0] == 3], order


def test_a_stick_two_pixels_wide_across_a_box_hides_it():
    # every pixel of so thin an occluder lies within a pixel of the box's outline on both sides: none is left
    # beyond that row, and the order must fall back on the raw reach of the box's closure
    box = np.zeros((240, 320), bool)
    box[80:160, 100:220] = True
    stick = np.zeros_like(box)
    stick[119:121, 60:260] = True
    box &= ~stick
    assert occlusion_order([stick, box]) == [(0, 1)]
    assert occlusion_order([box, stick]) == [(1, 0)]
