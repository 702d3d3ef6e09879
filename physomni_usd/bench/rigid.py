"""The rigid reference cases of ``bench physics``, each with an exact answer, and the harness that steps
them on one of Newton's rigid solvers.

Cases and their references:

- free fall: z(t) = z₀ − ½·g·t² (Galileo; any mechanics text);
- linear drag projectile: x(t) = x₀ + v₀ₓ(1 − e^{−kt})/k, z(t) = z₀ + (v₀z + g/k)(1 − e^{−kt})/k − g·t/k
  (Taylor, *Classical Mechanics*, 2005, §2.2–2.4);
- quadratic drag fall: z(t) = z₀ − ln(cosh(t·√(g·c)))/c (Taylor 2005, §2.4);
- friction on an incline: a block on a plane tilted by θ slides with a = g(sin θ − μ cos θ) when
  tan θ > μ and sticks otherwise (Coulomb; the plane is tilted by tilting gravity);
- restitution: a sphere dropped from h rises to e²·h after its first bounce;
- resting stack: five boxes stacked must not drift; error = largest drift / box size;
- free rotation: a free box spinning about a non-principal axis keeps its angular momentum
  (Euler's equations); error = |ΔL| / |L₀|.

Rigid solvers compared: XPBD, MuJoCo (its own CPU engine, where ``mujoco`` and ``mujoco-warp`` are
installed: the ``bench`` extra), Featherstone and semi-implicit (penalty contacts, ke = 1e6, kd = 1e4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..physics.stability import DEFAULT_ITERATIONS, StepPlan, contact_reuse
from ..physics.stepping import Stepper, contact_pipeline, run_frames, xpbd_solver

G = 9.81
FPS = 30
SOLVERS = ("xpbd", "mujoco", "featherstone", "semi_implicit")
TARGET = 0.01


@dataclass
class Case:
    name: str
    run: Callable  # (solver, substeps) -> error
    seconds: float  # simulated
    target: float = TARGET
    contact: bool = False


def _solver(name, model):
    import newton

    if name == "xpbd":  # the simulator's own
        return xpbd_solver(model, DEFAULT_ITERATIONS)
    if name == "mujoco":  # MuJoCo's own CPU engine and contacts, through Newton
        return newton.solvers.SolverMuJoCo(model, use_mujoco_cpu=True)
    if name == "featherstone":
        return newton.solvers.SolverFeatherstone(model)
    if name == "semi_implicit":
        return newton.solvers.SolverSemiImplicit(model)
    raise ValueError(name)


def _builder(gravity=(0.0, 0.0, -G), penalty=False):
    import newton

    b = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=tuple(gravity))
    if penalty:  # penalty solvers need stiff contacts (Newton's defaults let boxes sink)
        b.default_shape_cfg.ke, b.default_shape_cfg.kd = 1e6, 1e4
    return b


def _simulate(model, solver_name, substeps, seconds, contacts=False, forces=None, record=None, thinnest=None):
    """Step ``model`` for ``seconds`` through the simulator's stepper; XPBD on the simulator's schedule
    (contacts reused within a frame while the speeds allow, ``thinnest`` m the thinnest collider), the
    other solvers searching contacts every substep. Returns the final state and the stepping seconds."""
    solver = _solver(solver_name, model)
    # MuJoCo finds its own contacts
    pipe, found = contact_pipeline(model) if contacts and solver_name != "mujoco" else (None, None)
    stepper = Stepper(model, solver, pipeline=pipe, contacts=found, fields=forces)
    a = stepper.state
    if solver_name in ("featherstone", "mujoco") and a.joint_qd is not None and model.body_count:
        # these integrate joint coordinates: every body here hangs on a free joint whose
        # velocity coordinates are the body's (linear, angular) velocity
        a.joint_qd.assign(a.body_qd.numpy().ravel())
    if solver_name == "xpbd":
        plan = StepPlan(FPS, substeps, iterations=DEFAULT_ITERATIONS, collide_every=contact_reuse(substeps),
                        thinnest=thinnest, acceleration=G)
    else:
        plan = StepPlan(FPS, substeps)
    after = (lambda f: record.append(stepper.state.body_q.numpy().copy())) if record is not None else None
    sec = run_frames(stepper, plan, int(round(seconds * FPS)), after_frame=after)
    return stepper.state, sec


def _body(b, pos, kind="sphere", size=0.1, mass_density=1000.0, velocity=None, spin=None):
    import warp as wp

    body = b.add_body(xform=wp.transform(tuple(pos), wp.quat_identity()))
    cfg = b.default_shape_cfg.copy()
    cfg.density = mass_density
    if kind == "sphere":
        b.add_shape_sphere(body, radius=size, cfg=cfg)
    else:
        hx, hy, hz = size if isinstance(size, tuple) else (size, size, size)
        b.add_shape_box(body, hx=hx, hy=hy, hz=hz, cfg=cfg)
    if velocity is not None or spin is not None:
        v = velocity or (0.0, 0.0, 0.0)
        w = spin or (0.0, 0.0, 0.0)
        b.body_qd[body] = wp.spatial_vector(*v, *w)
    return body


def free_fall(solver, substeps):
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 2.0))
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, 0.5)
    exact = 0.5 * G * 0.5 ** 2
    return abs((2.0 - state.body_q.numpy()[0, 2]) - exact) / exact, sec


def linear_drag(solver, substeps):
    from ..fields import ForceField
    from ..physics.forces import FieldSet

    k, v0, t = 1.5, np.array([3.0, 0.0, 4.0]), 1.0
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 0), velocity=tuple(v0))
    model = b.finalize(device="cpu")
    fields = FieldSet([ForceField("drag", linear_drag=k)])
    fields.set_body_samples(np.zeros((1, 1, 3)))
    state, sec = _simulate(model, solver, substeps, t, forces=fields)
    e = 1 - math.exp(-k * t)
    exact = np.array([v0[0] * e / k, 0.0, (v0[2] + G / k) * e / k - G * t / k])
    return float(np.linalg.norm(state.body_q.numpy()[0, :3] - exact) / np.linalg.norm(exact)), sec


def quadratic_drag(solver, substeps):
    from ..fields import ForceField
    from ..physics.forces import FieldSet

    c, t = 0.2, 1.5
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 0))
    model = b.finalize(device="cpu")
    fields = FieldSet([ForceField("drag", quadratic_drag=c)])
    fields.set_body_samples(np.zeros((1, 1, 3)))
    state, sec = _simulate(model, solver, substeps, t, forces=fields)
    exact = math.log(math.cosh(t * math.sqrt(G * c))) / c
    return abs(-state.body_q.numpy()[0, 2] - exact) / exact, sec


def incline(solver, substeps, theta_deg=30.0, mu=0.3):
    """Slide down a 30° incline with μ = 0.3 (gravity tilted instead of the plane)."""
    th = math.radians(theta_deg)
    b = _builder(gravity=(G * math.sin(th), 0.0, -G * math.cos(th)), penalty=solver != "xpbd")
    b.default_shape_cfg.mu = mu
    b.add_ground_plane(cfg=b.default_shape_cfg.copy())
    _body(b, (0, 0, 0.1), kind="box", size=0.1)
    t = 1.0
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, t, contacts=True, thinnest=0.2)
    exact = 0.5 * G * (math.sin(th) - mu * math.cos(th)) * t * t
    return abs(state.body_q.numpy()[0, 0] - exact) / exact, sec


def restitution(solver, substeps, e=0.6, h=1.0):
    b = _builder(penalty=solver != "xpbd")
    b.default_shape_cfg.restitution = e
    b.add_ground_plane(cfg=b.default_shape_cfg.copy())
    _body(b, (0, 0, h + 0.1))
    record = []
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, 1.4, contacts=True, record=record,
                           thinnest=0.2)
    z = np.array([q[0, 2] for q in record]) - 0.1
    after = z[int(math.sqrt(2 * h / G) * FPS) + 2:]
    apex = float(after.max()) if len(after) else 0.0
    return abs(apex - e * e * h) / (e * e * h), sec


def resting_stack(solver, substeps, seconds=3.0):
    b = _builder(penalty=solver != "xpbd")
    b.add_ground_plane()
    size = 0.1
    for i in range(5):
        _body(b, (0, 0, size + 2 * size * i + 1e-4), kind="box", size=size)
    model = b.finalize(device="cpu")
    start = model.state().body_q.numpy()[:, :3].copy()
    state, sec = _simulate(model, solver, substeps, seconds, contacts=True, thinnest=2 * size)
    drift = np.linalg.norm(state.body_q.numpy()[:, :3] - start, axis=1).max()
    return float(drift / (2 * size)), sec


def free_rotation(solver, substeps):
    from scipy.spatial.transform import Rotation

    b = _builder(gravity=(0, 0, 0), penalty=solver != "xpbd")
    _body(b, (0, 0, 0), kind="box", size=(0.3, 0.2, 0.1), spin=(0.1, 5.0, 0.1))
    model = b.finalize(device="cpu")
    inertia = model.body_inertia.numpy()[0]
    s0 = model.state()
    w0 = s0.body_qd.numpy()[0, 3:]
    l0 = inertia @ w0  # identity orientation: body and world frames agree
    state, sec = _simulate(model, solver, substeps, 2.0)
    q = state.body_q.numpy()[0, 3:]
    r = Rotation.from_quat(q).as_matrix()
    w = state.body_qd.numpy()[0, 3:]
    l1 = r @ inertia @ r.T @ w
    return float(np.linalg.norm(l1 - l0) / np.linalg.norm(l0)), sec


CASES = [Case("free_fall", free_fall, 0.5), Case("linear_drag", linear_drag, 1.0),
         Case("quadratic_drag", quadratic_drag, 1.5), Case("incline_friction", incline, 1.0, contact=True),
         Case("restitution", restitution, 1.4, contact=True), Case("resting_stack", resting_stack, 3.0, contact=True),
         Case("free_rotation", free_rotation, 2.0)]


def rigid_solvers() -> tuple[str, ...]:
    """The rigid solvers this machine can run: MuJoCo only where its Python packages are installed."""
    import importlib.util

    have_mujoco = all(importlib.util.find_spec(m) for m in ("mujoco", "mujoco_warp"))
    return tuple(s for s in SOLVERS if s != "mujoco" or have_mujoco)
