"""The simulator's stepping, through ``simulate`` itself where it can be: restitution, the guard's account
of the work force fields do, and a noise field whose effect does not depend on the step."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.fields import ForceField
from physomni_usd.physics.forces import FieldSet
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings
from physomni_usd.usd import layers


def _heights(shot, name, frames) -> np.ndarray:
    stage = layers.open_shot(shot)  # held: a prim is valid only while its stage lives
    xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/Objects/{name}"))
    return np.array([xf.ComputeLocalToWorldTransform(f).ExtractTranslation()[2] for f in range(frames)])


@pytest.mark.parametrize("restitution", [0.9, 0.0])
def test_a_ball_thrown_at_the_ground_bounces_as_its_restitution_says(tmp_path, restitution):
    """A 5 cm ball thrown down at 3 m/s from 5 cm above the ground: with restitution 0.9 it rises at
    least 0.1 m afterwards (the ground's 0.1 averages in: e = 0.5), with 0 less than 3 cm."""
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    ball.apply_translation((0.0, 0.0, 0.1))
    shot = write_bench_shot(tmp_path, [BenchObject("ball", ball, "rigid", {"restitution": restitution},
                                                   velocity=(0.0, 0.0, -3.0))])
    report = simulate_shot(shot, SimulateSettings(seconds=0.5))
    rise = _heights(shot, "ball", report["frames"])[1:].max() - 0.05  # above resting on the ground
    if restitution:
        assert rise >= 0.1, rise
    else:
        assert rise < 0.03, rise


def _box_in_the_air(tmp_path, field):
    box = trimesh.creation.box((0.2, 0.2, 0.2))
    box.apply_translation((0.0, 0.0, 1.0))
    shot = write_bench_shot(tmp_path, [BenchObject("box", box, "rigid", {"density": 500.0})], forces=(field,))
    return simulate_shot(shot, SimulateSettings(seconds=0.3))


@pytest.mark.parametrize("field", [
    # a vortex about the box's own axis: no force at its centre, only a torque that spins it
    ForceField("vortex", strength=200.0, direction=(0.0, 0.0, 1.0), falloff=0.0),
    # a strong wind that starts between two frames (a frame is 1/30 s)
    ForceField("constant", strength=200.0, direction=(1.0, 0.0, 0.0), start_time=0.05),
], ids=["vortex", "mid_frame"])
def test_the_guard_accounts_the_work_of_fields(tmp_path, field):
    """The energy a field gives (spin included, from the moment it starts) is work, not growth: no
    roll-back, and the final energy matches the initial energy plus the work."""
    report = _box_in_the_air(tmp_path, field)
    guard = report["guard"]
    assert guard["rollbacks"] == []
    gained = guard["energy_final_j"] - guard["energy_initial_j"]
    assert guard["work_j"] > 10.0  # the field did real work: tens of joules on a 4 kg box
    assert gained == pytest.approx(guard["work_j"], rel=0.05)


def test_noise_moves_particles_alike_at_any_step():
    """A noise field is a random walk in velocity whose spread does not depend on the step: particles'
    velocity spread after 0.5 s at 4 and at 32 substeps per frame agree within 15 % (on the old white
    noise per step it was √8 ≈ 2.8 apart)."""
    import newton

    from physomni_usd.physics.stability import StepPlan
    from physomni_usd.physics.stepping import Stepper, run_frames, xpbd_solver

    def spread(substeps):
        builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=(0.0, 0.0, 0.0))
        for i in range(300):
            builder.add_particle((0.1 * (i % 20), 0.1 * (i // 20), 1.0), (0.0, 0.0, 0.0), mass=0.01, radius=0.005)
        model = builder.finalize(device="cpu")
        stepper = Stepper(model, xpbd_solver(model, 1), fields=FieldSet([ForceField("noise", strength=20.0, seed=3)]))
        run_frames(stepper, StepPlan(30.0, substeps), 15)
        return float(stepper.state.particle_qd.numpy().std())

    coarse, fine = spread(4), spread(32)
    assert coarse > 0.1 and fine > 0.1
    assert 1 / 1.15 < coarse / fine < 1.15, (coarse, fine)


@pytest.mark.parametrize("field", [None, ForceField("constant", strength=30.0, direction=(1.0, 0.0, 0.0), start_time=0.1)],
                         ids=["still", "wind"])
def test_simulate_captured_as_graphs_steps_as_launched(tmp_path, monkeypatch, field):
    """Two boxes dropped (one onto the other), with and without a wind starting mid-run: ``simulate``
    with its frames replayed from captured graphs ends where the launch-by-launch run does, and the
    guard counts the same work."""
    from physomni_usd.physics import runner

    def run(folder, capture):
        monkeypatch.setattr(runner, "CAPTURE", capture)
        a, b = trimesh.creation.box((0.2, 0.2, 0.2)), trimesh.creation.box((0.1, 0.1, 0.1))
        a.apply_translation((0.0, 0.0, 0.3))
        b.apply_translation((0.02, 0.0, 0.6))
        objs = [BenchObject("a", a, "rigid", {"density": 500.0}), BenchObject("b", b, "rigid", {"density": 500.0})]
        shot = write_bench_shot(folder, objs, forces=(field,) if field else ())
        report = simulate_shot(shot, SimulateSettings(seconds=0.5))
        stage = layers.open_shot(shot)
        pos = [UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/Objects/{n}")).ComputeLocalToWorldTransform(f)
               .ExtractTranslation() for n in "ab" for f in range(report["frames"])]
        return report, np.array(pos)

    (tmp_path / "g").mkdir(), (tmp_path / "l").mkdir()
    graph, p_graph = run(tmp_path / "g", True)
    launched, p_launched = run(tmp_path / "l", False)
    assert graph["captured_step"]["frames_replayed"] > 0 and graph["captured_step"]["error"] is None
    assert launched["captured_step"]["frames_replayed"] == 0
    assert np.ptp(p_launched[:, 2]) > 0.1  # they fell
    np.testing.assert_allclose(p_graph, p_launched, atol=1e-4)
    assert graph["guard"]["work_j"] == pytest.approx(launched["guard"]["work_j"], rel=1e-4, abs=1e-6)
    if field:
        assert graph["guard"]["work_j"] > 0.1
