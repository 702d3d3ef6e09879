"""The plate's fill against a known background: the blend fill holds to what surrounds the hole, leaves no
unfilled (blue) pixel, and on a surface whose truth is known errs less than Telea and the exemplar; the bench's measures
(distance to the surroundings' colours, the colour cap) count what they say."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from physomni_usd.bench.fill_truth import FAR_LEVELS, fill_rows, holds, surroundings_distance
from physomni_usd.texture.blend import COLOUR_CAP, cap_colours
from physomni_usd.texture.fill import background_plate, plate_hole


def _floor_and_photo():
    """A tiled floor in perspective-free squares of two greens with mortar, grain on it (the truth), and the
    photo: a red box standing on it (the object, masked) with a yellow bottle beside it (not masked)."""
    rng = np.random.default_rng(5)
    h, w = 180, 240
    y, x = np.mgrid[:h, :w]
    tile = ((y // 24 + x // 24) % 2)[..., None]
    floor = np.where(tile, [96.0, 150.0, 90.0], [150.0, 190.0, 140.0])
    floor[(y % 24 < 2) | (x % 24 < 2)] = (60.0, 60.0, 60.0)
    floor = np.clip(floor + rng.normal(0, 4, (h, w, 1)), 0, 255).astype(np.uint8)
    photo = floor.copy()
    box = np.zeros((h, w), bool)
    box[50:130, 90:150] = True
    photo[box] = (200, 40, 40)
    photo[60:110, 160:172] = (230, 210, 30)  # the bottle: in the photo, beside the hole, never the surface
    return photo, floor, box


def test_the_blend_fill_errs_least_and_brings_no_colour_the_surroundings_lack():
    photo, truth, box = _floor_and_photo()
    row = fill_rows(photo, truth, [box], 0.01)
    m = row["methods"]
    # measured 14.1 against Telea's 37.9 and the exemplar's 15.1 (whose copies of the bottle the blend leaves out)
    assert m["blend"]["error"] <= min(m["telea"]["error"], m["exemplar"]["error"])
    assert m["blend"]["far"] == 0 and m["blend"]["far_max"] <= FAR_LEVELS
    plate = row["plates"]["blend"]
    hole = plate_hole(photo, [box], 0.01)
    assert np.array_equal(plate[~hole], photo[~hole])  # the photo, pixel for pixel, outside the hole


def _lit_wall_and_sand():
    """A wall lit from one side (a smooth falloff, fine grain) over a floor of sand ripples, a box standing across
    the line where they meet (the object, masked) and a blue cup on the floor beside it (not masked): the truth
    and the photo."""
    rng = np.random.default_rng(11)
    h, w = 160, 220
    y, x = np.mgrid[:h, :w].astype(np.float32)
    wall = (200.0 - 0.45 * x)[..., None] * np.float32([1.0, 0.93, 0.85])
    ripple = 150.0 + 14.0 * np.sin(x / 6.0 + 4.0 * np.sin(y / 23.0))
    sand = ripple[..., None] * np.float32([1.0, 0.86, 0.62])
    truth = np.where((y < 70)[..., None], wall, sand) + rng.normal(0, 3, (h, w, 1))
    truth = np.clip(truth, 0, 255).astype(np.uint8)
    photo = truth.copy()
    box = np.zeros((h, w), bool)
    box[40:120, 70:130] = True
    photo[box] = (90, 40, 30)
    photo[95:125, 145:160] = (40, 60, 210)
    return photo, truth, box


@pytest.mark.parametrize("scene", [_floor_and_photo, _lit_wall_and_sand])
def test_the_default_fill_keeps_to_the_colours_around_the_hole(scene):
    """No revealed pixel of the plate's default fill lies farther than 60 levels from every colour around the
    hole (the cap holds it to 55, after the seam), though a box of another colour stood there and a bottle or a
    cup of a third stands beside it."""
    photo, truth, box = scene()
    row = fill_rows(photo, truth, [box], 0.01, ("faded",))
    assert row["methods"]["faded"]["far"] == 0 and row["methods"]["faded"]["far_max"] <= FAR_LEVELS


@pytest.mark.xfail(strict=True, reason="open: on these two scenes the faded fill errs more than the better of Telea "
                   "and the blend (tiles copied in step: 18.9 against the blend's 14.1; a lit wall over sand "
                   "ripples: 9.1 against Telea's 7.6); on generated scenes it holds in 18 of 32 (seeds 51, 52, 61, 62)")
@pytest.mark.parametrize("scene", [_floor_and_photo, _lit_wall_and_sand])
def test_the_default_fill_errs_at_most_as_much_as_telea_and_the_blend(scene):
    """The acceptance of the plate's fill on two made-up scenes whose truth is known: in the revealed area its
    error is at most the better of Telea's and the blend's, and no revealed pixel is of a foreign colour."""
    photo, truth, box = scene()
    row = fill_rows(photo, truth, [box], 0.01, ("faded", "telea", "blend"))
    m = row["methods"]
    # the case is real: one of the fills it is held to errs clearly more than the other
    assert abs(m["telea"]["error"] - m["blend"]["error"]) > 1.0, m
    assert holds(row), m


def test_the_acceptance_counts_a_larger_error_and_a_foreign_colour():
    row = {"methods": {"faded": {"error": 5.0, "far": 0}, "telea": {"error": 5.0, "far": 3},
                       "blend": {"error": 6.0, "far": 0}}}
    assert holds(row)  # as good as the better one; Telea's own far pixels are not the default fill's
    row["methods"]["faded"]["error"] = 5.01
    assert not holds(row)
    row["methods"]["faded"] |= {"error": 4.0, "far": 1}
    assert not holds(row)


def test_no_pixel_is_left_unfilled_where_shift_map_gives_up():
    """A hole that covers most of a small photo: shift-map leaves some of its reduced pixels unfilled (zero in
    CIELAB, which shows as a pure blue); the blend fill leaves none of that colour in a photo that has none."""
    photo, _, _ = _floor_and_photo()
    hole = np.zeros(photo.shape[:2], bool)
    hole[20:170, 10:230] = True
    blue = lambda p: (p[..., 2].astype(int) - np.maximum(p[..., 0], p[..., 1]) > 60).sum()  # noqa: E731
    assert blue(photo) == 0
    assert blue(background_plate(photo, [hole], 0.0, method="exemplar")) > 500  # measured 2452: the case is real
    assert blue(background_plate(photo, [hole], 0.0)) == 0


def test_a_hole_on_a_lit_panel_is_filled_from_the_panel_not_the_dark_room_around_it():
    """Five dark bars on a lit panel in a dark room: the hole covers most of the panel, and a window as wide as a
    quarter of it takes in the room. The fill is the panel's colour, not a grey smear of the room (before the
    copies' colours and the smooth fill were taken from the hole's border: error 94 levels, 7,784 of the 14,400
    revealed pixels darker than 160; after, 3.8 and none)."""
    rng = np.random.default_rng(3)
    h, w = 200, 260
    y, x = np.mgrid[:h, :w]
    truth = np.full((h, w, 3), (14.0, 18.0, 15.0))
    truth[(y // 9 + x // 13) % 5 == 0] = (40.0, 44.0, 40.0)
    truth[(y >= 12) & (y < 188) & (x >= 20) & (x < 240)] = (222.0, 240.0, 226.0)
    truth = np.clip(truth + rng.normal(0, 3, (h, w, 1)), 0, 255).astype(np.uint8)
    photo, masks = truth.copy(), []
    for k in range(5):
        m = np.zeros((h, w), bool)
        m[30 + 30 * k: 46 + 30 * k, 40:220] = True
        photo[m] = (10, 12, 10)
        masks.append(m)
    plate = background_plate(photo, masks, 0.015)
    revealed = np.any(masks, axis=0)
    assert np.abs(plate.astype(np.float32) - truth)[revealed].mean() < 10.0
    assert (plate[revealed].mean(-1) < 160).sum() == 0


def test_the_distance_to_the_surroundings_counts_a_foreign_colour():
    img = np.full((60, 80, 3), 120, np.uint8)
    hole = np.zeros((60, 80), bool)
    hole[20:40, 30:50] = True
    img[20:30, 30:50] = (120, 120, 200)  # 80 levels from the grey around it
    d = surroundings_distance(img, hole)
    assert d[~hole].max() == 0
    assert np.allclose(d[20:30, 30:50], 80.0) and np.allclose(d[30:40, 30:50], 0.0)
    capped = cap_colours(img, img, hole)
    assert surroundings_distance(capped, hole).max() <= COLOUR_CAP + 1.0  # rounded to whole levels
    assert np.array_equal(capped[30:40], img[30:40])  # what the surroundings hold is left as it is


def test_a_generated_scene_rendered_without_its_objects_scores_the_fill(tmp_path):
    """One scene of ``bench general`` rendered with and without its objects (needs Blender's Python)."""
    from physomni_usd.bench.fill_truth import bench_fill_truth
    from physomni_usd.bench.general import NoBlender, blender_python

    try:
        blender_python()
    except NoBlender as exc:
        pytest.skip(str(exc))
    numbers = bench_fill_truth(1, 3, tmp_path, echo=lambda m: None)
    row = numbers["rows"][0]
    empty = cv2.imread(str(tmp_path / "scene_000" / "empty" / "photo.png"))
    assert empty is not None and row["revealed_px"] > 0
    assert row["floor"] < 15  # the two renders agree where nothing was taken out
    for m in ("faded", "exemplar", "telea", "blend"):
        assert 0 < row["methods"][m]["error"] < 80
    assert row["methods"]["faded"]["far"] == 0 and row["methods"]["blend"]["far"] == 0


def test_a_copy_is_trusted_where_its_shift_maps_the_surface_onto_itself():
    """Stripes 16 px apart with a hole in them: a copy shifted by a whole period continues them in step and is
    trusted; one shifted by half a period puts dark stripes where light ones are and is not."""
    from physomni_usd.texture.blend import shift_trust

    rng = np.random.default_rng(3)
    h, w = 120, 160
    x = np.mgrid[:h, :w][1].astype(np.float32)
    stripes = 128.0 + 60.0 * np.sin(2 * np.pi * x / 16.0)
    src = np.repeat(stripes[..., None], 3, -1) + rng.normal(0, 2, (h, w, 1)).astype(np.float32)
    known = np.ones((h, w), bool)
    known[40:80, 60:100] = False
    chose = (~known).astype(np.float32)
    in_step = shift_trust(src, known, chose, 0, 48, 40)
    out_of_step = shift_trust(src, known, chose, 0, 56, 40)
    assert in_step > 0.9 and out_of_step < 0.3, (in_step, out_of_step)  # 1.00 and 0.19
