"""Round things (a ball's label, or a visible arc that is a circle's) lift as centred balls in any view:
their centre of mass over their contact, their size from the arc the photo shows."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.lift.silhouette import lift_silhouette
from physomni_usd.sizes import size_prior

from .conftest import ball_seen_low


def _fruit(camera, semi, centre):
    """Silhouette (bool) of an upright ellipsoid of semi-axes ``semi`` (m) centred at ``centre`` (m)."""
    body = trimesh.creation.icosphere(4, 1.0)
    body.vertices = body.vertices * semi + centre
    uv, _ = camera.project(body.vertices)
    mask = np.zeros((camera.height, camera.width), np.uint8)
    for tri in body.faces:
        cv2.fillPoly(mask, [np.round(uv[tri] * 16).astype(np.int32)], 1, shift=4)
    return mask > 0


def _com_over_contact(lifted):
    """(COM's horizontal distance from the middle of the lowest 2 mm of the mesh, that contact's half-width) m."""
    mesh = trimesh.Trimesh(lifted.vertices, lifted.faces, process=False)
    com = mesh.center_mass if mesh.is_volume else lifted.vertices.mean(0)
    low = lifted.vertices[lifted.vertices[:, 2] <= lifted.vertices[:, 2].min() + 0.002, :2]
    mid = 0.5 * (low.min(0) + low.max(0))
    return float(np.linalg.norm(com[:2] - mid)), float(0.5 * np.ptp(low, axis=0).min())


def _lift(mask, camera, label, visible=None):
    prior = size_prior(label)
    return lift_silhouette(mask, camera, height_hint=prior and prior.height_m, prior_shape=prior and prior.shape,
                           label=label, **({} if visible is None else {"visible": visible}))


@pytest.mark.parametrize("deg", [3.0, 10.0, 16.0])
def test_a_lemon_half_hidden_and_seen_low_is_a_centred_ball_of_its_visible_arc(deg):
    # the camera's pitch under FOOTPRINT_MIN_DEG: every fruit stood, and a hidden one's completed outline (its
    # visible part's convex hull with a guessed flat side) failed the ball test and became a slab or a blob
    camera, seen, centre = ball_seen_low(deg, radius=0.032)
    ys, xs = np.nonzero(seen)
    visible = seen & (np.arange(seen.shape[1])[None, :] < xs.min() + 0.55 * np.ptp(xs))  # its right side hidden
    completed = visible.copy()
    cols = slice(xs.min() + int(0.5 * np.ptp(xs)), xs.min() + int(0.85 * np.ptp(xs)))
    completed[ys.min() + 5:ys.max() + 1, cols] = True  # a boxy guess at the hidden part
    lifted = _lift(completed, camera, "lemon", visible)
    assert lifted.shape == "sphere" and lifted.info["axis"] == "ball"
    radius = 0.5 * np.ptp(lifted.vertices[:, 0])
    assert radius == pytest.approx(0.032, rel=0.08)
    rest = lifted.vertices[np.argmin(lifted.vertices[:, 2])]
    assert np.linalg.norm(rest[:2] - centre[:2]) < 0.1 * 0.032  # where the true ball rests, not ahead of it
    off, _ = _com_over_contact(lifted)
    assert off < 0.001


def test_a_flatter_than_ball_lemon_seen_low_is_its_upright_spheroid_not_a_front_anchored_loft():
    # 7.45 x 5.98 cm: too flat for the ball test, so it was lofted against its front plane, its centre of mass a
    # radius behind where it touched; as a ball of its mean radius it lost a fifth of its outline's overlap
    camera = PinholeCamera(640, 480, 50.0, 10.0, (0.0, -0.6, 0.03 + 0.6 * np.tan(np.radians(10.0))))
    mask = _fruit(camera, np.array([0.03725, 0.03725, 0.0299]), np.array([0.0, 0.0, 0.0299]))
    lifted = _lift(mask, camera, "lemon")
    assert lifted.shape == "sphere"
    width, _, height = np.ptp(lifted.vertices, axis=0)
    assert width == pytest.approx(2 * 0.03725, rel=0.05)
    assert height == pytest.approx(2 * 0.0299 * (1 - 0.5 * 0.03), rel=0.05)  # its sole cut off
    off, _ = _com_over_contact(lifted)
    assert off < 0.001
    rest = lifted.vertices[np.argmin(lifted.vertices[:, 2])]
    assert abs(rest[1]) < 0.025  # near where it rests: a ball of its mean radius rests a little nearer
    assert lifted.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)


def test_an_unlabelled_outline_is_a_ball_only_where_its_visible_arc_is_a_circle():
    camera, seen, _ = ball_seen_low(10.0)
    ys, xs = np.nonzero(seen)
    visible = seen & (np.arange(seen.shape[1])[None, :] < xs.min() + 0.6 * np.ptp(xs))
    completed = visible.copy()
    completed[ys.min() + 3:ys.max() + 1, xs.min() + int(0.5 * np.ptp(xs)):xs.max() - 3] = True  # a boxy guess
    assert _lift(completed, camera, "thing", visible).shape == "sphere"
    box = np.zeros_like(seen)
    box[200:300, 250:400] = True
    assert _lift(box, camera, "thing", box & (np.arange(box.shape[1])[None, :] < 330)).info.get("axis") != "ball"


def test_a_potato_half_hidden_is_not_made_a_ball():
    # the size table calls a potato a ball, but it lies on its long side (10 x 6 cm): only a round label's
    # outline, or a visible arc that is a circle, makes a ball
    camera = PinholeCamera(640, 480, 50.0, 10.0, (0.0, -0.6, 0.03 + 0.6 * np.tan(np.radians(10.0))))
    seen = _fruit(camera, np.array([0.05, 0.03, 0.03]), np.array([0.0, 0.0, 0.03]))
    ys, xs = np.nonzero(seen)
    visible = seen & (np.arange(seen.shape[1])[None, :] < xs.min() + 0.6 * np.ptp(xs))
    assert _lift(seen, camera, "potato", visible).shape != "sphere"
    lemon = _lift(seen, camera, "lemon", visible)  # a lemon's label: the upright spheroid its outline shows
    assert lemon.shape == "sphere"
    width, _, height = np.ptp(lemon.vertices, axis=0)
    assert width == pytest.approx(0.10, rel=0.05) and height == pytest.approx(0.06 * 0.985, rel=0.05)


@pytest.mark.parametrize("x", [0.0, 0.15])
def test_an_occluders_straight_edge_is_not_the_balls_arc(x):
    # the completed outline of a ball cut by something in front runs along that thing's straight edge: counted as
    # the ball's edge, it pulled the circle in (a 30 px ball fitted at 18-21 px)
    camera, seen, centre = ball_seen_low(10.0, x=x, radius=0.03)
    ys, xs = np.nonzero(seen)
    cut = xs.min() + int(0.6 * np.ptp(xs))
    occluder = np.zeros_like(seen)
    occluder[ys.min() - 20:ys.max() + 20, cut:cut + 60] = True
    visible = seen & ~occluder
    prior = size_prior("orange")
    lifted = lift_silhouette(visible, camera, height_hint=prior.height_m, prior_shape=prior.shape, label="orange",
                             visible=visible, occluders=occluder)
    assert lifted.info.get("axis") == "ball"
    assert 0.5 * np.ptp(lifted.vertices[:, 0]) == pytest.approx(0.03, rel=0.05)
    middle = 0.5 * (lifted.vertices.min(0) + lifted.vertices.max(0))
    assert np.linalg.norm(middle[:2] - centre[:2]) < 0.1 * 0.03


def test_a_ball_far_outside_its_labels_size_is_not_lifted_as_one():
    # a wrong arc or support can put a ball's cone far away: an orange came out 22 cm across, on the ground behind
    # the fruit it lay on
    camera, seen, _ = ball_seen_low(10.0, radius=0.3)
    ys, xs = np.nonzero(seen)
    visible = seen & (np.arange(seen.shape[1])[None, :] < xs.min() + 0.6 * np.ptp(xs))
    assert _lift(seen, camera, "orange", visible).info.get("axis") != "ball"
