"""The place stage's checks on placed meshes and the lift's choice of shape for boxes, on tiny scenes."""

from __future__ import annotations

import numpy as np
import trimesh

from physomni_usd.align.place import occlusion_kept
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
