"""The place stage's checks on placed meshes and the lift's choice of shape for boxes, on tiny scenes."""

from __future__ import annotations

import numpy as np
import trimesh

from physomni_usd.texture.hidden import occlusion_kept
from physomni_usd.geometry.camera import PinholeCamera


def test_occlusion_kept_when_no_ray_meets_the_hidden_object():
    """Every ray through the occluder misses the object behind it (placed off to the side): the order holds."""
    camera = PinholeCamera(64, 48, 50.0, 0.0, (0.0, -1.0, 0.1))
    front = trimesh.creation.box((0.2, 0.05, 0.2))
    front.apply_translation([0.0, 0.0, 0.1])
    behind = trimesh.creation.box((0.1, 0.1, 0.1))
    behind.apply_translation([5.0, 2.0, 0.05])
    u, v = camera.project(np.array([[0.0, -0.025, 0.1]]))[0][0]
    pixels = np.array([[u + dx, v + dy] for dx in (-2, 0, 2) for dy in (-2, 0, 2)])
    assert occlusion_kept(camera, front, behind, pixels) == 1.0
    assert occlusion_kept(camera, behind, front, pixels) is None  # no ray meets the far box at all


def test_a_box_seen_corner_on_keeps_square_edges():
    """The top box of the stack is a mirror-symmetric hexagon with no flat bottom, the outline of a round
    thing; its label makes it a cuboid (it was a surface of revolution, IoU 0.68 from the photo's view)."""
    from physomni_usd.bench.synthetic import make_stack
    from physomni_usd.lift.silhouette import lift_silhouette, mirror_iou

    scene = make_stack("three_boxes", 240, 180)
    top = scene.masks[2]
    assert mirror_iou(top) > 0.8  # the outline alone would say round
    camera = PinholeCamera(240, 180, 50.0, 27.0, (0.0, 0.0, 1.0))  # as build finds it: seen from the side
    assert lift_silhouette(top, camera, base_z=0.37, photo=scene.photo, label="vase").shape == "round"
    assert lift_silhouette(top, camera, base_z=0.37, photo=scene.photo, label="box").shape == "cuboid"


def test_a_flat_thing_lies_on_its_broadest_face():
    """The stack's spoon (a 9 × 1.4 × 0.5 cm bar in the saucer, 2 cm up) under the true camera: at the label's 2 cm
    the footprint is a 3 mm fin on its edge; lying, it comes out a few mm thick and at least as wide as thick.
    A height that already lies flat (2 mm) is left alone."""
    from physomni_usd.bench.synthetic import make_stack
    from physomni_usd.lift.footprint import _narrow_side, lying_height, outline

    scene = make_stack("cup_saucer_spoon", 480, 360)
    poly = outline(scene.masks[2])
    assert _narrow_side(poly, scene.camera, 0.02, 0.02)[0] < 0.005  # the fin the typical height made
    h = lying_height(poly, scene.camera, 0.02, 0.02)
    assert h is not None and 0.001 <= h <= 0.009, h
    assert _narrow_side(poly, scene.camera, 0.02, h)[0] >= h
    assert lying_height(poly, scene.camera, 0.02, 0.002) is None


def _box_scene(shift):
    """A 10 cm box on the ground seen from 60 cm, its mask, and the box's mesh moved ``shift`` (3,) metres."""
    from physomni_usd.geometry.raycast import SilhouetteRenderer

    camera = PinholeCamera(160, 120, 50.0, 30.0, (0.0, -0.5, 0.35))
    box = trimesh.creation.box((0.1, 0.08, 0.06))
    box.apply_translation([0.0, 0.0, 0.03])
    mask = SilhouetteRenderer([box.vertices], [box.faces]).render(camera) == 0
    return camera, box, mask, box.vertices + np.asarray(shift, float)


def test_the_solve_brings_a_misplaced_object_back_onto_its_outline():
    from physomni_usd.align.solve import solve_places

    camera, box, mask, moved = _box_scene([0.015, 0.0, 0.0])
    solved = solve_places(camera, [moved], [box.faces], [mask])
    one = solved.info["objects"][0]
    assert solved.info["taken"], solved.info
    assert one["reprojection_px_after"] < 0.5 * one["reprojection_px_before"], one
    assert abs(solved.vertices[0][:, 0].mean()) < 0.005  # back over x = 0, from 15 mm off
    assert abs(solved.vertices[0][:, 2].min()) < 1e-9  # still on the ground


def test_the_solve_keeps_first_poses_it_cannot_better_and_never_pushes_objects_into_each_other():
    """Two boxes whose masks are one place: the solve may not pull them into each other; an object already on
    its outline is left where it is."""
    from physomni_usd.align.solve import solve_places
    from physomni_usd.metrics.geometry import max_penetration

    camera, box, mask, _ = _box_scene([0.0, 0.0, 0.0])
    left, right = box.vertices + [-0.051, 0, 0], box.vertices + [0.051, 0, 0]
    solved = solve_places(camera, [left, right], [box.faces, box.faces], [mask, mask])
    a, b = (trimesh.Trimesh(v, box.faces, process=False) for v in solved.vertices)
    assert max_penetration({"a": a, "b": b}) <= 0.0005
    still = solve_places(camera, [box.vertices], [box.faces], [mask])
    assert not still.info["taken"] and np.allclose(still.vertices[0], box.vertices)
