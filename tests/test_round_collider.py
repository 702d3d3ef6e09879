"""Issue 38, part 1 (nothing unpushed moves): a round ball collides as a sphere with its lowest point where its
hull's is (``physics.round``), so a lifted fruit resting on the ground stays where it rocked on its tessellated
hull, rests at the mesh's height, and still rolls when pushed; what is not round (a tall or squashed fruit, a
box) keeps its hull."""

from __future__ import annotations

import numpy as np
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.round import fit_ball
from physomni_usd.physics.settle import settle_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import BALL_MAX_PROTRUSION, BALL_MIN_FILL, SimulateSettings
from physomni_usd.usd import layers

FRUIT = {"density": 950.0, "restitution": 0.2, "dynamic_friction": 0.45, "static_friction": 0.5}


def _ball(tall: float = 1.132, radius: float = 0.0322):
    """A lifted ball as the build writes it: a tessellated sphere ``tall`` times taller than wide, standing
    on a small flat foot (235726/005's apple: 6.4 cm wide, 7.3 cm tall)."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    v = m.vertices * [1.0, 1.0, tall]
    low = v[:, 2].min()
    v[v[:, 2] < low + 0.0025 * tall, 2] = low
    v[:, 2] -= low
    return trimesh.Trimesh(v, m.faces, process=False)


def _settle(tmp_path, mesh, shape):
    shot = write_bench_shot(tmp_path, [BenchObject("ball", mesh, "rigid", FRUIT, shape=shape)])
    return settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)


def test_a_round_ball_on_the_ground_neither_rocks_nor_rolls_nor_sinks(tmp_path):
    for tall in (1.0, 1.02):  # an orange, one a little taller than wide
        settled = _settle(tmp_path / f"t{tall}", _ball(tall), "sphere")
        m = settled.motions["ball"]
        assert settled.colliders["ball"]["collides_as"] == "sphere", settled.colliders
        assert m.turned_deg < 0.05, (tall, m)
        assert np.abs(m.translation[:2]).max() < 1e-4, (tall, m)
        assert abs(m.translation[2]) < 5e-4, (tall, m)  # it rests where its mesh does


def test_two_touching_balls_a_little_taller_than_wide_stay(tmp_path):
    """The sphere is no wider than the hull: one as tall as a ball a little taller than wide pokes out of its
    sides into the fruit beside it, and the two push each other away."""
    for tall in (1.02, 1.04):
        a = _ball(tall)
        b = a.copy()
        b.apply_translation((np.ptp(a.vertices[:, 0]) + 0.0002, 0.0, 0.0))  # hulls 0.2 mm apart
        shot = write_bench_shot(tmp_path / f"t{tall}", [BenchObject("a", a, "rigid", FRUIT, shape="sphere"),
                                                        BenchObject("b", b, "rigid", FRUIT, shape="sphere")])
        settled = settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)
        for name in ("a", "b"):
            assert settled.colliders[name]["collides_as"] == "sphere", (tall, settled.colliders)
            m = settled.motions[name]
            assert m.moved_m < 1e-3 and m.turned_deg < 0.5, (tall, name, m)


def test_a_ball_round_across_and_a_little_taller_collides_as_the_sphere_of_its_level_radius(tmp_path):
    """A footprint's ball takes its height from its outline's tangent cone, a few per cent uncertain
    (452298/004's round orange lifted 6.6 % taller than wide): round across and taller by at most
    ``BALL_TALL_SPREAD``, it collides as the sphere of its level radius and stays, where its hull rocked."""
    for tall in (1.066, 1.095):
        settled = _settle(tmp_path / f"t{tall}", _ball(tall), "sphere")
        assert settled.colliders["ball"]["collides_as"] == "sphere", (tall, settled.colliders)
        semi = settled.colliders["ball"]["semi_axes_m"]
        assert semi[0] == semi[2] <= 0.0322 + 1e-4, semi  # no wider than the hull across
        m = settled.motions["ball"]
        assert m.turned_deg < 0.05 and m.moved_m < 1e-4, (tall, m)


def test_a_ball_something_rests_on_keeps_its_hull(tmp_path):
    """A sphere does not resist rolling: a round ball with another resting on it a little off its top keeps
    its hull, and stays where it is; the ball on top, holding nothing, is a sphere."""
    a = _ball(1.0, 0.035)
    b = a.copy()
    b.apply_translation((0.002, 0.0, np.ptp(a.vertices[:, 2]) + 0.0002))
    shot = write_bench_shot(tmp_path, [BenchObject("a", a, "rigid", FRUIT, shape="sphere"),
                                       BenchObject("b", b, "rigid", FRUIT, shape="sphere")])
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)
    assert settled.colliders["a"]["collides_as"] == "hull" and settled.colliders["a"]["holds"] == "b", settled.colliders
    assert settled.colliders["b"]["collides_as"] == "sphere", settled.colliders
    assert settled.motions["a"].moved_m < 3e-3, settled.motions["a"]  # as a sphere: 22 cm


def test_a_ball_less_round_keeps_its_hull(tmp_path):
    """A ball taller or flatter than the sphere spread allows keeps its hull: an ellipsoid balancing on its end
    rolled away where the hull stays on its foot."""
    for tall in (1.132, 0.7):  # an apple, a squashed tomato
        settled = _settle(tmp_path / f"t{tall}", _ball(tall), "sphere")
        assert settled.colliders["ball"]["collides_as"] == "hull", (tall, settled.colliders)
        assert settled.motions["ball"].moved_m < 0.01, (tall, settled.motions["ball"])


def test_the_same_mesh_not_lifted_as_a_ball_keeps_its_hull(tmp_path):
    """The sphere is for what the lift made a ball: the same points lifted otherwise rest on their hull,
    which the solver rocks on its foot (the case the sphere mends)."""
    settled = _settle(tmp_path, _ball(1.02), "extrude")
    m = settled.motions["ball"]
    assert "ball" not in settled.colliders and m.turned_deg > 0.1 and -m.translation[2] < 1e-3, (m, settled)


def test_what_a_ball_is_not_keeps_its_hull(tmp_path):
    """Below the roundness floor the hull stays: a cube lifted as a ball (its extents equal) stands on its
    face, not on a sphere that would roll it."""
    import trimesh

    box = trimesh.creation.box((0.06, 0.06, 0.06))
    box.apply_translation((0.0, 0.0, 0.03))
    settled = _settle(tmp_path, box, "sphere")
    assert settled.colliders["ball"]["collides_as"] == "hull", settled.colliders
    m = settled.motions["ball"]
    assert m.moved_m < 1e-3 and m.turned_deg < 0.5, m


def test_the_fit_and_its_floor():
    import trimesh

    turn = trimesh.transformations.rotation_matrix(0.7, [0, 0, 1])[:3, :3]
    lemon = _ball(1.0).vertices * [1.4, 1.0, 1.0] @ turn.T  # long along a horizontal axis turned 40°
    fit = fit_ball(lemon)
    assert np.allclose(sorted(fit.semi), sorted([0.0322 * 1.4, 0.0322, fit.semi[2]]), atol=5e-4)
    assert abs(abs(fit.axes[:, 0] @ turn[:, 0]) - 1.0) < 1e-3  # its long axis is the lemon's
    assert not fit.sphere and not fit.fits  # not round: it keeps its hull
    ball = _ball(1.02).vertices
    fit = fit_ball(ball)
    assert fit.sphere and fit.fits  # a nearly round one is a sphere
    assert abs(fit.centre[2] - fit.semi[2] - ball[:, 2].min()) < 1e-9  # its lowest point is the mesh's
    # it stands straight under the centre of mass, so it starts balanced; one far off the middle is no ball's
    com = ball.mean(axis=0) + [0.0005, 0.0, 0.0]
    assert np.allclose(fit_ball(ball, com).centre[:2], com[:2]) and fit_ball(ball, com).fits
    off = fit_ball(ball, ball.mean(axis=0) + [0.004, 0.0, 0.0])
    assert off.sphere and off.protrusion > BALL_MAX_PROTRUSION and not off.fits
    cube = fit_ball(trimesh.creation.box((0.1, 0.1, 0.1)).vertices)
    assert cube.sphere and cube.fill < BALL_MIN_FILL and not cube.fits
    cylinder = fit_ball(trimesh.creation.cylinder(0.05, 0.1, sections=64).vertices)
    assert cylinder.sphere and cylinder.fill < BALL_MIN_FILL and not cylinder.fits


def test_a_pushed_ball_rolls(tmp_path):
    """Pushed along the ground, the ball turns as it goes, as a ball rolls: its turn is the distance over
    its radius once it has stopped sliding."""
    mesh = _ball(1.0, 0.04)
    shot = write_bench_shot(tmp_path, [BenchObject("ball", mesh, "rigid", FRUIT, velocity=(0.6, 0.0, 0.0),
                                                   shape="sphere")])
    report = simulate_shot(shot, SimulateSettings(seconds=1.0))
    assert report["colliders"]["ball"]["collides_as"] == "sphere"
    stage = layers.open_shot(shot)
    xf = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Objects/ball"))
    poses = [np.array(xf.ComputeLocalToWorldTransform(f)) for f in (report["frames"] - 4, report["frames"] - 1)]
    dx = poses[1][3, 0] - poses[0][3, 0]
    turn = poses[0][:3, :3].T @ poses[1][:3, :3]  # row-vector matrices: the turn between the two frames
    angle = np.arccos(np.clip((np.trace(turn) - 1.0) / 2.0, -1.0, 1.0))
    assert dx > 0.01, dx  # still going after a second (three frames: a turn under half a revolution)
    assert abs(angle * 0.04 / dx - 1.0) < 0.1, (angle, dx)  # rolling, not sliding
    assert abs(poses[1][3, 2] - poses[0][3, 2]) < 1e-3  # on the ground, not bouncing


def test_a_ball_lifted_standing_and_stacked_on_another_stays(tmp_path):
    """A ball seen from the side (8° down) is lofted about its own upright axis: stacked on another such ball
    and steadied as the build does, it stays. Lofted against its front plane as a cup is, its centre of mass lay
    2 cm behind its lowest point and it tipped backward off the ball under it (25 cm; 452298/027, /035, /020)."""
    import trimesh

    from physomni_usd.lift.silhouette import lift_silhouette
    from physomni_usd.physics.support import steady_stacks

    from .conftest import ball_seen_low

    camera, mask, _ = ball_seen_low(8.0)
    lifted = lift_silhouette(mask, camera, label="orange")
    lower = trimesh.Trimesh(lifted.vertices, lifted.faces, process=False)
    upper = lower.copy()
    upper.vertices[:, 2] += np.ptp(lower.vertices[:, 2])  # its lowest point on the lower one's top
    verts, _ = steady_stacks([lower.vertices, upper.vertices], [lower.faces, upper.faces], {1: (0, "contact")},
                             camera.origin)
    shot = write_bench_shot(tmp_path, [
        BenchObject("lower", trimesh.Trimesh(verts[0], lower.faces, process=False), "rigid", FRUIT, shape="round"),
        BenchObject("upper", trimesh.Trimesh(verts[1], upper.faces, process=False), "rigid", FRUIT, shape="round")])
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)
    for name in ("lower", "upper"):
        m = settled.motions[name]
        assert m.moved_m < 0.002 and m.turned_deg < 1.0, (name, m)


def test_a_ball_a_little_taller_collided_as_a_sphere_rolls_as_a_round_one(tmp_path):
    """A ball collided as a sphere has the sphere's mass properties: on a level floor a round ball is balanced
    wherever it turns, so a gentle push rolls a ball 6.6-9.5 % taller than wide as far as it rolls a round one.
    With its mesh's centre of mass (1.2-2.9 mm over the sphere's centre) it sat on top of its round bottom and a
    2 cm/s push tipped it over, 4.5-5 cm where the round one went 4 mm."""

    def rolled(tall):
        shot = write_bench_shot(tmp_path / f"t{tall}", [BenchObject("ball", _ball(tall), "rigid", FRUIT,
                                                                   velocity=(0.02, 0.0, 0.0), shape="sphere")])
        report = simulate_shot(shot, SimulateSettings(seconds=2.0))
        assert report["colliders"]["ball"]["collides_as"] == "sphere", (tall, report["colliders"])
        stage = layers.open_shot(shot)
        xf = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Objects/ball"))
        first, last = [np.array(xf.ComputeLocalToWorldTransform(f)) for f in (0, report["frames"] - 1)]
        return float(np.linalg.norm(last[3, :2] - first[3, :2]))

    round_one = rolled(1.0)
    assert round_one < 0.01, round_one
    for tall in (1.066, 1.095):
        assert abs(rolled(tall) - round_one) < 0.002, (tall, round_one)
