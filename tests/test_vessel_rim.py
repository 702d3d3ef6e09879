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


def test_a_foot_over_the_pots_front_wall_is_in_its_mouth_one_on_the_ground_beside_or_behind_is_not():
    """Foliage hanging over a pot's front shows its lowest pixel over the pot's wall, below the rim's front."""
    pot, mask = _scene(0.2)
    f = vessel_frame(pot.vertices)
    away = CAMERA.world_from_camera[:2, 2] / np.linalg.norm(CAMERA.world_from_camera[:2, 2])
    side = np.array([away[1], -away[0]])

    def foot_at(point):  # a small outline whose lowest pixel is where ``point`` projects
        uv, _ = CAMERA.project(np.asarray(point, float)[None])
        u, v = int(uv[0, 0]), int(uv[0, 1])
        m = np.zeros_like(mask)
        m[v - 12:v, u - 3:u + 3] = True
        return m

    front_wall = np.r_[f["centre"] - 0.9 * f["outer"] * away, 0.6 * f["rim_z"]]  # over the wall's front, below the rim
    assert foot_in_mouth(pot.vertices, foot_at(front_wall), CAMERA)
    beside = np.r_[f["centre"] + 2.5 * f["outer"] * side, 0.0]
    assert not foot_in_mouth(pot.vertices, foot_at(beside), CAMERA)
    # behind it, where the pot hides its foot: what shows of it ends over the rim's back
    behind = np.r_[f["centre"] + 1.4 * f["outer"] * away, 0.0]
    uv_back, _ = CAMERA.project(np.r_[f["centre"] + f["outer"] * away, f["rim_z"]][None])
    m = foot_at(behind)
    m[int(uv_back[0, 1]) - 1:] = False
    if m.any():
        assert not foot_in_mouth(pot.vertices, m, CAMERA)


def test_what_stands_in_the_mouth_clears_the_rim_and_stands_on_the_filled_vessel_which_does_not_sink():
    """On the rim a 0.6 kg plant touched each of a 50 g pot's wall pieces, and XPBD, at the simulator's two
    iterations, let the pot sink 6 mm into the ground; on the pot filled up to its foot, neither moves more than
    a few mm (this 4.6 kg foliage on the empty pot's rim: the pot 11 mm, the foliage 25 mm)."""
    import newton
    import warp as wp
    from types import SimpleNamespace

    from physomni_usd.lift.rim import filled, soil_level
    from physomni_usd.physics.pieces import add_decomposed
    from physomni_usd.physics.stepping import contact_pipeline, xpbd_solver

    pot, mask = _scene(0.2)
    verts, faces, contact = rests_on_rim(pot.vertices, mask, CAMERA, rows=16, sections=16)
    f = vessel_frame(pot.vertices)
    hull = trimesh.Trimesh(verts, faces, process=False).convex_hull
    gap = -trimesh.proximity.signed_distance(pot, hull.sample(4000, seed=0)).max()
    assert 0.0 < gap < f["wall"]  # clear of the rim, not resting on it
    foot = float(verts[:, 2].min())
    level = soil_level(pot.vertices, foot)
    assert level >= foot - 1e-9
    verts = verts + [0.0, 0.0, level - foot]
    pv, pf = filled(pot.vertices, level)
    # filled to the level (to the brim: a tenth of a wall under the rim, whose hull closes it), the wall as it was
    assert -1e-6 < level - vessel_frame(pv)["floor_z"] < 0.1 * f["wall"] + 1e-6
    assert abs(vessel_frame(pv)["outer"] - f["outer"]) < 1e-9 and abs(vessel_frame(pv)["rim_z"] - f["rim_z"]) < 1e-9
    centre = np.r_[f["centre"], 0.0]

    wp.config.quiet = True
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    builder.add_ground_plane()
    vessel = SimpleNamespace(matrix=np.eye(4), points=pv - centre, faces=pf, path="/pot",
                             params={"density": 200.0, "dynamic_friction": 0.7}, to_local=lambda p: p)
    add_decomposed(builder, [vessel], newton, wp)
    body = builder.add_body(xform=wp.transform((0.0, 0.0, 0.0), wp.quat_identity()))
    cfg = newton.ModelBuilder.ShapeConfig()
    cfg.density = 200.0
    seated = (hull.vertices + [0.0, 0.0, level - foot] - centre).astype(np.float32)
    builder.add_shape_convex_hull(body, mesh=newton.Mesh(seated, hull.faces.ravel().astype(np.int32)), cfg=cfg)
    model = builder.finalize(device="cpu")
    solver = xpbd_solver(model, iterations=2)
    pipeline, contacts = contact_pipeline(model)
    state, after, control = model.state(), model.state(), model.control()
    for _ in range(240):
        state.clear_forces()
        pipeline.collide(state, contacts)
        solver.step(state, after, control, contacts, 1.0 / 240)
        state, after = after, state
    moved = np.linalg.norm(state.body_q.numpy()[:, :3], axis=1)
    assert moved.max() < 5e-3, moved
