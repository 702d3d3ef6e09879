"""An open vessel collides as convex pieces: a ball dropped in a bowl stays in it, where its hull lets it roll off."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import trimesh

from physomni_usd.lift.vessel import vessel_mesh
from physomni_usd.geometry.overlap import convex_pieces

from .conftest import cli

BOWL = dict(centre=np.array([0.0, 0.0]), base_radius_m=0.09, rim_radius=0.12, height=0.06)


def test_the_pieces_fill_the_wall_and_floor_not_the_inside():
    mesh = vessel_mesh(**BOWL)
    pieces = [trimesh.convex.convex_hull(p) for p in convex_pieces(mesh.vertices, mesh.faces)]
    assert len(pieces) > 10
    assert sum(p.volume for p in pieces) < 1.05 * mesh.volume < 0.4 * mesh.convex_hull.volume
    solid = trimesh.creation.cylinder(0.05, 0.05)  # a closed thing is its own hull
    assert len(convex_pieces(solid.vertices, solid.faces)) == 1


def _drop(hollow: bool) -> np.ndarray:
    """Where a 6 cm ball dropped 2 cm above the bowl's floor, 4 cm off its axis, is after 0.5 s (XPBD, as the
    simulator steps a stacked scene)."""
    import newton
    import warp as wp

    from physomni_usd.physics.pieces import add_decomposed
    from physomni_usd.physics.stepping import contact_pipeline, xpbd_solver

    wp.config.quiet = True
    mesh = vessel_mesh(**BOWL, wall=0.01)
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    builder.add_ground_plane()
    bowl = SimpleNamespace(matrix=np.eye(4), points=mesh.vertices, faces=mesh.faces, path="/bowl",
                           params={"density": 700.0, "dynamic_friction": 0.35, "restitution": 0.2},
                           to_local=lambda p: p)
    if hollow:
        add_decomposed(builder, [bowl], newton, wp)
    else:  # what Newton makes of the same mesh under physics:approximation = convexHull
        body = builder.add_body(xform=wp.transform((0.0, 0.0, 0.0), wp.quat_identity()))
        hull = mesh.convex_hull
        builder.add_shape_convex_hull(body, mesh=newton.Mesh(hull.vertices.astype(np.float32),
                                                             hull.faces.ravel().astype(np.int32)))
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    b = builder.add_body(xform=wp.transform((0.04, 0.0, 0.01 + 0.03 + 0.02), wp.quat_identity()))
    builder.add_shape_convex_hull(b, mesh=newton.Mesh(ball.vertices.astype(np.float32),
                                                      ball.faces.ravel().astype(np.int32)))
    model = builder.finalize(device="cpu")
    solver = xpbd_solver(model, iterations=8)
    pipeline, contacts = contact_pipeline(model)
    state, after, control = model.state(), model.state(), model.control()
    for _ in range(15 * 32):
        state.clear_forces()
        pipeline.collide(state, contacts)
        solver.step(state, after, control, contacts, 1.0 / 960)
        state, after = after, state
    return state.body_q.numpy()[-1, :3]


def test_a_ball_dropped_in_a_bowl_stays_in_it():
    p = _drop(hollow=True)
    assert np.hypot(p[0], p[1]) < 0.09 and abs(p[2] - 0.04) < 0.003, p  # on the inner floor, inside the wall
    q = _drop(hollow=False)
    assert q[2] > 0.06 + 0.02, q  # against its hull it lies on a lid over the rim




def test_a_pushed_hollow_body_moves(tmp_path, photo):
    """A body whose collider is cut into convex pieces is built here, not by Newton's USD importer, which is
    what gives a body the velocity ``--push`` writes (``physics:velocity``): a pushed pot stood still."""
    from pxr import Sdf, Usd, UsdGeom

    from physomni_usd.physics.simulate import simulate_shot
    from physomni_usd.settings import SimulateSettings

    out = tmp_path / "shot"
    proc = cli("build", photo["photo"], "-o", out, "--mask", f"{photo['cup']}:cup", "--mask", f"{photo['box']}:box",
               "--push", "cup=0.8,0,0", "-q")
    assert proc.returncode == 0, proc.stderr
    layer = Sdf.Layer.FindOrOpen(str(out / "physics.usda"))  # as the build writes a vessel's collider
    edit = Usd.Stage.Open(layer)
    edit.OverridePrim("/World/Objects/cup_0").CreateAttribute(
        "physics:approximation", Sdf.ValueTypeNames.Token).Set("convexDecomposition")
    layer.Save()
    simulate_shot(out, SimulateSettings(seconds=1.0))
    shot = Usd.Stage.Open(str(out / "shot.usda"))
    cup = UsdGeom.Xformable(shot.GetPrimAtPath("/World/Objects/cup_0"))
    times = cup.GetTimeSamples()
    moved = (cup.ComputeLocalToWorldTransform(times[-1]).ExtractTranslation()
             - cup.ComputeLocalToWorldTransform(times[0]).ExtractTranslation()).GetLength()
    # 0.8 m/s against friction 0.5 slides v^2 / (2 mu g) = 6.5 cm; standing still it moved 0.2 mm
    assert moved > 0.03, moved
