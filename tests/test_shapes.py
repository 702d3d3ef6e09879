"""Shapes per label: inflated organic things, cuboids for boxes, thin plates from above; all closed."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from physomni_usd.bench.photos import make_known_scene
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.lift.silhouette import lift_silhouette
from physomni_usd.sizes import body_kind, size_prior

from .conftest import ball_seen_low


def _blob(tilt_deg: float = 0.0) -> np.ndarray:
    """A lopsided outline (a body and a head), not mirror-symmetric: no surface of revolution fits it. With
    ``tilt_deg`` the body's far end dips below the rest, so the body touches the ground only out there."""
    m = np.zeros((240, 320), np.uint8)
    cv2.ellipse(m, (160, 170), (60, 25), tilt_deg, 0, 360, 1, -1)
    cv2.circle(m, (110, 160), 18, 1, -1)
    return m > 0


def _closed(lifted) -> trimesh.Trimesh:
    mesh = trimesh.Trimesh(lifted.vertices, lifted.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    return mesh


def _silhouette(camera, mesh) -> np.ndarray:
    uv, _ = camera.project(mesh.vertices)
    out = np.zeros((camera.height, camera.width), np.uint8)
    for tri in mesh.faces:
        cv2.fillPoly(out, [np.round(uv[tri] * 16).astype(np.int32)], 1, shift=4)
    return out > 0


def test_an_inflated_body_rests_on_a_flat_patch_or_is_the_slab():
    """The photo shows it at rest: its weight must fall over what touches the ground, or it would roll away."""
    from physomni_usd.lift.silhouette import stands

    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    level = lift_silhouette(_blob(), camera, label="lime")
    assert level.shape == "inflated" and stands(level.vertices, level.faces)
    z = level.vertices[:, 2]
    touching = level.vertices[z <= z.min() + 1e-9]
    assert np.ptp(touching[:, 0]) > 0.2 * np.ptp(level.vertices[:, 0])  # a patch, not a point
    tipped = lift_silhouette(_blob(10.0), camera, label="lime")  # its low end is far from its weight
    assert tipped.shape == "extrude"  # the slab, as such outlines were lifted before there were soft bodies


def test_labels_choose_the_body():
    assert body_kind("lime") == "organic" and body_kind("rubber_whale") == "organic" and body_kind("bag") == "organic"
    assert body_kind("book") == "boxy" and body_kind("cookie box") == "boxy"
    assert body_kind("toy box") == "organic"  # a toy word wins: a toy is rounded
    assert body_kind("cup") is None and body_kind("gizmo") is None


@pytest.mark.parametrize("label", ["lime", "rubber whale", "bag"])
def test_organic_outlines_inflate_into_a_solid_deeper_than_a_slab_that_still_matches_the_photo(label):
    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    mask = _blob()
    inflated = lift_silhouette(mask, camera, label=label)
    slab = lift_silhouette(mask, camera)
    assert (inflated.shape, slab.shape) == ("inflated", "extrude")
    mesh = _closed(inflated)
    _closed(slab)
    # across the camera's view the inflated body is about as deep as the outline is high; the slab is not
    depth = lambda m: float(np.ptp(m.vertices[:, 1]))  # noqa: E731 (the camera looks along +y)
    assert depth(inflated) > 1.5 * depth(slab)
    assert depth(inflated) > 0.6 * inflated.height
    seen = _silhouette(camera, mesh)
    assert (seen & mask).sum() / (seen | mask).sum() >= 0.85
    assert inflated.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)


def test_a_box_whose_top_shows_becomes_a_cuboid_of_its_faces():
    scene = make_known_scene(20.0)
    i = scene.labels.index("box")
    prior = size_prior("box")
    lifted = lift_silhouette(scene.masks[i], scene.camera, height_hint=prior.height_m, prior_shape=prior.shape,
                             photo=scene.photo, label="box")
    assert lifted.shape == "cuboid"
    _closed(lifted)
    truth = scene.meshes[i].extents
    extent = np.ptp(lifted.vertices, axis=0)
    assert extent[2] == pytest.approx(truth[2], rel=0.15)  # height from the edge of its top
    assert extent[1] == pytest.approx(truth[1], rel=0.25)  # depth from the top's far edge (the box is turned)
    # the slab the same outline gave before is a third as deep
    slab = lift_silhouette(scene.masks[i], scene.camera, height_hint=prior.height_m, prior_shape=prior.shape,
                           photo=scene.photo)
    assert slab.shape == "extrude" and np.ptp(slab.vertices[:, 1]) < 0.6 * extent[1]


def test_seen_from_above_flat_parts_are_thin_plates_and_organic_things_domes():
    camera = PinholeCamera(320, 240, 50.0, 85.0, (0.0, 0.0, 0.5))
    mask = np.zeros((240, 320), np.uint8)
    cv2.fillPoly(mask, [np.array([[100, 80], [200, 80], [200, 110], [140, 110], [140, 170], [100, 170]])], 1)
    part = size_prior("part")
    plate = lift_silhouette(mask > 0, camera, height_hint=part.height_m, prior_shape=part.shape, flat=True,
                            label="part")
    assert plate.info["mode"] == "footprint" and plate.shape == "plate"
    assert plate.height == pytest.approx(part.height_m)
    _closed(plate)
    banana = size_prior("banana")
    dome = lift_silhouette(_blob(), camera, height_hint=banana.height_m, prior_shape=banana.shape, label="banana")
    assert dome.shape == "inflated"
    mesh = _closed(dome)
    assert dome.height == pytest.approx(banana.height_m, rel=0.05)
    # rounded: its volume is well under the prism of its footprint and height
    prism = lift_silhouette(_blob(), camera, height_hint=banana.height_m, prior_shape=banana.shape)
    assert prism.shape == "prism" and mesh.volume < 0.85 * trimesh.Trimesh(prism.vertices, prism.faces).volume


def test_a_box_whose_top_does_not_show_stays_a_slab():
    """A front face alone (one colour with grain, no top lit apart) has no top edge to fit a cuboid to."""
    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    rng = np.random.default_rng(3)
    photo = np.clip(np.full((240, 320, 3), 120.0) + rng.normal(0, 6, (240, 320, 1)), 0, 255).astype(np.uint8)
    mask = np.zeros((240, 320), bool)
    mask[130:200, 120:220] = True
    photo[mask] = np.clip(np.array([70, 110, 190]) + rng.normal(0, 6, (int(mask.sum()), 1)), 0, 255)
    lifted = lift_silhouette(mask, camera, photo=photo, label="box")
    assert lifted.shape == "extrude"
    _closed(lifted)


def test_a_bowl_seen_from_above_its_rim_is_a_hollow_vessel_of_its_true_size():
    """The synthetic bowl (24 cm rim, 18 cm base, 6 cm deep) under its true camera: lifted open at the top, its
    rim, base and depth within 5 % of the truth, and what lies in it meets its inner floor, not its rim."""
    from physomni_usd.bench.synthetic import make_stack
    from physomni_usd.lift.silhouette import fill_holes

    scene = make_stack("bowl_of_spheres", 320, 240)
    bowl = scene.labels.index("bowl")
    mask = fill_holes(np.logical_or.reduce(scene.masks))  # the bowl with what lies in it, as amodal completion gives
    lifted = lift_silhouette(mask, scene.camera, **_prior("bowl"), label="bowl")
    assert lifted.shape == "vessel" and lifted.info["mode"] == "footprint"
    mesh = _closed(lifted)
    assert lifted.info["rim_radius_m"] == pytest.approx(0.12, rel=0.05)
    assert lifted.info["base_radius_m"] == pytest.approx(0.09, rel=0.05)
    assert lifted.height == pytest.approx(0.06, rel=0.05)
    centre = 0.5 * (mesh.bounds[0] + mesh.bounds[1])
    down, _, _ = mesh.ray.intersects_location([[centre[0], centre[1], 1.0]], [[0.0, 0.0, -1.0]])
    floor = float(down[:, 2].max())
    assert floor < 0.25 * lifted.height  # the first thing under the rim's middle is the inner floor
    assert mesh.volume < 0.4 * mesh.convex_hull.volume  # open: most of its hull is the inside
    plain = _closed(lift_silhouette(mask, scene.camera, **_prior("bowl")))  # no label: the solid it used to be
    top, _, _ = plain.ray.intersects_location([[centre[0], centre[1], 1.0]], [[0.0, 0.0, -1.0]])
    assert float(top[:, 2].max()) > 0.9 * float(plain.vertices[:, 2].max()) and bowl == 0


def test_only_open_containers_are_vessels():
    for label in ("bowl", "fruit bowl", "basin", "pot", "bucket", "pan", "dish"):
        assert body_kind(label) == "vessel", label
    for label in ("teapot", "tray", "cup", "toy bowl"):
        assert body_kind(label) != "vessel", label


def _prior(label: str) -> dict:
    p = size_prior(label)
    return {"height_hint": p.height_m, "prior_shape": p.shape}


def test_a_thin_part_of_a_slab_is_no_deeper_than_it_is_wide_and_the_slab_still_stands():
    """A body with a thin stalk on top (a mirror on its stem): the stalk's rows are as deep as they are wide,
    not the body's depth (a turned object would show each as a strip as long as the body is deep); the body's
    rows keep the slab's depth, and so does its bottom band, so that it stands as it did."""
    from physomni_usd.lift.silhouette import stands

    m = np.zeros((240, 320), np.uint8)
    cv2.rectangle(m, (80, 150), (240, 200), 1, -1)  # the body
    cv2.rectangle(m, (196, 60), (200, 150), 1, -1)  # a 5 px stalk
    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    slab = lift_silhouette(m > 0, camera, label="thing")
    assert slab.shape == "extrude" and stands(slab.vertices, slab.faces)
    mesh = _closed(slab)
    v = slab.vertices
    forward = camera.world_from_camera[:, 2].copy()
    forward[2] = 0.0
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    z0, height = v[:, 2].min(), np.ptp(v[:, 2])

    def extent(low, high):
        band = v[(v[:, 2] >= z0 + low * height) & (v[:, 2] <= z0 + high * height)]
        return np.ptp(band @ forward), np.ptp(band @ right)

    stalk_deep, stalk_wide = extent(0.6, 1.0)
    body_deep, body_wide = extent(0.0, 0.3)
    assert stalk_deep <= 1.5 * stalk_wide, (stalk_deep, stalk_wide)  # the rays spread it a little, no more
    assert body_deep > 5 * stalk_deep and body_deep >= 0.3 * min(body_wide, height), (body_deep, stalk_deep)


def test_a_slab_on_a_thin_foot_keeps_its_full_depth_underfoot_and_stands():
    """A wide body on a narrow foot (a sign on its post, a lamp on its stem): the foot's rows are narrow, but a
    foot only as deep as it is wide would leave the body's weight behind it and the slab would tip over; the
    bottom band keeps the slab's full depth."""
    from physomni_usd.lift.silhouette import stands
    from physomni_usd.settings import LiftSettings

    m = np.zeros((240, 320), np.uint8)
    cv2.rectangle(m, (80, 60), (240, 150), 1, -1)  # the body
    cv2.rectangle(m, (150, 150), (170, 200), 1, -1)  # its foot, 20 px wide
    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    slab = lift_silhouette(m > 0, camera, LiftSettings(shape="extrude"), label="thing")
    assert slab.shape == "extrude" and stands(slab.vertices, slab.faces)
    v = slab.vertices
    forward = camera.world_from_camera[:, 2].copy()
    forward[2] = 0.0
    forward /= np.linalg.norm(forward)
    z0, height = v[:, 2].min(), np.ptp(v[:, 2])
    foot = v[v[:, 2] <= z0 + 0.1 * height] @ forward
    body = v[v[:, 2] >= z0 + 0.5 * height] @ forward
    assert np.ptp(foot) >= 0.9 * np.ptp(body), (np.ptp(foot), np.ptp(body))


def test_a_slab_too_thin_once_thinned_keeps_every_row_deep(monkeypatch):
    """A slanted oval cut by the frame's edge (the fruits photo's kiwi), here with a stalk on top: thinned, its
    stalk's rows as deep as they are wide, its box is judged thinner than its outline allows
    (``metrics.geometry.thin_side``, on its own box or along the slab's axes), so the full slab is kept, every
    row as deep as the body (the full slab is no thicker than its outline makes it: thinning is what is
    refused, not the outline)."""
    from physomni_usd.lift import silhouette
    from physomni_usd.settings import LiftSettings

    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    m = np.zeros((240, 320), np.uint8)
    cv2.ellipse(m, (20, 150), (25, 50), 30, 0, 360, 1, -1)
    cv2.rectangle(m, (18, 70), (21, 110), 1, -1)  # a stalk on top: rows narrower than the slab is deep
    forward = camera.world_from_camera[:, 2].copy()
    forward[2] = 0.0
    forward /= np.linalg.norm(forward)

    def top_and_body():
        slab = lift_silhouette(m > 0, camera, LiftSettings(shape="extrude"), label="thing")
        v = slab.vertices
        z0, height = v[:, 2].min(), np.ptp(v[:, 2])
        return np.ptp(v[v[:, 2] >= z0 + 0.97 * height] @ forward), np.ptp(v @ forward)

    top, body = top_and_body()
    assert top >= 0.9 * body, (top, body)  # the kiwi's top row as deep as its body
    monkeypatch.setattr(silhouette, "_keeps_thinned", lambda thin, full, rows: True)  # kept, it is thinned
    top, body = top_and_body()
    assert top < 0.6 * body, (top, body)


def test_a_post_with_an_arm_to_one_side_stands_as_its_full_slab_does():
    """A narrow post with a wide arm to one side (a gallows, a signpost): thinned, the post's rows above the
    bottom band lose depth and the arm keeps it, the weight moves toward the arm, off the foot, and the slab
    tips where the full slab stands (:func:`lift.silhouette.stands`); the full slab is kept."""
    from physomni_usd.lift.silhouette import stands
    from physomni_usd.settings import LiftSettings

    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, 0.0, 1.0))
    for arm in (14, 18, 22):
        m = np.zeros((240, 320), np.uint8)
        cv2.rectangle(m, (100, 60), (129, 200), 1, -1)  # the post, 30 px
        cv2.rectangle(m, (100, 60), (200, 60 + arm), 1, -1)  # the arm, to the right
        slab = lift_silhouette(m > 0, camera, LiftSettings(shape="extrude"), label="thing")
        assert slab.shape == "extrude" and stands(slab.vertices, slab.faces), arm


@pytest.mark.parametrize("deg, x", [(4.0, 0.0), (9.0, 0.12), (15.0, -0.1)])
def test_a_ball_seen_from_the_side_is_lofted_about_one_upright_axis_under_its_centre_of_mass(deg, x):
    """A ball's lowest point is under its middle, not at its front (a cup's foot): lofted against the front plane
    its centre of mass lay 2 cm behind its lowest point, and stacked on another fruit it tipped backward off it."""
    camera, mask, centre = ball_seen_low(deg, x)
    lifted = lift_silhouette(mask, camera, label="orange")
    assert lifted.shape == "round"
    mesh = _closed(lifted)
    z = lifted.vertices[:, 2]
    lowest = lifted.vertices[z <= z.min() + 5e-4, :2].mean(axis=0)
    assert np.linalg.norm(mesh.center_mass[:2] - lowest) < 1e-3
    assert np.linalg.norm(mesh.center_mass - centre) < 0.01  # where the ball is, to a few pixels of its foot
    extent = np.ptp(lifted.vertices, axis=0)
    assert np.ptp(extent) < 0.05 * extent.max()  # as deep as wide and tall
    seen = _silhouette(camera, mesh)
    assert (seen & mask).sum() >= 0.99 * mask.sum() and (seen & mask).sum() >= 0.85 * (seen | mask).sum()


def test_a_cup_seen_from_the_side_keeps_its_front_and_flat_base():
    """What is not a ball (a cup's outline: taller than wide) stays the front-anchored loft on its flat base."""
    camera = PinholeCamera(640, 480, 50.0, 10.0, (0.0, -0.6, 0.14))
    mask = np.zeros((480, 640), np.uint8)
    cv2.ellipse(mask, (320, 300), (45, 70), 0, 0, 360, 1, -1)
    lifted = lift_silhouette(mask > 0, camera, label="cup")
    assert lifted.shape == "round" and "axis" not in lifted.info
    z = lifted.vertices[:, 2]
    base = lifted.vertices[z <= z.min() + 1e-9, :2]
    assert np.ptp(base[:, 0]) > 0.5 * np.ptp(lifted.vertices[:, 0])  # a flat base as wide as the body


@pytest.mark.parametrize("deg", [1.0, 4.0, 15.0])
def test_a_ball_seen_from_the_side_is_round_at_both_ends(deg):
    """A ball rests on a small sole under its middle, and its top is the sphere's: every vertex within 2 mm of
    the ground lies within √(2R·2 mm) of its upright axis (a sphere's ring there), and its top is no higher
    than the ball's. Its end
    rows took the widest span of the rows half-way to their neighbours and it stood on a flat foot 29 mm
    across (its bottom ring 15 mm in radius at the ground; at 1° no cap at all), and its top overshot by 3 mm.
    Its contact stays the outline's foot on the ground, in front of where it rests (``info['rest']``)."""
    import math

    radius = 0.035
    camera, mask, centre = ball_seen_low(deg)
    lifted = lift_silhouette(mask, camera, label="orange")
    assert lifted.info.get("axis") == "ball"
    v = lifted.vertices
    rest = np.asarray(lifted.info["rest"])
    assert abs(rest[2] - v[:, 2].min()) < 1e-6
    near = v[v[:, 2] <= v[:, 2].min() + 0.002]
    assert np.linalg.norm(near[:, :2] - rest[:2], axis=1).max() <= math.sqrt(2.0 * radius * 0.002), deg
    assert np.ptp(v[:, 2]) <= 2.0 * radius + 0.0015
    mesh = _closed(lifted)
    assert np.linalg.norm(mesh.center_mass[:2] - rest[:2]) < 1e-3
    # the foot the outline shows: nearer the camera than where the ball rests, on the ground
    assert abs(lifted.contact[2] - rest[2]) < 1e-9
    assert np.linalg.norm(lifted.contact[:2] - camera.origin[:2]) < np.linalg.norm(rest[:2] - camera.origin[:2])
