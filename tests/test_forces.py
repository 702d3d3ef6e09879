"""Each force kind against independent references: the formulas of the force-field table written
again in NumPy (turbulence's Perlin noise included), checked against the warp kernels point by point,
and a lone rigid body and a lone particle under the field alone against the NumPy field's integral
(SciPy's adaptive RK45 at tight tolerance). Where a closed form exists, the reference is checked
against it too.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from physomni_usd.fields import KINDS, ForceField, field_from_values
from physomni_usd.physics.forces import POINT_EPSILON, FieldSet, body_samples

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
#: Fields that exercise every term of each formula (radii, falloffs, flow, offsets from the origin).
RICH = {
    "wind": ForceField("wind", strength=-2.5, direction=(1, 1, 0), position=(0.2, -0.1, 0.0), radius=0.6),
    "point": ForceField("point", strength=1.7, position=(0.1, -0.2, 0.3), radius=0.9, falloff=1.5, flow=0.4),
    "drag": ForceField("drag", linear_drag=0.3, quadratic_drag=1.2),
    "vortex": ForceField("vortex", strength=-3.0, direction=(0, 1, 1), position=(0.1, 0.0, -0.2), radius=0.8,
                         falloff=2.0, radial_strength=0.7, inner_radius=0.15, damping=0.25),
    "turbulence": ForceField("turbulence", strength=1.5, frequency=2.7, seed=9, flow=0.6),
}


# --- the field table in NumPy ---------------------------------------------------------------------------
_U32 = np.uint32


def _pcg(state):
    """PCG hash of uint32 values (Jarzynski & Olano 2020), the generator warp's noise draws from."""
    with np.errstate(over="ignore"):
        b = state * _U32(747796405) + _U32(2891336453)
        c = ((b >> ((b >> _U32(28)) + _U32(4))) ^ b) * _U32(277803737)
    return (c >> _U32(22)) ^ c


def _lattice_gradient(state, ix, iy, iz):
    """Unit gradient (…, 3) at integer lattice points: a hash of the corner, three uniform draws in a cube."""
    with np.errstate(over="ignore"):
        idx = (ix.astype(_U32) * _U32(73856093)) ^ (iy.astype(_U32) * _U32(19349663)) \
            ^ (iz.astype(_U32) * _U32(53471161) + state)
    g = []
    for _ in range(3):
        idx = _pcg(idx)
        g.append((idx >> _U32(8)).astype(np.float64) / 16777216.0 - 0.5)
    g = np.stack(g, -1)
    return g / np.linalg.norm(g, axis=-1, keepdims=True)


def perlin(seed: int, p: np.ndarray) -> np.ndarray:
    """3D gradient (Perlin) noise at points (N, 3): the dot of each cell corner's gradient with the offset
    to it, blended by the quintic 6t⁵ − 15t⁴ + 10t³ along x, then y, then z."""
    state = _pcg(np.asarray(seed, _U32))
    cell = np.floor(p)
    f = p - cell
    i0 = cell.astype(np.int64)
    fade = f ** 3 * (f * (f * 6 - 15) + 10)
    out = 0.0
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        g = _lattice_gradient(state, *(i0 + c).T)
        weight = np.prod(np.where(c == 1, fade, 1 - fade), axis=1)
        out = out + weight * np.einsum("ni,ni->n", g, f - c)
    return out


def numpy_field(f: ForceField, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """a(x, v) (N, 3) of one active field, from the table in :mod:`physomni_usd.physics.forces`."""
    x, v = np.atleast_2d(x).astype(float), np.atleast_2d(v).astype(float)
    d = np.asarray(f.direction, float)
    c = np.asarray(f.position, float)
    s = f.strength
    if f.kind == "constant":
        return np.broadcast_to(s * d, x.shape).copy()
    if f.kind == "wind":
        off = x - c
        perp = off - np.outer(off @ d, d)
        inside = (f.radius < 0) | (np.linalg.norm(perp, axis=1) <= f.radius)
        return np.where(inside[:, None], s * d, 0.0)
    if f.kind == "point":
        delta = x - c
        r = np.sqrt((delta ** 2).sum(axis=1) + POINT_EPSILON)
        a0 = s * delta / r[:, None]
        a = (a0 + f.flow * (a0 - v)) / (r[:, None] + 1.0) ** f.falloff
        return np.where(((f.radius < 0) | (r <= f.radius))[:, None], a, 0.0)
    if f.kind == "drag":
        return -f.linear_drag * v - f.quadratic_drag * np.linalg.norm(v, axis=1, keepdims=True) * v
    if f.kind == "vortex":
        off = x - c
        delta = off - np.outer(off @ d, d)
        rho = np.linalg.norm(delta, axis=1)
        g = np.where(rho <= f.inner_radius, 1.0, 1.0 / (np.maximum(rho - f.inner_radius, 0.0) + 1.0) ** f.falloff)
        if f.radius >= 0:
            g = np.where(rho > f.radius, 0.0, g)
        return g[:, None] * (s * np.cross(d, delta) - f.radial_strength * delta) - f.damping * v
    if f.kind == "turbulence":
        p = f.frequency * x
        a0 = s * np.stack([perlin(f.seed + k, p) for k in range(3)], axis=1)
        return a0 + f.flow * (a0 - v)
    raise ValueError(f.kind)


def reference(field: ForceField, x0=START, v0=V0, seconds=SECONDS):
    """Where a point starting at ``x0`` with ``v0`` is after ``seconds`` under the NumPy field alone."""
    def rhs(t, y):
        return np.concatenate([y[3:], numpy_field(field, y[None, :3], y[None, 3:])[0]])

    sol = solve_ivp(rhs, (0, seconds), np.concatenate([x0, v0]), rtol=1e-9, atol=1e-11, method="RK45")
    return sol.y[:3, -1]


@pytest.mark.parametrize("name", sorted(set(FIELDS) | set(RICH)))
def test_kernels_compute_the_formulas(name):
    rng = np.random.default_rng(3)
    x = rng.uniform(-1.2, 1.2, (400, 3))
    v = rng.normal(0.0, 1.5, (400, 3))
    for field in [f for f in (FIELDS.get(name), RICH.get(name)) if f is not None]:
        want = numpy_field(field, x, v)
        got = FieldSet([field]).acceleration(x, v, 0.0)
        assert np.abs(want).max() > 0.1 and (np.abs(want).sum(axis=1) > 1e-3).mean() > 0.2  # the case has content
        assert np.allclose(got, want, rtol=1e-4, atol=1e-5), np.abs(got - want).max()


def test_numpy_perlin_is_gradient_noise():
    """The reference noise itself: zero on the lattice, smooth, bounded, different per seed."""
    rng = np.random.default_rng(0)
    lattice = rng.integers(-5, 5, (50, 3)).astype(float)
    assert np.abs(perlin(4, lattice)).max() < 1e-12
    p = rng.uniform(-3, 3, (2000, 3))
    n = perlin(4, p)
    assert 0.05 < n.std() < 0.5 and np.abs(n).max() < 1.0
    assert np.abs(perlin(4, p + 1e-4) - n).max() < 1e-3 and not np.allclose(perlin(5, p), n)


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


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_of_the_table_has_a_law(kind):
    """A kind added to ``fields.FIELD_KINDS`` without its warp function fails here, not in a user's shot."""
    f = field_from_values(kind, {"drag": {"linear": 0.5}}.get(kind, {}))
    a = FieldSet([f]).acceleration(START[None], V0[None], 0.0)
    assert np.isfinite(a).all() and np.abs(a).sum() > 0


def test_every_reader_of_the_kinds_reads_the_table(tmp_path):
    """The CLI's help, the VLM's prompt, the studio's presets and the schema list every kind of
    ``fields.FIELD_KINDS`` (none keeps a list of its own that a new kind would miss)."""
    from click.testing import CliRunner

    from physomni_usd.cli import main
    from physomni_usd.fields import FIELD_KINDS
    from physomni_usd.materials.vlm import SYSTEM_PROMPT
    from physomni_usd.studio.session import FORCE_PRESETS

    helps = " ".join(CliRunner().invoke(main, [command, "--help"]).output.replace("\n", " ")
                     for command in ("build", "run"))
    schema = (pathlib.Path(__file__).parents[1] / "schemas" / "physomni" / "schema.usda").read_text()
    asked = SYSTEM_PROMPT.split("of types ", 1)[1].split(";", 1)[0].split(", ")  # the VLM's choice of kinds
    assert asked == [k.name for k in FIELD_KINDS if k.suggested]
    for kind in FIELD_KINDS:
        assert kind.name in helps and kind.name in FORCE_PRESETS and f'"{kind.name}"' in schema, kind.name
