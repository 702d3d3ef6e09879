"""Render-and-compare (``align.compare``): the rasteriser draws a known mesh where a camera sees it, the IoU is the
IoU, the pitch search keeps the cues' pitch unless another explains the scene clearly better, and on a
synthetic scene (meshes of known size standing on the ground, masks drawn through a known camera, a photo with
no lines to read a pitch from) the search finds the camera's pitch that the cues alone miss."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from physomni_usd.align import compare
from physomni_usd.align.photo_scene import lift_photo_scene
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.geometry.raycast import SilhouetteRenderer
from physomni_usd.settings import BuildSettings


def _hull_mask(points_uv: np.ndarray, width: int, height: int) -> np.ndarray:
    """The convex hull of projected points, drawn by pixel centres (a convex mesh's silhouette)."""
    import cv2

    hull = cv2.convexHull(points_uv.astype(np.float32)).reshape(-1, 2)
    v, u = np.mgrid[0:height, 0:width] + 0.5
    inside = np.ones((height, width), bool)
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):  # every edge keeps the hull's side
        cross = (b[0] - a[0]) * (v - a[1]) - (b[1] - a[1]) * (u - a[0])
        side = np.sign((b[0] - a[0]) * (hull.mean(0)[1] - a[1]) - (b[1] - a[1]) * (hull.mean(0)[0] - a[0]))
        inside &= cross * side >= 0
    return inside


@pytest.mark.parametrize("pitch", [15.0, 50.0, 85.0])
def test_a_box_is_drawn_where_the_camera_sees_it(pitch):
    cam = PinholeCamera(160, 120, 55.0, pitch, (0.0, 0.0, 0.5))
    box = trimesh.creation.box((0.3, 0.2, 0.15))
    box.apply_translation(cam.ground_points(70.0, 90.0) + [0, 0, 0.075])
    drawn = compare.silhouette(box.vertices, box.faces, cam)
    uv, _ = cam.project(box.vertices)
    hull = _hull_mask(uv, 160, 120)
    assert hull.sum() > 800
    assert compare.mask_iou(drawn, hull) > 0.97
    # as the ray caster the bench measures with sees it
    cast = SilhouetteRenderer([box.vertices], [box.faces]).render(cam) == 0
    assert compare.mask_iou(drawn, cast) > 0.97


def test_what_is_behind_the_camera_is_not_drawn_and_a_half_visible_mesh_is_clipped():
    cam = PinholeCamera(100, 80, 60.0, 30.0, (0.0, 0.0, 1.0))
    behind = trimesh.creation.icosphere(2, radius=0.2)
    behind.apply_translation(cam.origin - 1.0 * cam.world_from_camera[:, 2])
    assert not compare.silhouette(behind.vertices, behind.faces, cam).any()
    big = trimesh.creation.box((40.0, 40.0, 0.01))  # a floor far wider than the frame
    floor = compare.silhouette(big.vertices, big.faces, cam)
    assert floor[-1].all() and not floor[0].any()  # the floor fills the bottom rows, the sky the top
    assert compare.silhouette(big.vertices, np.zeros((0, 3), int), cam).shape == (80, 100)


def test_mask_iou():
    a = np.zeros((10, 10), bool)
    b = np.zeros((10, 10), bool)
    a[:, :5] = True
    b[:, 2:6] = True
    assert compare.mask_iou(a, b) == pytest.approx(30 / 60)
    assert compare.mask_iou(a, a) == 1.0
    assert compare.mask_iou(a, ~a) == 0.0
    assert compare.mask_iou(np.zeros((3, 3), bool), np.zeros((3, 3), bool)) == 1.0


def _valley(truth: float, depth: float = 1.0):
    """A score with its minimum at ``truth`` (and None above 80°: no scene there)."""
    def evaluate(p):
        if p > 80.0:
            return None
        return compare.SceneScore(0.05 + depth * min(abs(p - truth) / 30.0, 1.0), {"silhouette": 0.0})
    return evaluate


def test_the_search_replaces_a_cue_the_scene_contradicts_and_keeps_one_it_cannot_tell_from_others():
    found = compare.search_pitch(_valley(47.0), cue_pitch=10.0, lowest=0.0, highest=89.5)
    assert abs(found.pitch_deg - 47.0) <= 2.5
    assert found.cue_pitch_deg == 10.0 and found.as_dict()["chosen"] == "silhouettes"
    assert all(p <= 80.0 for p, _ in found.tried)  # pitches with no scene are not tried as scores
    # a landscape too flat to tell: the cues' pitch stays
    kept = compare.search_pitch(_valley(47.0, depth=0.01), cue_pitch=30.0, lowest=0.0, highest=89.5)
    assert kept.pitch_deg == 30.0 and kept.as_dict()["chosen"] == "cues"
    # a cue under the lowest pitch is read at the lowest
    assert compare.search_pitch(_valley(20.0), cue_pitch=5.0, lowest=12.0, highest=89.5).cue_pitch_deg == 12.0


def test_on_a_plateau_of_good_pitches_the_one_nearest_the_cues_is_taken():
    def plateau(p):  # every pitch from 45° up explains the scene about as well (a view from above fits any outline)
        return compare.SceneScore(0.10 - 0.01 * (p - 45.0) / 45.0 if p >= 45.0 else 0.8, {})
    found = compare.search_pitch(plateau, cue_pitch=10.0, lowest=0.0, highest=89.5)
    # the plateau's near edge, as finely as the grid finds it
    assert found.as_dict()["chosen"] == "silhouettes" and 45.0 <= found.pitch_deg < 45.0 + compare.COARSE_STEP_DEG
    # a strong cue asks for a far better scene: a third better is not enough
    def third_better(p):
        return compare.SceneScore(0.2 if p >= 30.0 else 0.3, {})
    assert compare.search_pitch(third_better, 20.0, 0.0, 40.0, gain_fraction=0.7).pitch_deg == 20.0
    assert compare.search_pitch(third_better, 20.0, 0.0, 40.0, gain_fraction=0.2).pitch_deg == 30.0


def _synthetic(pitch: float, width: int = 240, height: int = 180):
    """Two cans, a book lying flat and an apple, each its label's typical size, standing on the ground where
    the camera ``pitch`` degrees down sees them; their masks drawn through it and a plain photo."""
    cam = PinholeCamera(width, height, 50.0, pitch, (0.0, 0.0, 0.6))
    at = lambda u, v: cam.ground_points(u * width, v * height)  # noqa: E731
    can_a = trimesh.creation.cylinder(0.033, 0.12, sections=48)
    can_a.apply_translation(at(0.3, 0.62) + [0, 0, 0.06])
    can_b = trimesh.creation.cylinder(0.033, 0.12, sections=48)
    can_b.apply_translation(at(0.72, 0.8) + [0, 0, 0.06])
    book = trimesh.creation.box((0.24, 0.17, 0.03))
    book.apply_translation(at(0.62, 0.45) + [0, 0, 0.015])
    apple = trimesh.creation.icosphere(3, radius=0.04)
    apple.apply_translation(at(0.22, 0.87) + [0, 0, 0.04])
    meshes = [can_a, can_b, book, apple]
    masks = [compare.silhouette(m.vertices, m.faces, cam) for m in meshes]
    photo = np.clip(np.random.default_rng(1).normal(128, 3, (height, width, 3)), 0, 255).astype(np.uint8)
    return masks, ["can", "can", "book", "apple"], photo


@pytest.mark.parametrize("pitch", [30.0, 60.0])
def test_the_search_recovers_the_pitch_of_a_synthetic_scene_the_cues_miss(pitch, monkeypatch):
    from physomni_usd.align import cues

    # the book's corners read the pitch (test_a_lying_books_corners_read_the_pitch_the_search_would_find): left
    # out here, so that nothing in the plain photo does
    monkeypatch.setattr(cues, "rectangle_cues", lambda *a, **k: [])
    masks, labels, photo = _synthetic(pitch)
    names = [f"o{i}" for i in range(len(masks))]
    cues_only = lift_photo_scene(masks, labels, names, photo, BuildSettings(render_compare=False), {}, visible=masks)
    searched = lift_photo_scene(masks, labels, names, photo, BuildSettings(), {}, visible=masks)
    assert abs(cues_only.camera.pitch_deg - pitch) > 15.0  # nothing in a plain photo says the pitch
    assert abs(searched.camera.pitch_deg - pitch) <= 7.5
    info = searched.info["camera"]
    assert info["render_compare"]["chosen"] == "silhouettes"
    assert info["pitch_deg"] == pytest.approx(searched.camera.pitch_deg, abs=1e-3)
    assert min(info["render_compare"]["score"]["silhouette_iou"]) > 0.8


def test_a_lying_books_corners_read_the_pitch_the_search_would_find():
    # its 3 cm of thickness counted: its outline's lower corners are its bottom's, cast onto the ground as its
    # top's, they read 39.5° for 30°
    masks, labels, photo = _synthetic(30.0)
    found = lift_photo_scene(masks, labels, [f"o{i}" for i in range(len(masks))], photo,
                             BuildSettings(render_compare=False), {}, visible=masks)
    corners = [c for c in found.info["camera"]["cues"] if c["cue"] == "square corners"]
    assert len(corners) == 1 and corners[0]["label"] == "book"
    assert found.camera.pitch_deg == pytest.approx(30.0, abs=2.0)


def test_where_no_cue_reads_the_pitch_the_feet_default_has_no_reading_to_defend(monkeypatch):
    # a plain photo: only the feet's least tilt, a default; the silhouettes replace it on a smaller gain than
    # a reading of the photo needs (a scene seen from 75° kept at the feet's 10° for want of 40 %)
    from physomni_usd.align import cues as camera_cues, photo_scene

    monkeypatch.setattr(camera_cues, "rectangle_cues", lambda *a, **k: [])  # the book's corners read one
    masks, labels, photo = _synthetic(60.0)
    asked = []
    real = photo_scene.search_pitch

    def spy(*args, **kwargs):
        asked.append(kwargs["gain_fraction"])
        return real(*args, **kwargs)

    monkeypatch.setattr(photo_scene, "search_pitch", spy)
    names = [f"o{i}" for i in range(len(masks))]
    lifted = lift_photo_scene(masks, labels, names, photo, BuildSettings(), {}, visible=masks)
    cues = lifted.info["camera"]["cues"]
    assert [c["cue"] for c in cues if c.get("pitch_deg") is not None] == ["objects' feet"]
    assert asked == [photo_scene.NO_READING_GAIN_FRACTION] and asked[0] < compare.MIN_GAIN_FRACTION


def test_the_view_search_finds_pitch_and_field_of_view_together_and_keeps_the_cues_where_flat():
    def bowl(p, f):  # the scene explained best by a 60° pitch under a 35° view; none under 20° of pitch
        if p < 20.0:
            return None
        return compare.SceneScore(0.05 + min(abs(p - 60.0) / 30.0 + abs(f - 35.0) / 30.0, 1.0), {})
    found = compare.search_view(bowl, cue_pitch=30.0, cue_fov=50.0, lowest=lambda f: 0.0, highest=89.5)
    assert abs(found.pitch_deg - 60.0) <= 2.5 and abs(found.fov_deg - 35.0) <= 2.5
    assert found.as_dict()["chosen"] == "silhouettes" and all(p >= 20.0 for p, _, _ in found.tried)
    flat = compare.search_view(lambda p, f: compare.SceneScore(0.3 + 0.001 * abs(f - 40.0), {}), 30.0, 50.0,
                               lambda f: 0.0, 89.5)
    assert (flat.pitch_deg, flat.fov_deg) == (30.0, 50.0) and flat.as_dict()["chosen"] == "cues"
    # the least pitch depends on the view: a wider one sees the feet lower in its frame
    low = compare.search_view(bowl, 30.0, 50.0, lambda f: 70.0 - f / 2, 89.5)
    assert all(p >= 70.0 - f / 2 - 1e-6 for p, f, _ in low.tried)


def test_the_size_term_measures_each_object_against_its_label():
    box = trimesh.creation.box((0.4, 0.2, 0.3))  # a 'box' of its label's size and proportions (0.4 m, 0.3 m high)
    cup = trimesh.creation.cylinder(0.15, 0.05)  # a 'cup' (0.11 m, about as tall as wide) three times wider, flat
    logs, thin = compare.prior_terms([box.vertices, cup.vertices], ["box", "cup"])
    assert logs[0] == pytest.approx(0.0, abs=1e-6) and logs[1] == pytest.approx(0.0, abs=1e-6)
    assert logs[2] > 0.9 and logs[3] == pytest.approx(compare.SIZE_LOG_CAP)  # a flat cup: capped
    assert thin[0] == 0.0 and thin[1] > 0.4  # a cup is no disc: thinner than a third of its width
    # the scene's scale counts: the same box at twice the scale is log 2 off
    assert compare.prior_terms([box.vertices], ["box"], 2.0)[0][0] == pytest.approx(np.log(2.0), abs=1e-6)


def test_a_degenerate_lift_of_two_vertices_is_scored_not_crashed_on():
    # a lift that came out as two points under one candidate pitch (generated scene 733619048 at 37.5°) had two
    # principal extents, and the size term indexed a third: the pitch search ended the build
    assert compare.principal_extents(np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])) == pytest.approx([0.1, 0.0, 0.0])
    logs, thin = compare.prior_terms([np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])], ["box"])
    assert all(np.isfinite(logs)) and len(thin) == 1

def test_a_side_the_photo_did_not_give_counts_the_same_at_every_pitch():
    # a book lifted from above: its height copied from the label (0.03 m) agrees with it by construction; only its
    # footprint, three times the label's longest, is held to the label, and its proportions count as unread
    book = trimesh.creation.box((0.72, 0.4, 0.03))
    read = compare.prior_terms([book.vertices], ["book"], heights_read=[True])[0]
    copied = compare.prior_terms([book.vertices], ["book"], heights_read=[False])[0]
    assert read[0] == pytest.approx(np.log(3.0), abs=1e-6) and read[1] > 0.9
    assert copied == pytest.approx([np.log(3.0), compare.UNREAD_LOG], abs=1e-6)
    # a bottle (as tall as long) seen from above shows no side of its label's: both count as unread, whatever
    # the size the lift gave it
    for radius in (0.04, 0.2):
        bottle = trimesh.creation.cylinder(radius, 0.25)
        assert compare.prior_terms([bottle.vertices], ["bottle"], heights_read=[False])[0] == pytest.approx(
            [compare.UNREAD_LOG] * 2)
    # a copied height is no thinness: a cup three times wider than tall is thin only where its height was read
    cup = trimesh.creation.cylinder(0.15, 0.05)
    assert compare.prior_terms([cup.vertices], ["cup"], heights_read=[True])[1][0] > 0.4
    assert compare.prior_terms([cup.vertices], ["cup"], heights_read=[False])[1][0] == 0.0


def test_with_no_reading_to_keep_the_best_scoring_of_the_near_best_pitches_is_taken():
    def flat(p):  # about as good from 20 to 40 degrees, best at 33; the feet's default 10 far worse
        return compare.SceneScore(0.10 + 0.0004 * abs(p - 33.0) if 20.0 <= p <= 40.0 else 0.5, {})
    nearest = compare.search_pitch(flat, cue_pitch=10.0, lowest=0.0, highest=89.5, gain_fraction=0.0)
    best = compare.search_pitch(flat, cue_pitch=10.0, lowest=0.0, highest=89.5, gain_fraction=0.0, pick="best")
    assert nearest.pitch_deg == pytest.approx(20.0)
    assert abs(best.pitch_deg - 33.0) <= 2.5 and best.cue_pitch_deg == 10.0


def _leaning(truth: float, lean: float = 0.0):
    """A valley at ``truth`` whose far side falls again towards 89.5° by ``lean`` (a view from straight above
    fits any outline)."""
    def evaluate(p):
        return compare.SceneScore(0.1 + min(abs(p - truth) / 30.0, 0.4) - lean * max(p - 60.0, 0.0) / 29.5, {})
    return evaluate


def test_a_light_reading_loses_to_a_far_shallower_pitch_but_a_steeper_one_does_not_move_it():
    # a window about the cue alone never sees the shallow valley; the trust check scores the whole range
    confined = compare.search_pitch(_leaning(5.0), 84.0, 0.0, 89.5, gain_fraction=0.7, window_deg=20.0)
    assert confined.pitch_deg >= 64.0
    found = compare.search_pitch(_leaning(5.0), 84.0, 0.0, 89.5, gain_fraction=0.7, window_deg=20.0,
                                 trust_deg=20.0)
    assert abs(found.pitch_deg - 5.0) <= 2.5 and found.as_dict()["chosen"] == "silhouettes"
    assert any(p < 30.0 for p, _ in found.tried) and any(p > 85.0 for p, _ in found.tried)
    # the silhouettes' lean to straight down is no reason to drop a reading read shallower than it
    kept = compare.search_pitch(_leaning(20.0, lean=0.5), 20.0, 0.0, 89.5, gain_fraction=0.7, window_deg=20.0,
                                trust_deg=20.0)
    assert kept.pitch_deg == 20.0 and kept.as_dict()["chosen"] == "cues"


def test_a_reading_too_light_to_count_chooses_among_the_pitches_as_good_as_the_best():
    def plateau(p):  # 45° and up about equally good; the feet's 10° far worse
        return compare.SceneScore(0.10 + 0.005 * abs(p - 50.0) / 40.0 if p >= 45.0 else 0.8, {})
    plain = compare.search_pitch(plateau, cue_pitch=10.0, lowest=0.0, highest=89.5)
    assert plain.pitch_deg == pytest.approx(45.0)
    anchored = compare.search_pitch(plateau, cue_pitch=10.0, lowest=0.0, highest=89.5, anchor=84.0)
    assert anchored.pitch_deg == pytest.approx(84.0) and anchored.cue_pitch_deg == 10.0
    # where the anchor scores no better than the cue, the cue stays
    flat = compare.search_pitch(lambda p: compare.SceneScore(0.3, {}), cue_pitch=10.0, lowest=0.0, highest=89.5,
                                anchor=84.0)
    assert flat.pitch_deg == 10.0


def test_the_field_of_view_is_weighed_along_the_row_a_vanishing_point_fixes():
    from physomni_usd.align.cues import Cue, row_pitch
    horizon = Cue("horizon vanishing points", 30.0, 1.5, detail={"row": -40.0})
    # a wider view pitched more puts the horizon on the same row
    assert row_pitch(horizon, 70.0, 240) > row_pitch(horizon, 50.0, 240) > row_pitch(horizon, 30.0, 240)
    assert row_pitch(Cue("ellipse", 30.0, 1.0), 50.0, 240) is None

    def scene(p, f):  # the scene explains the photo best under a 30° view
        return compare.SceneScore(0.05 + abs(f - 30.0) / 100.0, {})
    along = compare.search_row(scene, lambda f: row_pitch(horizon, f, 240), 50.0, lambda f: 0.0)
    assert along.fov_deg == 30.0 and along.pitch_deg == pytest.approx(row_pitch(horizon, 30.0, 240), abs=1e-3)
    assert along.cue_fov_deg == 50.0 and along.as_dict()["chosen"] == "silhouettes"
    # a flat landscape keeps the default; a view under which a foot stands above the horizon is no camera
    flat = compare.search_row(lambda p, f: compare.SceneScore(0.2, {}), lambda f: row_pitch(horizon, f, 240), 50.0,
                              lambda f: 0.0)
    assert flat.fov_deg == 50.0 and flat.as_dict()["chosen"] == "cues"
    feet = compare.search_row(scene, lambda f: row_pitch(horizon, f, 240), 50.0,
                              lambda f: 0.0 if f >= 45.0 else 90.0)
    assert feet.fov_deg >= 45.0 and all(f >= 45.0 for _, f, _ in feet.tried)


def test_where_the_row_search_moves_the_field_of_view_the_report_gives_the_pitch_built(monkeypatch):
    # along a vanishing row the pitch moves with the field of view: the report's pitch is the camera's, not the
    # one the row meant under the default view (a scene built at 27° was reported at 42°)
    from dataclasses import replace

    from physomni_usd.align import photo_scene
    from physomni_usd.align.cues import Cue, focal_px, row_pitch

    masks, labels, photo = _synthetic(30.0)
    h = photo.shape[0]
    horizon = Cue("horizon vanishing points", 30.0, 1.5,
                  detail={"row": 0.5 * h - focal_px(50.0, h) * np.tan(np.radians(30.0))})
    real_estimate = photo_scene.estimate_camera

    def estimate(*args, **kwargs):  # the plain photo given a strong vanishing row, read under the default view
        est = real_estimate(*args, **kwargs)
        return replace(est, pitch_deg=30.0, cues=[horizon, *est.cues], pitch_source="horizon vanishing points")

    def along(evaluate, pitch_of, cue_fov, lowest, *args, **kwargs):  # the silhouettes prefer a 35° view
        p = round(float(pitch_of(35.0)), 3)
        score = evaluate(p, 35.0)
        return compare.ViewSearch(p, 35.0, round(float(pitch_of(cue_fov)), 3), cue_fov, score, score, [])

    monkeypatch.setattr(photo_scene, "estimate_camera", estimate)
    monkeypatch.setattr(photo_scene, "search_row", along)
    names = [f"o{i}" for i in range(len(masks))]
    lifted = lift_photo_scene(masks, labels, names, photo, BuildSettings(), {}, visible=masks)
    info = lifted.info["camera"]
    assert info["fov_deg"] == pytest.approx(35.0) and lifted.camera.fov_deg == pytest.approx(35.0)
    assert row_pitch(horizon, 35.0, h) < 25.0  # the row means a shallower pitch under the narrower view
    assert info["pitch_deg"] == pytest.approx(lifted.camera.pitch_deg, abs=1e-3)
    # and the least pitch that stands every foot on the ground is the built view's too
    assert info["min_pitch_deg"] == pytest.approx(photo_scene.min_pitch(35.0, h, photo_scene._feet(masks)), abs=1e-3)
