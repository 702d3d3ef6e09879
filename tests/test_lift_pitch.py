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


def _outline(camera, vertices, faces) -> np.ndarray:
    import cv2

    uv, _ = camera.project(vertices)
    out = np.zeros((camera.height, camera.width), np.uint8)
    for f in faces:
        cv2.fillConvexPoly(out, np.round(uv[f] * 8).astype(np.int32), 1, shift=3)
    return out > 0


def _slab_as_cast(mask, camera):
    """The slab with every row's sides along its own rays (no foot reaching back): the outline it must keep."""
    from physomni_usd.lift import silhouette
    from physomni_usd.lift.silhouette import LiftSettings

    keep = silhouette._foot_reaching_back
    silhouette._foot_reaching_back = lambda r, depth: (r.camera.rays(r.spans[:, 0], r.edges),
                                                       r.camera.rays(r.spans[:, 1], r.edges))
    try:
        return lift_silhouette(mask, camera, LiftSettings(shape="extrude"))
    finally:
        silhouette._foot_reaching_back = keep


@pytest.mark.parametrize("pitch,yaw", [(10.0, 25.0), (20.0, 35.0)])
def test_a_turned_box_slab_stands_on_a_foot_reaching_back_to_its_corners(pitch, yaw):
    """A box turned to the camera shows its bottom edges sloping (they run back on the ground): the slab of its
    outline stands on a foot reaching back to its corners, not on the lowest corner with its centre beyond it
    (a box on a stack toppled off it); the photo's view keeps its outline and the wedge in front of the box's
    sides stays empty (a neighbour standing there would start inside it)."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.silhouette import LiftSettings, stands

    camera = PinholeCamera(640, 480, 50.0, pitch, (0.0, 0.0, 0.2 + 1.2 * np.sin(np.radians(pitch))))
    box = trimesh.creation.box((0.30, 0.20, 0.25))
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(yaw), [0, 0, 1]))
    box.apply_translation([0.05, 1.3, 0.125])
    mask = _outline(camera, box.vertices, box.faces)
    as_cast = _slab_as_cast(mask, camera)
    lifted = lift_silhouette(mask, camera, LiftSettings(shape="extrude"))
    assert lifted.info["mode"] == "standing" and lifted.shape == "extrude"
    assert not stands(as_cast.vertices, as_cast.faces)
    assert stands(lifted.vertices, lifted.faces)
    seen, seen_before = _outline(camera, lifted.vertices, lifted.faces), _outline(camera, as_cast.vertices,
                                                                                as_cast.faces)
    assert (seen != seen_before).sum() <= 0.002 * seen_before.sum()
    # the foot adds to the slab as cast behind the box's bottom edges, not in the wedge in front of its sides
    # (the slab as cast overhangs them a little already: its band stands on the front plane); a foot as wide as
    # the slab across its front would hold a neighbour standing there
    lo, hi = box.bounds[0] - [0.1, 0.1, 0.0], box.bounds[1] + [0.1, 0.1, 0.0]
    grid = np.stack(np.meshgrid(np.linspace(lo[0], hi[0], 60), np.linspace(lo[1], hi[1], 60),
                                np.linspace(0.002, 0.04, 5), indexing="ij"), -1).reshape(-1, 3)
    inside = [trimesh.Trimesh(m.vertices, m.faces, process=False).contains(grid) for m in (lifted, as_cast)]
    assert (inside[0] & ~inside[1]).sum() > 0
    outside = [(held & ~box.contains(grid)).sum() for held in inside]
    assert outside[0] <= 1.15 * outside[1]


def test_a_stem_with_a_leaf_keeps_the_foot_it_shows():
    """A leaf drooping beside a thin stem is no bottom edge running back: the slab's foot stays the stem's."""
    import cv2

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.silhouette import LiftSettings

    camera = PinholeCamera(640, 480, 50.0, 10.0, (0.0, 0.0, 0.8))
    mask = np.zeros((480, 640), np.uint8)
    cv2.rectangle(mask, (315, 300), (325, 420), 1, -1)
    cv2.ellipse(mask, (320, 230), (110, 90), 0, 0, 360, 1, -1)
    cv2.fillConvexPoly(mask, np.array([[320, 300], [200, 405], [210, 410], [325, 320]], np.int32), 1)
    lifted = lift_silhouette(mask > 0, camera, LiftSettings(shape="extrude"))
    as_cast = _slab_as_cast(mask > 0, camera)
    foot = lambda v: v[v[:, 2] <= v[:, 2].min() + 1e-6]
    assert np.ptp(foot(lifted.vertices)[:, 0]) == pytest.approx(np.ptp(foot(as_cast.vertices)[:, 0]), abs=1e-6)
    assert np.ptp(foot(lifted.vertices)[:, 0]) < 0.05


def test_a_thin_outline_seen_from_steeply_above_lifts_as_a_slab():
    """A pencil lying across a top-down view, forced to a slab: its bottom band spans under two pixel rows, so
    there is no bottom edge to read a slope from and the foot is cast as it shows (reading one raised, and the
    build reported the pencil's foot as above the horizon)."""
    import cv2

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.silhouette import LiftSettings

    camera = PinholeCamera(640, 480, 50.0, 82.0, (0.0, 0.0, 0.3))
    for thick in (6, 12):
        mask = np.zeros((480, 640), np.uint8)
        cv2.rectangle(mask, (220, 300 - thick // 2), (420, 300 + thick // 2), 1, -1)
        lifted = lift_silhouette(mask > 0, camera, LiftSettings(shape="extrude"))
        assert lifted.shape == "extrude" and len(lifted.faces)


def test_a_typical_height_the_outline_cannot_hold_is_cut_to_one_it_can():
    """A label's typical size is a guess (boxes come in every size): a small box on a stack, seen from steeply
    above and given a height four times its own, had no footprint under that height (the outline's casts at its
    foot and at its top did not meet), was lifted as a slab standing on a corner of its slanted lower edge, and
    fell off the stack. Cut to where its footprint keeps half the outline's cast, it is a footprint of about its
    size."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.footprint import lift_footprint

    camera = PinholeCamera(320, 240, 50.0, 72.0, (0.0, 0.0, 1.0))
    base = 0.35  # the top of the stack it rests on
    box = trimesh.creation.box((0.08, 0.06, 0.07))
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(20.0), [0, 0, 1]))
    box.apply_translation([0.03, 0.22, base + 0.035])
    mask = _outline(camera, box.vertices, box.faces)
    found = lift_footprint(mask, camera, 0.3, "box", base, kind="boxy")
    assert found is not None
    verts, _, shape, _, info = found
    assert info["mode"] == "footprint" and shape == "prism"
    assert float(verts[:, 2].min()) == pytest.approx(base, abs=1e-6)
    height = float(np.ptp(verts[:, 2]))
    assert 0.5 * 0.07 <= height <= 1.5 * 0.07
    assert float(np.ptp(verts[:, :2], axis=0).max()) <= 1.5 * float(np.ptp(box.vertices[:, :2], axis=0).max())
    # on the ground the outline's slab stands and keeps the outline: nothing is cut there (the slab is lifted)
    mask = _outline(camera, box.vertices - [0.0, 0.0, base], box.faces)
    assert lift_footprint(mask, camera, 0.5, "box", 0.0, kind="boxy") is None


def test_a_typical_height_leaving_a_sliver_is_cut_and_a_held_one_is_kept():
    """A guessed height just under the one that leaves no footprint leaves a sliver: a 12 × 10 × 9 cm box on a
    stack, given the 30 cm of boxes in general, kept 3.7 % of its outline's cast and stood as a fin 30 cm tall
    that toppled. Cut to where its footprint keeps half the cast, it is a box about its own size; a height
    that already holds that much (its own) is kept as it is."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.footprint import lift_footprint

    camera = PinholeCamera(320, 240, 50.0, 72.0, (0.0, 0.0, 1.0))
    base = 0.3
    box = trimesh.creation.box((0.12, 0.10, 0.09))
    box.apply_translation([0.02, 0.22, base + 0.045])
    mask = _outline(camera, box.vertices, box.faces)
    verts, _, shape, _, info = lift_footprint(mask, camera, 0.3, "box", base, kind="boxy")
    assert shape == "prism" and "cut" in info["height_source"]
    size = np.ptp(verts, axis=0)
    assert 0.5 * 0.09 <= size[2] <= 1.5 * 0.09
    assert min(size[:2]) >= 0.7 * 0.10 and max(size[:2]) <= 1.3 * 0.12
    verts, _, shape, _, info = lift_footprint(mask, camera, 0.09, "box", base, kind="boxy")
    assert "cut" not in info["height_source"]
    assert float(np.ptp(verts[:, 2])) == pytest.approx(0.09, rel=1e-6)


def test_a_cut_footprint_round_enough_for_a_cylinder_stays_a_prism():
    """A 12 × 10 × 9 cm box turned 20° on a stack seen from 44°: its footprint cut from its cast is a hexagon
    whose circle IoU passes for round (0.86); a box's label, or a cut height whatever the label, keeps the
    square edges of a prism, not a cylinder."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.lift.footprint import ROUND_IOU, lift_footprint

    camera = PinholeCamera(320, 240, 50.0, 44.0, (0.0, 0.0, 1.0))
    base = 0.3
    box = trimesh.creation.box((0.12, 0.10, 0.09))
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(20.0), [0, 0, 1]))
    box.apply_translation([0.02, 0.8, base + 0.045])
    mask = _outline(camera, box.vertices, box.faces)
    for kind in ("boxy", None):
        _, _, shape, _, info = lift_footprint(mask, camera, 0.3, "box", base, kind=kind)
        assert info["circle_iou"] >= ROUND_IOU and "cut" in info["height_source"]
        assert shape == "prism", kind
