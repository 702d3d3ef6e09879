"""Reference cases for the deformable solvers, each returning (relative error, wall seconds per
simulated second).

- cloth sag: a 1 m square cloth (XPBD springs with the simulator's own stiffness, damping and
  iterations) pinned along two opposite edges sags like a hammock until it comes to rest; error = its
  resting sag (the lowest point's drop, averaged over the last half of the run) against the same run at
  256 substeps per frame (a convergence check: a spring cloth has no closed form);
- elastic bar: an MPM cantilever (0.5 m × 0.1 m × 0.1 m, E = 5 MPa, ρ = 1000 kg/m³) clamped at one end,
  released straight under gravity; its tip's oscillation frequency (a damped-sinusoid fit) against
  Euler–Bernoulli beam theory, f₁ = (1.8751² / 2π)·√(E·I / (ρ·A·L⁴)) (e.g. Timoshenko, *Vibration
  Problems in Engineering*, 1937). At L/h = 5 shear and rotary inertia, which Euler–Bernoulli leaves
  out, lower the true frequency by about 3 % (a Timoshenko beam gives 4.43 Hz against 4.57 Hz), so the
  1 % target holds the simulation to the textbook formula rather than to the bar's exact frequency;
  slenderer bars, where the two agree, need more particles through the thickness than a CPU run affords;
- dam break: a water column of width a and height 2a against a wall collapses; its front position
  Z = x/a against the time T = t·√(2g/a) measured by Martin & Moyce (1952), *Phil. Trans. R. Soc. A*
  244:312–324 (the n² = 2 series, digitised);
- granular column: a sand column of aspect ratio a = h₀/L₀ = 1 against a wall spreads to a run-out
  (L∞ − L₀)/L₀ = 1.2·a, the planar scaling of Lube et al. (2005), *Phys. Rev. E* 72:041301 (a ≲ 1.8);
  Lajeunesse et al. (2005) found the same 1.2·a for quasi-2D columns.

The dam break and the column are quasi-two-dimensional: the material sits between two side walls.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.mpm import grid_points

G = 9.81
FPS = 30
#: Martin & Moyce (1952), n² = 2: (T, Z) pairs.
MARTIN_MOYCE = ((0.41, 1.11), (0.84, 1.22), (1.19, 1.44), (1.43, 1.67), (1.63, 1.89), (1.83, 2.11),
                (1.98, 2.33), (2.20, 2.56), (2.32, 2.78), (2.51, 3.00), (2.65, 3.22), (2.83, 3.44))


#: Substeps per frame of the cloth reference run. The cloth hangs around the origin: XPBD recomputes
#: velocities from float32 position differences, and far from the origin a fine step's fall
#: (g·dt² ≈ 1e-7 m) drowns in rounding, so that a cloth 1.5 m up stopped sagging beyond ~128 substeps.
CLOTH_REFERENCE = 256
#: The bench cloth: particles per side, mass per particle (kg), simulated seconds. √(m/k) with the
#: simulator's spring stiffness is the time scale its step rule (``stability.CLOTH_FACTOR``) scales.
CLOTH_GRID = 16
CLOTH_PARTICLE_MASS = 0.01
CLOTH_SECONDS = 8.0


def cloth_sag(substeps: int, seconds: float = CLOTH_SECONDS, reference_substeps: int = CLOTH_REFERENCE,
              reference: dict = {}) -> tuple[float, float]:  # noqa: B006 - a cache on purpose
    key = (reference_substeps, seconds)
    if key not in reference:
        reference[key] = _cloth(reference_substeps, seconds)[0]
    sag, sec = _cloth(substeps, seconds)
    exact = reference[key]
    return (abs(sag - exact) / exact if math.isfinite(sag) else float("inf")), sec / seconds


def cloth_time_scale() -> float:
    """√(m/k) of the bench cloth (s): a step of ``factor`` times this is what the simulator's cloth rule
    allows, so the recommended substeps translate into that rule's factor."""
    from ..physics.cloth import CLOTH_SPRING_KE

    return math.sqrt(CLOTH_PARTICLE_MASS / CLOTH_SPRING_KE[1])


def _cloth(substeps: int, seconds: float = CLOTH_SECONDS) -> tuple[float, float]:
    """(resting sag in m, wall seconds) of the hammock at ``substeps`` per frame."""
    import newton
    import warp as wp

    from ..physics.cloth import CLOTH_BEND_KE, CLOTH_SPRING_KD, CLOTH_SPRING_KE
    from ..physics.stability import DEFAULT_ITERATIONS, StepPlan
    from ..physics.stepping import Stepper, run_frames, xpbd_solver

    n = CLOTH_GRID
    b = newton.ModelBuilder(up_axis=newton.Axis.Z)
    # the stiffest cloth the simulator makes (the paper's default compliance clamps to it)
    b.add_cloth_grid(pos=wp.vec3(-0.5, -0.5, 0.0), rot=wp.quat_identity(), vel=wp.vec3(0.0, 0.0, 0.0), dim_x=n, dim_y=n,
                     cell_x=1.0 / n, cell_y=1.0 / n, mass=CLOTH_PARTICLE_MASS, fix_left=True, fix_right=True,
                     add_springs=True, spring_ke=CLOTH_SPRING_KE[1], spring_kd=CLOTH_SPRING_KD,
                     edge_ke=CLOTH_BEND_KE[0])
    model = b.finalize(device="cpu")
    model.particle_max_radius = 0.0
    model.particle_grid = None
    stepper = Stepper(model, xpbd_solver(model, DEFAULT_ITERATIONS))
    frames = int(round(seconds * FPS))
    sags = []
    sec = run_frames(stepper, StepPlan(FPS, substeps, iterations=DEFAULT_ITERATIONS), frames,
                     after_frame=lambda f: sags.append(-float(stepper.state.particle_q.numpy()[:, 2].min())))
    rest = np.array(sags[frames // 2:])
    return (float(rest.mean()) if np.isfinite(rest).all() else float("inf")), sec


def _static_scene(walls=(), floor_friction: float = 0.5):
    """A rigid model holding a floor and frictionless static boxes ((centre, half extents), …)."""
    import newton
    import warp as wp

    b = newton.ModelBuilder(up_axis=newton.Axis.Z)
    b.default_shape_cfg.mu = floor_friction
    # a closed slab rather than a ground plane: Newton merges static colliders into one mesh, and an
    # open plane among closed boxes confuses the inside/outside test near the walls
    b.add_shape_box(-1, xform=wp.transform((0.0, 0.0, -0.25), wp.quat_identity()), hx=5.0, hy=5.0, hz=0.25)
    smooth = b.default_shape_cfg.copy()
    smooth.mu = 0.0
    for centre, half in walls:
        b.add_shape_box(-1, xform=wp.transform(tuple(centre), wp.quat_identity()), hx=half[0], hy=half[1],
                        hz=half[2], cfg=smooth)
    return b.finalize(device="cpu")


def _run_particles(points, masses, kind, params, spacing, rigid, seconds, steps_per_frame, record) -> float:
    """Step an MPM block of one material for ``seconds`` through the simulator's stepper, handing (time,
    positions) to ``record`` after each step; returns wall seconds per simulated second."""
    from ..physics.mpm import MPMScene, newton_parameters, particle_solver, solver_options
    from ..physics.stability import StepPlan
    from ..physics.stepping import Stepper, run_frames

    values = [(len(points), newton_parameters(kind, params))]
    model, solver, state = particle_solver(points, masses, values, spacing, rigid, "cpu", **solver_options([kind]))
    scene = MPMScene(model, solver, state, [], spacing, 0.0)
    stepper = Stepper(rigid, mpm=scene)
    plan = StepPlan(FPS, steps_per_frame, steps_per_frame)
    frames = math.ceil(seconds * FPS - 1e-9)  # whole frames, covering ``seconds``
    sec = run_frames(stepper, plan, frames, after_mpm_step=lambda t: record(t, scene.state.particle_q.numpy()))
    return sec / (frames / FPS)


def elastic_bar(steps_per_frame: int, spacing: float = 0.025, seconds: float = 1.0) -> tuple[float, float]:
    L, h, e, rho = 0.5, 0.1, 5e6, 1000.0
    pts = grid_points((-2 * spacing, -h / 2, 0.5), (L, h / 2, 0.5 + h), spacing)
    clamp = pts[:, 0] < 0.0
    masses = np.where(clamp, 0.0, rho * spacing ** 3)
    tip = pts[:, 0] > L - 1.01 * spacing
    trace = []
    cost = _run_particles(pts, masses, "mpm_elastic", {"youngs_modulus": e, "poissons_ratio": 0.3, "density": rho},
                         spacing, _static_scene(), seconds, steps_per_frame,
                         lambda t, q: trace.append((t, float(q[tip, 2].mean()))))
    exact = 1.8751 ** 2 / (2 * math.pi) * math.sqrt(e * h ** 2 / 12 / (rho * L ** 4))
    f = _frequency(np.array(trace))
    return (abs(f - exact) / exact if math.isfinite(f) else float("inf")), cost


def _frequency(trace: np.ndarray) -> float:
    """Frequency (Hz) of a damped oscillation sampled as (t, z) rows: a least-squares fit of
    c + e^(−λt)·(a·cos ωt + b·sin ωt), started from the signal's mean crossings. Counting crossings of
    the mean alone is biased when the swing decays about a centre the mean misses (a released bar
    sags onto its static deflection): on the elastic bar that read 1.3 % low."""
    from scipy.optimize import least_squares

    t, z = trace[:, 0], trace[:, 1]
    centred = z - z.mean()
    ups = np.nonzero((centred[:-1] < 0) & (centred[1:] >= 0))[0]
    if len(ups) < 2 or not np.isfinite(z).all():
        return float("nan")
    times = t[ups] - centred[ups] * (t[ups + 1] - t[ups]) / (centred[ups + 1] - centred[ups])
    omega = 2 * math.pi * (len(times) - 1) / (times[-1] - times[0])

    def residual(p):
        c, a, b, decay, w = p
        return c + np.exp(-decay * t) * (a * np.cos(w * t) + b * np.sin(w * t)) - z

    fit = least_squares(residual, [z.mean(), z[0] - z.mean(), 0.0, 0.0, omega])
    return float(abs(fit.x[4]) / (2 * math.pi)) if fit.success else float("nan")


def _channel(depth):
    wall = 0.05  # thicker than a grid voxel, or particles leak through
    return [((-wall, 0.0, 0.5), (wall, 0.5, 0.5)),  # back wall, its face at x = 0
            ((1.0, depth / 2 + wall, 0.5), (1.2, wall, 0.5)), ((1.0, -depth / 2 - wall, 0.5), (1.2, wall, 0.5))]


def dam_break(steps_per_frame: int, spacing: float = 0.01, a: float = 0.1) -> tuple[float, float]:
    depth = 0.05
    pts = grid_points((0.0, -depth / 2, 0.0), (a, depth / 2, 2 * a), spacing)
    masses = np.full(len(pts), 1000.0 * spacing ** 3)
    t_end = MARTIN_MOYCE[-1][0] / math.sqrt(2 * G / a)
    front = []
    # Martin & Moyce's channel was smooth: the water slides on the floor
    cost = _run_particles(pts, masses, "mpm_liquid", {"viscosity": 1e-3}, spacing,
                         _static_scene(_channel(depth), floor_friction=0.0),
                         t_end, steps_per_frame, lambda t, q: front.append((t, float(np.percentile(q[:, 0], 99.5)))))
    front = np.array(front)
    errors = []
    for big_t, z in MARTIN_MOYCE:
        x = np.interp(big_t / math.sqrt(2 * G / a), front[:, 0], front[:, 1])
        errors.append(abs(x / a - z) / z)
    return float(np.mean(errors)), cost


def granular_column(steps_per_frame: int, spacing: float = 0.01, length: float = 0.1,
                    aspect: float = 1.0) -> tuple[float, float]:
    depth = 0.05
    pts = grid_points((0.0, -depth / 2, 0.0), (length, depth / 2, aspect * length), spacing)
    masses = np.full(len(pts), 1600.0 * spacing ** 3)
    last = {}
    cost = _run_particles(pts, masses, "mpm_sand", {"friction_angle": 30.0}, spacing, _static_scene(_channel(depth)),
                         1.0, steps_per_frame, lambda t, q: last.update(q=q))
    run_out = (float(np.percentile(last["q"][:, 0], 99.5)) - length) / length
    exact = 1.2 * aspect
    return abs(run_out - exact) / exact, cost
