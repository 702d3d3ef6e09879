"""What rests on a vessel's rim (lift.rim.rests_on_rim): a plant's foliage wider than its pot's mouth."""

import numpy as np
import trimesh

from physomni_usd.align.compare import silhouette
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.lift.rim import foot_in_mouth, rests_on_rim, vessel_frame
from physomni_usd.lift.vessel import vessel_mesh

CAMERA = PinholeCamera(320, 240, 50.0, 30.0, (0.0, 0.0, 1.0))


def _scene(foliage_radius: float):
    away = CAMERA.world_from_camera[:2, 2] / np.linalg.norm(CAMERA.world_from_camera[:2, 2])
    centre = 1.3 * away
    pot = vessel_mesh(centre, 0.1, 0.13, 0.15)
    blob = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    blob.apply_scale([foliage_radius, foliage_radius, 0.07])
    blob.apply_translation([centre[0], centre[1], 0.15 + 0.05])
    seen = silhouette(np.asarray(blob.vertices), np.asarray(blob.faces), CAMERA)
    # the pot's front rim hides the foliage's lower part: the outline ends at the rim's front
    uv, _ = CAMERA.project(np.r_[centre - 0.12 * away, 0.15][None])
    mask = seen.copy()
    mask[int(uv[0, 1]):] = False
    return pot, mask


def test_foliage_wider_than_the_mouth_rests_on_the_rim_centred_and_clear_of_the_wall():
    pot, mask = _scene(0.2)
    assert foot_in_mouth(pot.vertices, mask, CAMERA)
    verts, faces, contact = rests_on_rim(pot.vertices, mask, CAMERA, rows=16, sections=16)
    f = vessel_frame(pot.vertices)
    body = trimesh.Trimesh(verts, faces, process=False)
    assert body.is_watertight and body.volume > 0
    # centred on the pot's axis, so it does not tip off the rim
    assert np.linalg.norm(body.center_mass[:2] - f["centre"]) < 1e-3
    # its convex hull (what physics collides) is not inside the pot's wall, and touches it (it rests there)
    hull = body.convex_hull
    points = np.vstack([hull.vertices, hull.sample(4000, seed=0)])
    inside = trimesh.proximity.signed_distance(pot, points)
    assert inside.max() < 1e-3
    assert -inside.max() < 5e-3
    # its lowest point reaches into the mouth, below the rim, where the photo shows it over the soil
    assert verts[:, 2].min() < f["rim_z"] + 1e-3


def test_foliage_narrower_than_the_mouth_does_not_rest_on_the_rim():
    pot, mask = _scene(0.06)
    assert rests_on_rim(pot.vertices, mask, CAMERA, rows=16, sections=16) is None
