"""The silhouette IoU ``build`` records per object (report.json, ``align.compare.visible_ious``) is what the shot
shows through the photo's camera: each lifted mesh cut out by the mask its texture carries, hidden only where a
nearer mesh is opaque. The lifter spans an outline's concavities (the gap under an arch, between a
motorcycle's wheels) and the texture cuts them away; the bare meshes would score that gap as a misfit and let
it hide whatever the photo shows through it."""

from __future__ import annotations

import numpy as np
import trimesh

from physomni_usd.align import compare
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.lift.silhouette import lift_silhouette


def _arch_and_box_behind():
    """An arch (a gate: two legs and a lintel) lifted from its mask as the builder lifts it, and a box behind it
    that the photo shows through the arch's opening; their masks as the photo has them."""
    cam = PinholeCamera(200, 150, 50.0, 10.0, (0.0, 0.0, 1.0))
    arch = np.zeros((150, 200), bool)
    arch[40:140, 50:150] = True
    arch[70:140, 70:130] = False  # the opening, down to the ground
    lifted = lift_silhouette(arch, cam)
    box = trimesh.creation.box((0.6, 0.4, 0.5))
    box.apply_translation([0.0, lifted.vertices[:, 1].max() + 0.5, 0.25])  # on the ground behind the arch
    box_whole = compare.silhouette(box.vertices, box.faces, cam)
    box_seen = box_whole & ~arch
    assert box_seen.sum() > 0.3 * box_whole.sum()  # the photo shows it through the opening
    return cam, [lifted.vertices, box.vertices], [lifted.faces, box.faces], [arch, box_seen]


def test_a_concave_outline_and_what_shows_through_it_match_their_masks():
    cam, verts, faces, masks = _arch_and_box_behind()
    bare = compare.silhouette(verts[0], faces[0], cam)
    assert compare.mask_iou(bare, masks[0]) < 0.8  # the lifted arch is a slab over its opening
    ious = compare.visible_ious(verts, faces, cam, masks)
    assert min(ious) >= 0.9, ious


def test_an_object_placed_off_its_mask_scores_low():
    cam, verts, faces, masks = _arch_and_box_behind()
    off = verts[1] + [0.35, 0.0, 0.0]  # the box slid sideways, off what the photo shows of it
    ious = compare.visible_ious([verts[0], off], faces, cam, masks)
    assert ious[0] >= 0.9 and ious[1] < compare.WARN_IOU, ious


def test_a_nearer_opaque_object_hides_what_it_covers():
    cam, verts, faces, masks = _arch_and_box_behind()
    # the box's mask claims the arch's leg too: where the leg is opaque and nearer, the box is not shown there
    claimed = masks[1] | masks[0]
    ious = compare.visible_ious(verts, faces, cam, [masks[0], claimed])
    seen = masks[1].sum() / claimed.sum()
    assert abs(ious[1] - seen) < 0.05 and ious[1] < 0.85, (ious, seen)
