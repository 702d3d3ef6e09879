"""Lifting at any pitch: footprints from above, heights from visible sides or the typical size."""

from __future__ import annotations

import numpy as np
import pytest

from physomni_usd.bench.photos import make_known_scene
from physomni_usd.sizes import size_prior
from physomni_usd.lift.silhouette import lift_silhouette


def _lift(scene, label):
    i = scene.labels.index(label)
    prior = size_prior(label)
    flat = prior.height_m <= 0.3 * prior.longest_m
    return lift_silhouette(scene.masks[i], scene.camera, height_hint=prior.height_m, prior_shape=prior.shape,
                           flat=flat, photo=scene.photo), scene.meshes[i]


@pytest.mark.parametrize("pitch", [60.0, 85.0])
def test_seen_from_above_a_silhouette_is_a_footprint(pitch):
    scene = make_known_scene(pitch)
    for label in ("can", "plate", "box", "bottle"):
        lifted, truth = _lift(scene, label)
        assert lifted.info["mode"] == "footprint"
        height = float(np.ptp(lifted.vertices[:, 2]))
        assert height == pytest.approx(truth.extents[2], rel=0.15), label
        # the footprint's middle lies where the object stands (camera distance ~1.4 m)
        mid = 0.5 * (lifted.vertices.min(0) + lifted.vertices.max(0))[:2]
        assert np.linalg.norm(mid - truth.bounds.mean(0)[:2]) < 0.05, label
    assert _lift(scene, "plate")[0].shape == "disc" and _lift(scene, "can")[0].shape == "cylinder"


def test_round_things_take_their_height_from_their_visible_sides():
    scene = make_known_scene(30.0)
    lifted, truth = _lift(scene, "bottle")
    assert lifted.info["height_source"].startswith("visible sides")
    assert float(np.ptp(lifted.vertices[:, 2])) == pytest.approx(truth.extents[2], rel=0.1)


def test_a_side_view_still_lifts_standing_silhouettes():
    scene = make_known_scene(5.0)
    lifted, truth = _lift(scene, "bottle")
    assert lifted.info["mode"] == "standing"
    assert float(np.ptp(lifted.vertices[:, 2])) == pytest.approx(truth.extents[2], rel=0.15)
