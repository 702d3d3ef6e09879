"""The renderer's contact shadow: a soft darkening around whatever has left its photo pose, whatever the light."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import Usd

from physomni_usd.geometry.raycast import CONTACT_REACH, ContactCaster, contact_falloff


def test_a_ball_seen_from_above_darkens_a_ring_around_its_silhouette():
    # a ball resting on the ground, rays straight down: the ground right under it is hidden, the ring around its
    # outline is where its shadow must show (a shadow cast straight down, by height alone, ends at the outline)
    r = 0.05
    ball = trimesh.creation.icosphere(subdivisions=3, radius=r)
    points = ball.vertices + [0.0, 0.0, r]
    caster = ContactCaster(points, ball.faces, np.zeros(len(ball.faces), np.int32), "cpu")
    xs = np.linspace(0.0, 0.4, 81)
    ground = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], -1)
    origin = np.array([0.0, 0.0, 1.0])
    rays = (ground - origin) / np.linalg.norm(ground - origin, axis=1, keepdims=True)
    weight, reach = np.array([0.6]), np.array([r])
    caster.update(points, weight)
    dark = caster.darkening(origin, rays[None].astype(np.float32), weight, reach)[0]
    gap = (np.hypot(xs, r) - r) / r  # distance from the ground point to the sphere, in reaches
    assert np.allclose(dark, 0.6 * contact_falloff(gap), atol=0.01)  # the kernel computes the documented falloff
    ring = (xs > 1.05 * r) & (xs < 1.3 * r)
    assert dark[ring].min() > 0.15  # beside the outline: dark enough to see
    assert dark[xs > r * (1 + CONTACT_REACH) + r].max() == 0.0  # far off: none
    assert np.all(np.diff(dark) <= 1e-6)  # fading outward
    # past a backdrop (the plane x = 0.2, facing the origin) the rays see no ground, and no shadow
    walled = caster.darkening(origin, rays[None].astype(np.float32), weight, reach,
                              (np.array([-1.0, 0.0, 0.0]), -0.2))[0]
    assert np.array_equal(walled[xs < 0.19], dark[xs < 0.19]) and walled[xs > 0.21].max() == 0.0
    assert dark[(xs > 0.21) & (xs < 0.25)].min() > 0.0  # (where, without it, there was some)
    # an object that casts nothing (in place, hidden) leaves the ground as it is
    assert caster.darkening(origin, rays[None].astype(np.float32), np.zeros(1), reach).max() == 0.0


@pytest.fixture(scope="module")
def renderers(shot):
    from physomni_usd.rendering.video import ShotRenderer
    from physomni_usd.settings import RenderSettings

    stage = Usd.Stage.Open(str(shot["shot"]))
    return stage, ShotRenderer(stage), ShotRenderer(stage, RenderSettings(shadow_strength=0.0))


def test_a_box_pushed_across_the_floor_has_a_soft_shadow_and_frame_0_is_untouched(renderers):
    import cv2

    stage, lit, bare = renderers
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    # frame 0: nothing has moved, the photo keeps its own shadows and no synthetic one is added
    assert np.array_equal(lit.frame(start), bare.frame(start))
    image, state = lit.render(end)
    plain = bare.frame(end).astype(np.float32).mean(2)
    dark = 1.0 - image.astype(np.float32).mean(2) / np.maximum(plain, 1.0)
    box = [k for k, o in enumerate(lit.objects) if o.path.rsplit("/", 1)[-1].startswith("box")][0]
    face = state.mesh_face
    seen = np.where(face >= 0, lit.face_object[np.maximum(face, 0)], -1)
    away = cv2.distanceTransform((seen != box).astype(np.uint8), cv2.DIST_L2, 5)
    ground = seen < 0
    near = ground & (away > 1) & (away <= 6)
    far = ground & (away > 40) & (away <= 60)
    assert near.sum() > 50 and far.sum() > 50
    assert dark[near].mean() > 0.04  # a darker band around the moved box (none without it) ...
    assert dark[near].mean() > 4 * max(dark[far].mean(), 0.005)  # ... that fades with distance
