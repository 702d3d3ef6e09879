"""Each force kind against its integral: a lone rigid body and a lone particle under the field alone.

The reference trajectory integrates the same field a(x, v, t) (evaluated by
the same kernels) with SciPy's adaptive RK45 at tight tolerance; for the kinds
with a closed form the field itself is checked against it too.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from physomni_usd.physics.forces import FieldSet, ForceField, body_samples

SECONDS = 1.0
FPS, SUBSTEPS = 50, 10
START = np.array([0.6, 0.2, 0.3])
V0 = np.array([0.0, 0.5, 0.0])

FIELDS = {
    "constant": ForceField("constant", strength=2.0, direction=(1, 0, 1)),
    "wind": ForceField("wind", strength=1.5, direction=(0, 1, 0), radius=5.0),
    "point": ForceField("point", strength=-1.0, position=(0, 0, 0)),
    "drag": ForceField("drag", linear_drag=0.8, quadratic_drag=0.5),
    "vortex": ForceField("vortex", strength=2.0, direction=(0, 0, 1), radial_strength=0.5, falloff=1.0),
    "turbulence": ForceField("turbulence", strength=2.0, frequency=1.3, seed=4),
}


def reference(field: ForceField, x0=START, v0=V0, seconds=SECONDS):
    fs = FieldSet([field])

    def rhs(t, y):
        a = fs.acceleration(y[None, :3], y[None, 3:], t)[0]
        return np.concatenate([y[3:], a])

    sol = solve_ivp(rhs, (0, seconds), np.concatenate([x0, v0]), rtol=1e-9, atol=1e-11, method="RK45")
    return sol.y[:3, -1]


def _newton(kind: str):
    import newton
    import warp as wp

    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=(0.0, 0.0, 0.0))
    if kind == "rigid":
        body = builder.add_body(xform=wp.transform(tuple(START), wp.quat_identity()))
        builder.add_shape_box(body, hx=0.005, hy=0.005, hz=0.005)
        builder.body_qd[body] = wp.spatial_vector(*V0, 0.0, 0.0, 0.0)
    else:
        builder.add_particle(tuple(START), tuple(V0), mass=0.01, radius=0.005)
    return newton, builder.finalize(device="cpu")


def simulate(field: ForceField, kind: str):
    newton, model = _newton(kind)
    fs = FieldSet([field])
    if kind == "rigid":
        corners = np.array([[x, y, z] for x in (-0.005, 0.005) for y in (-0.005, 0.005) for z in (-0.005, 0.005)])
        fs.set_body_samples(body_samples([corners]))
        solver = newton.solvers.SolverXPBD(model, iterations=2)
    else:
        solver = newton.solvers.SolverSemiImplicit(model)
    a, b = model.state(), model.state()
    control = model.control()
    dt = 1.0 / (FPS * SUBSTEPS)
    for step in range(int(SECONDS * FPS * SUBSTEPS)):
        a.clear_forces()
        fs.apply(model, a, step * dt, step)
        solver.step(a, b, control, None, dt)
        a, b = b, a
    return (a.body_q.numpy()[0, :3] if kind == "rigid" else a.particle_q.numpy()[0]).astype(float)


@pytest.mark.parametrize("kind", ["rigid", "particle"])
@pytest.mark.parametrize("name", sorted(FIELDS))
def test_lone_body_follows_the_integral(name, kind):
    field = FIELDS[name]
    want = reference(field)
    got = simulate(field, kind)
    travel = np.linalg.norm(want - START)
    assert travel > 0.05, "the case must move the body to mean anything"
    assert np.linalg.norm(got - want) <= 0.01 * travel, (got, want)


def test_closed_forms_of_the_fields():
    t = SECONDS
    # constant: x = x0 + v0 t + a t²/2
    a = 2.0 * np.array([1, 0, 1]) / np.sqrt(2)
    assert np.allclose(reference(FIELDS["constant"]), START + V0 * t + 0.5 * a * t * t, atol=1e-6)
    # linear drag alone: x = x0 + v0 (1 − e^{−k t}) / k
    k = 0.8
    lin = ForceField("drag", linear_drag=k)
    assert np.allclose(reference(lin), START + V0 * (1 - np.exp(-k * t)) / k, atol=1e-6)
    # quadratic drag alone: x = x0 + ln(1 + c |v0| t) / c along v0
    c = 0.5
    quad = ForceField("drag", quadratic_drag=c)
    s = np.linalg.norm(V0)
    assert np.allclose(reference(quad), START + V0 / s * np.log(1 + c * s * t) / c, atol=1e-6)
    # wind outside its radius does nothing
    far = ForceField("wind", strength=3.0, direction=(0, 1, 0), position=(10, 0, 0), radius=1.0)
    assert np.allclose(reference(far), START + V0 * t, atol=1e-9)


def test_point_sign_and_vortex_handedness():
    x = np.array([[1.0, 0.0, 0.0]])
    v = np.zeros((1, 3))
    push = FieldSet([ForceField("point", strength=2.0)]).acceleration(x, v, 0.0)[0]
    assert push[0] > 0  # positive strength pushes away from the centre
    spin = FieldSet([ForceField("vortex", strength=1.0, direction=(0, 0, 1), falloff=0.0)]).acceleration(x, v, 0.0)[0]
    assert spin[1] > 0 and abs(spin[0]) < 1e-9  # counter-clockwise about +Z


def test_start_end_and_enabled():
    f = ForceField("constant", strength=1.0, start_time=0.5, end_time=0.7)
    x, v = np.zeros((1, 3)), np.zeros((1, 3))
    fs = FieldSet([f])
    assert not fs.acceleration(x, v, 0.4).any() and fs.acceleration(x, v, 0.6).any()
    assert not fs.acceleration(x, v, 0.7).any()
    off = FieldSet([ForceField("constant", strength=1.0, enabled=False)])
    assert not off.acceleration(x, v, 0.1).any()


def test_noise_is_seeded_and_zero_mean():
    x = np.zeros((4000, 3))
    a1 = FieldSet([ForceField("noise", strength=1.0, seed=7)]).acceleration(x, x, 0.0, step=3)
    a2 = FieldSet([ForceField("noise", strength=1.0, seed=7)]).acceleration(x, x, 0.0, step=3)
    assert np.array_equal(a1, a2)
    assert np.abs(a1.mean(axis=0)).max() < 0.05 and np.abs(a1).max() <= 1.0


def test_vortex_spins_a_rigid_body():
    import newton
    import warp as wp

    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=(0.0, 0.0, 0.0))
    body = builder.add_body(xform=wp.transform((0.0, 0.0, 0.0), wp.quat_identity()))
    builder.add_shape_box(body, hx=0.2, hy=0.2, hz=0.05)
    model = builder.finalize(device="cpu")
    fs = FieldSet([ForceField("vortex", strength=3.0, direction=(0, 0, 1), falloff=0.0)])
    corners = np.array([[x, y, z] for x in (-0.2, 0.2) for y in (-0.2, 0.2) for z in (-0.05, 0.05)])
    fs.set_body_samples(body_samples([corners]))
    state = model.state()
    state.clear_forces()
    fs.apply(model, state, 0.0, 0)
    wrench = state.body_f.numpy()[0]
    assert np.allclose(wrench[:3], 0.0, atol=1e-6)  # no net force at the axis
    assert wrench[5] > 0  # but a torque about +Z: the field has curl


@pytest.mark.parametrize("kind", ["rigid", "particle"])
def test_noise_moves_bodies_as_a_zero_mean_random_walk(kind):
    """White noise has no deterministic integral: its expectation is no drift, and each body jitters."""
    import newton
    import warp as wp

    n = 64
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=(0.0, 0.0, 0.0))
    for i in range(n):
        p = (i * 0.1, 0.0, 0.0)
        if kind == "rigid":
            b = builder.add_body(xform=wp.transform(p, wp.quat_identity()))
            builder.add_shape_box(b, hx=0.005, hy=0.005, hz=0.005)
        else:
            builder.add_particle(p, (0.0, 0.0, 0.0), mass=0.01, radius=0.005)
    model = builder.finalize(device="cpu")
    fs = FieldSet([ForceField("noise", strength=20.0, seed=11)])
    if kind == "rigid":
        fs.set_body_samples(body_samples([np.zeros((1, 3))] * n))
        solver = newton.solvers.SolverXPBD(model, iterations=1)
    else:
        solver = newton.solvers.SolverSemiImplicit(model)
    a, b = model.state(), model.state()
    start = (a.body_q.numpy()[:, :3] if kind == "rigid" else a.particle_q.numpy()).copy()
    dt = 1.0 / (FPS * SUBSTEPS)
    for step in range(int(SECONDS * FPS * SUBSTEPS)):
        a.clear_forces()
        fs.apply(model, a, step * dt, step)
        solver.step(a, b, model.control(), None, dt)
        a, b = b, a
    end = a.body_q.numpy()[:, :3] if kind == "rigid" else a.particle_q.numpy()
    moved = end - start
    spread = moved.std(axis=0)
    assert (spread > 1e-4).all()  # every axis jitters
    assert (np.abs(moved.mean(axis=0)) < 4 * spread / np.sqrt(n)).all()  # and does not drift
