"""The camera from the photo: cues on synthetic photos with a known camera."""

from __future__ import annotations

import pytest

from physomni_usd.align.cues import estimate_camera
from physomni_usd.bench.photos import make_known_scene
from physomni_usd.lift.silhouette import fill_holes, foot_pixel


def _estimate(scene, **kw):
    feet = [foot_pixel(fill_holes(m))[1] for m in scene.masks]
    return estimate_camera(scene.photo, scene.masks, scene.labels, feet, **kw)


@pytest.mark.parametrize("pitch", [5.0, 30.0, 85.0])
def test_pitch_and_field_of_view_come_from_the_photo(pitch):
    scene = make_known_scene(pitch)
    est = _estimate(scene)
    assert est.pitch_deg == pytest.approx(pitch, abs=5.0)
    assert est.fov_deg == pytest.approx(scene.camera.fov_deg, rel=0.10)
    kinds = {c.kind for c in est.cues}
    assert "ellipse" in kinds and "horizon vanishing points" in kinds
    assert all(c.weight > 0 for c in est.cues)


def test_given_pitch_and_fov_win_over_the_cues():
    scene = make_known_scene(30.0)
    est = _estimate(scene, fov_deg=40.0, pitch_deg=50.0)
    assert (est.pitch_deg, est.fov_deg, est.pitch_source, est.fov_source) == (50.0, 40.0, "user", "user")
    assert est.cues  # still recorded
