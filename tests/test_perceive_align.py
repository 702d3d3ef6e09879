"""Units of perceive and align: masks, lifting, camera, separation."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from physomni_usd.geometry.camera import PinholeCamera, pick_pitch
from physomni_usd.align.place import footprint, make_room, separate, separation
from physomni_usd.errors import InputError
from physomni_usd.metrics import mask_iou, ssim
from physomni_usd.lift.silhouette import flat_bottom, is_ball, lift_silhouette
from physomni_usd.perceive.masks import identifier, split_spec
from physomni_usd.settings import LiftSettings

from .conftest import ball_seen_low

W, H = 320, 240


def _mask(draw):
    m = np.zeros((H, W), np.uint8)
    draw(m)
    return m > 0


def _silhouette(mesh_vertices, faces, camera):
    uv, _ = camera.project(mesh_vertices)
    out = np.zeros((H, W), np.uint8)
    for f in faces:
        cv2.fillConvexPoly(out, np.round(uv[f] * 16).astype(np.int32), 1, shift=4)
    return out > 0


@pytest.mark.parametrize("shape, draw", [
    ("round", lambda m: cv2.ellipse(m, (160, 150), (40, 60), 0, 0, 360, 1, -1)),
    ("extrude", lambda m: cv2.rectangle(m, (100, 90), (230, 200), 1, -1)),
    ("extrude", lambda m: cv2.fillPoly(m, [np.array([[60, 200], [260, 200], [200, 80], [90, 140]])], 1)),
])
def test_lifted_mesh_is_closed_on_the_ground_and_matches_its_silhouette(shape, draw):
    mask = _mask(draw)
    camera = PinholeCamera(W, H, 50.0, pick_pitch(50.0, H, [np.nonzero(mask)[0].max() + 1], None))
    lifted = lift_silhouette(mask, camera, LiftSettings(shape=shape))
    mesh = trimesh.Trimesh(lifted.vertices, lifted.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert abs(lifted.vertices[:, 2].min()) < 1e-9
    seen = _silhouette(lifted.vertices, lifted.faces, camera)
    # the mesh must cover the mask (the texture's alpha cuts away any excess) and not much more
    assert (seen & mask).sum() >= 0.99 * mask.sum()
    assert mask_iou(seen, mask) >= 0.8  # a slab seen from above also shows its top


def test_auto_shape_tells_boxes_cups_and_balls_apart():
    box = _mask(lambda m: cv2.rectangle(m, (100, 90), (230, 200), 1, -1))
    ball = _mask(lambda m: cv2.circle(m, (160, 120), 50, 1, -1))
    assert flat_bottom(box) and not is_ball(box)
    assert is_ball(ball) and not flat_bottom(ball)


def test_camera_projects_its_own_rays_back_to_their_pixels():
    cam = PinholeCamera(W, H, 55.0, 20.0, (0.3, -1.0, 1.2))
    u, v = np.array([10.5, 160.0, 300.2]), np.array([200.0, 120.0, 230.7])
    ground = cam.ground_points(u, v)
    assert np.allclose(ground[:, 2], 0.0)
    uv, depth = cam.project(ground)
    assert np.allclose(uv, np.stack([u, v], 1), atol=1e-6) and (depth > 0).all()
    right, up, back = cam.usd_matrix()[:3, :3]
    assert np.isclose(np.linalg.det(np.stack([right, up, back])), 1.0)  # a rotation, not a reflection


def test_pitch_is_refused_when_a_foot_would_be_above_the_horizon():
    assert pick_pitch(50.0, H, [30], None) > 10.0
    with pytest.raises(InputError):
        pick_pitch(50.0, H, [30], 5.0)


def test_separation_leaves_no_footprint_overlap():
    a = trimesh.creation.box((1, 1, 1)).vertices + [0, 0, 0.5]
    b = a + [0.6, 0.3, 0]
    moves = separate([a, b], gap=0.01)
    pa, pb = footprint(a + moves[0]), footprint(b + moves[1])
    assert separation(pa, pb) is None
    assert all(m[2] == 0 for m in moves)  # never moved vertically


def test_make_room_squashes_the_nearer_object_only():
    near = trimesh.creation.box((1, 1, 1)).vertices + [0, 1.5, 0.5]
    far = near + [0, 0.8, 0]
    verts, scales = make_room([near, far], [np.array([0, 1.0, 0]), np.array([0, 1.8, 0])], np.zeros(3), 0.01)
    assert scales[1] == 1.0 and scales[0] < 1.0
    assert separation(footprint(verts[0]), footprint(verts[1])) is None
    assert np.isclose(verts[0][:, 1].min(), near[:, 1].min())  # the front stays where the camera saw it


def test_make_room_keeps_a_ball_seen_standing_balanced_over_where_it_rests():
    """A ball seen standing was as deep as it is wide (its depth measured, not guessed): placing shrinks it
    about its own axis, never squashes it behind its foot, which kept its front half and flattened its back
    half, its centre of mass ahead of where it rests."""
    from physomni_usd.backends.builtin import _depth_measured

    camera, mask, _ = ball_seen_low(8.0)
    lifted = lift_silhouette(mask, camera, label="orange")
    behind = np.array([0.0, 0.05, 0.0])  # a second one 5 cm behind it, their backs and fronts overlapping
    measured = _depth_measured(lifted.info)
    verts, _ = make_room([lifted.vertices, lifted.vertices + behind], [lifted.contact, lifted.contact + behind],
                         camera.origin, 0.002, fixed_depth=[measured, measured])
    near = trimesh.Trimesh(verts[0], lifted.faces, process=False)
    z = verts[0][:, 2]
    sole = verts[0][z <= z.min() + 1e-6, :2].mean(axis=0)  # the round sole it rests on
    assert np.linalg.norm(near.center_mass[:2] - sole) < 1e-3


def test_mask_spec_and_identifiers():
    assert split_spec("dir/cup.png:cup") == ("dir/cup.png", "cup")
    assert split_spec("C:/x/cup.png") == ("C:/x/cup.png", None)
    assert identifier("3 red cups!") == "_3_red_cups_"


def test_ssim_is_one_for_identical_images_and_drops_with_noise():
    rng = np.random.default_rng(1)
    ramp = np.linspace(0, 255, 64)
    img = np.stack(np.broadcast_arrays(ramp[None, :], ramp[:, None], 128.0), -1).astype(np.uint8)
    assert ssim(img, img) == pytest.approx(1.0)
    noisy = np.clip(img + rng.normal(0, 40, img.shape), 0, 255).astype(np.uint8)
    assert ssim(img, noisy) < 0.5


def test_ssim_agrees_with_scikit_image():
    metrics = pytest.importorskip("skimage.metrics")
    rng = np.random.default_rng(2)
    a = cv2.GaussianBlur(rng.integers(0, 255, (80, 90), dtype=np.uint8), (0, 0), 2)
    b = np.clip(a + rng.normal(0, 10, a.shape), 0, 255).astype(np.uint8)
    ref = metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                        data_range=255)
    assert ssim(a, b) == pytest.approx(ref, abs=0.02)


def test_placing_keeps_two_balls_seen_standing_round_and_moves_them_apart():
    """Two oranges side by side whose fits to their masks overlap by 4 mm: each keeps its shape, as wide as
    the photo shows it and no taller than wide, and they are moved the few millimetres apart. Shrunk in width
    alone, as a footprint seen from above is, each was 15 % narrower than its image and an egg taller than wide
    (its photo's mask covered 0.79 to 0.82 where it had 0.95)."""
    from physomni_usd.align.photo_scene import place_on_ground
    from physomni_usd.backends.builtin import _depth_measured
    from physomni_usd.swappable.protocols import GroundEvidence, LiftedObject

    camera, mask, _ = ball_seen_low(8.0)
    lifted = lift_silhouette(mask, camera, label="orange")
    assert lifted.info.get("axis") == "ball"
    side = np.array([np.ptp(lifted.vertices[:, 0]) - 0.004, 0.0, 0.0])

    def obj(shift):
        return LiftedObject(lifted.vertices + shift, lifted.faces, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                            shape="ball", ground=GroundEvidence(camera, lifted.contact + shift,
                                                                _depth_measured(lifted.info), None, lifted.info))

    scene = place_on_ground([obj(np.zeros(3)), obj(side)], ["a", "b"], 0.002)
    for v in scene.vertices:
        assert np.allclose(np.ptp(v, axis=0), np.ptp(lifted.vertices, axis=0), atol=1e-6)
        assert np.ptp(v[:, 2]) <= max(np.ptp(v[:, 0]), np.ptp(v[:, 1])) + 1e-6
    assert separation(footprint(scene.vertices[0]), footprint(scene.vertices[1])) is None


def test_balls_on_one_supporter_that_cannot_be_moved_apart_shrink_whole_about_where_they_rest():
    """On one supporter objects are not moved apart (that would take them off it): two balls there that overlap
    shrink as a whole, about the point each rests on, so each stays a ball, no taller than wide, still resting."""
    camera, mask, _ = ball_seen_low(8.0)
    lifted = lift_silhouette(mask, camera, label="orange")
    side = np.array([np.ptp(lifted.vertices[:, 0]) - 0.004, 0.0, 0.0])
    verts, scales = make_room([lifted.vertices, lifted.vertices + side], [lifted.contact, lifted.contact + side],
                              camera.origin, 0.002, fixed_depth=[True, True], balls=[True, True], movable=False)
    assert separation(footprint(verts[0]), footprint(verts[1])) is None and min(scales) < 1.0
    for v, k in zip(verts, scales):
        assert np.allclose(np.ptp(v, axis=0), k * np.ptp(lifted.vertices, axis=0), atol=1e-6)
        assert np.isclose(v[:, 2].min(), lifted.vertices[:, 2].min())
