"""Plates between a stacked object and what holds it: where two flat faces meet, the widest four-cornered
patch they share; none where they do not meet flat (a ball on a box, a box beside another)."""

import numpy as np
import trimesh

from physomni_usd.physics.support import shared_quad


def _poly_prism(outline: np.ndarray, z0: float, z1: float) -> np.ndarray:
    return np.vstack([np.column_stack([outline, np.full(len(outline), z0)]),
                      np.column_stack([outline, np.full(len(outline), z1)])])


def _area(q: np.ndarray) -> float:
    x, y = q[:, 0], q[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def test_skewed_books_share_a_wide_patch():
    # a lifted book's outline: dozens of corners, a slanted parallelogram over another
    t = np.linspace(0, 1, 20)
    lower_outline = np.vstack([np.column_stack([-0.1 + 0.2 * t, -0.06 + 0.02 * t]),
                               np.column_stack([0.1 - 0.2 * t, 0.06 + 0.02 * (1 - t)])])
    upper_outline = np.vstack([np.column_stack([-0.08 + 0.2 * t, -0.03 + 0.03 * t]),
                               np.column_stack([0.12 - 0.2 * t, 0.05 - 0.03 * t])])
    lower = _poly_prism(lower_outline, 0.0, 0.03)
    upper = _poly_prism(upper_outline, 0.03, 0.06)
    quad = shared_quad(upper, lower)
    assert quad is not None and quad.shape == (4, 2)
    foot_area = _area(upper_outline[[0, 19, 20, 39]])
    assert _area(quad) > 0.6 * foot_area
    # every corner lies on or inside both outlines' hulls
    from scipy.spatial import ConvexHull
    for outline in (lower_outline, upper_outline):
        eq = ConvexHull(outline).equations
        assert np.all(quad @ eq[:, :2].T + eq[:, 2] <= 1e-6)


def test_no_plate_without_flat_contact():
    box = trimesh.creation.box((0.2, 0.2, 0.05))
    box.apply_translation((0, 0, 0.025))
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    ball.apply_translation((0, 0, 0.09))
    assert shared_quad(np.asarray(ball.vertices), np.asarray(box.vertices)) is None  # rests on a point
    side = box.copy()
    side.apply_translation((0.25, 0, 0))
    assert shared_quad(np.asarray(side.vertices), np.asarray(box.vertices)) is None  # beside, not on
    # a box flat on the box
    on = trimesh.creation.box((0.1, 0.1, 0.05))
    on.apply_translation((0, 0, 0.075))
    assert shared_quad(np.asarray(on.vertices), np.asarray(box.vertices)) is not None


def test_plates_only_where_a_face_has_more_corners_than_the_contact_samples():
    from physomni_usd.physics.support import needs_plates

    box = trimesh.creation.box((0.2, 0.2, 0.2))
    box.apply_translation((0, 0, 0.1))
    on = trimesh.creation.box((0.2, 0.2, 0.2))
    on.apply_translation((0, 0, 0.3))
    assert not needs_plates(np.asarray(on.vertices), np.asarray(box.vertices))  # met at its four corners
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    book = _poly_prism(np.column_stack([0.1 * np.cos(t), 0.07 * np.sin(t)]), 0.2, 0.23)  # a many-cornered outline
    assert needs_plates(book, np.asarray(box.vertices))
    assert needs_plates(np.asarray(on.vertices) + (0, 0, 0.03), book)  # a box on it
