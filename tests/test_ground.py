"""Ground planes: canonical pose, RANSAC and AGMF, on point sets with known truth."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from physomni_usd.align.ground import agmf_plane, apply, canonical_pose, ground_transform, ransac_plane

TRUE_UP = np.array([0.0, np.sin(0.3), np.cos(0.3)])  # the true floor is tilted in the prior's frame


def _rot_to(up):
    from physomni_usd.rotations import between

    return between(np.array([0.0, 0.0, 1.0]), up)


def _scene(with_wall: bool, seed=0):
    """Boxes on a floor, seen in a frame where the floor's normal is TRUE_UP; optionally a tall wall."""
    rng = np.random.default_rng(seed)
    r = _rot_to(TRUE_UP)
    sets = []
    for x in (-1.0, 0.0, 1.0):
        box = trimesh.creation.box((0.3, 0.3, 0.4)).sample(3000, seed=int(rng.integers(1 << 30)))
        sets.append((box + [x, 1.0, 0.2]) @ r.T)
    if with_wall:  # a thin, tall, dense slab standing on the floor with a tilted foot region
        wall = trimesh.creation.box((3.0, 0.05, 2.5)).sample(20000, seed=1) + [0.0, 2.0, 1.25]
        sets.append(wall @ r.T)
        figure = trimesh.creation.cylinder(0.15, 1.8).sample(8000, seed=2) + [-0.5, 1.5, 0.9]
        sets.append(figure @ r.T)
    return sets


def _angle(a, b):
    return np.degrees(np.arccos(np.clip(abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def test_agmf_finds_the_floor_among_tall_structures():
    sets = _scene(with_wall=True)
    prior = np.array([0.0, 0.0, 1.0])
    agmf = agmf_plane(sets, prior)
    assert _angle(agmf.normal, TRUE_UP) < 1.0


def test_both_agree_without_distractors():
    sets = _scene(with_wall=False)
    prior = np.array([0.0, 0.0, 1.0])
    assert _angle(agmf_plane(sets, prior).normal, TRUE_UP) < 1.0
    assert _angle(ransac_plane(sets, prior, seed=3).normal, TRUE_UP) < 3.0


def test_fits_are_seeded():
    sets = _scene(with_wall=True)
    a = ransac_plane(sets, [0, 0, 1], seed=5)
    b = ransac_plane(sets, [0, 0, 1], seed=5)
    assert np.array_equal(a.normal, b.normal)


def test_ground_transform_puts_the_floor_at_zero():
    sets = _scene(with_wall=False)
    plane = agmf_plane(sets, [0, 0, 1])
    m = ground_transform(plane)
    assert np.isclose(np.linalg.det(m[:3, :3]), 1.0)
    moved = [apply(m, s) for s in sets]
    lows = [s[:, 2].min() for s in moved]
    assert np.allclose(lows, 0.0, atol=0.01)


def test_canonical_pose_rests_the_short_axis_on_the_ground():
    box = trimesh.creation.box((1.0, 0.6, 0.1))
    rot = trimesh.transformations.random_rotation_matrix(np.random.default_rng(4).random(3))
    v = apply(rot, box.vertices) + [3, 2, 1]
    m = canonical_pose(v)
    out = apply(m, v)
    assert np.isclose(out[:, 2].min(), 0.0, atol=1e-9)
    assert np.isclose(np.ptp(out[:, 2]), 0.1, atol=1e-6)


@pytest.mark.parametrize("points", [
    [np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])],  # collinear: no plane
    [np.array([[0.0, 0.0, 0.0]])],  # one point
])
def test_degenerate_anchor_sets_fall_back_to_the_prior(points):
    plane = agmf_plane(points, [0, 0, 1])
    assert plane.method == "agmf-fallback" and np.allclose(plane.normal, [0, 0, 1])
