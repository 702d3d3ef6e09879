"""Material-point objects on Newton's implicit MPM: how each paper material maps onto Newton's
elasto-visco-plastic parameters, particles sampled inside a mesh, two-way contact with the rigid
model, and the surface mesh that follows the particles.

Newton's ``SolverImplicitMPM`` has one constitutive family — elasticity with a Drucker–Prager
yield surface capped by a yield pressure, a deviatoric yield stress, viscosity and hardening — so
every paper material is a choice of those numbers (no warp model of our own was needed):

| paper type | E, ν | friction (DP slope) | yield stress | yield pressure | tensile ratio | hardening | viscosity |
|---|---|---|---|---|---|---|---|
| mpm_elastic, mpm_muscle | E, ν | 0 | ∞ | ∞ | 1 | 0 | 0 |
| mpm_elastoplastic | E, ν | 0 | yield_stress (von Mises) | ∞ | 1 | 0 | 0 |
| mpm_sand | E, ν | tan(friction_angle) | 0 | ∞ | 0 (no cohesion) | 0 | 0 |
| mpm_snow | E, ν | 0.3 | 0 | E·critical_compression | critical_stretch / critical_compression | 10 (Stomakhin et al. 2013, ξ) | 0 |
| mpm_liquid | E, ν | 0 | 0 | ∞ | 0 | 0 | viscosity |
| pbd_liquid | 1e6 Pa, 0.2 | 0 | 0 | ∞ | 0 | 0 | 1e-3 Pa·s (water) |
| pbd_particle | 1e6 Pa, 0.2 | 0.5 | 0 | ∞ | 0 | 0 | 0 |

"∞" is 1e15 Pa, Newton's own "never yields". ``pbd_liquid`` and ``pbd_particle`` run here as
particles too, since Newton has no position-based fluid. Newton's elasticity is corotated
(``MPM_LAW``); a ``model`` of another name (``mpm_muscle``'s neo-Hookean) runs as that, and
``simulate`` says so (:mod:`.params`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..materials.catalog import CATALOG

#: Material types simulated as MPM particles.
MPM_TYPES = ("mpm_elastic", "mpm_elastoplastic", "mpm_sand", "mpm_liquid", "mpm_snow", "mpm_muscle",
             "pbd_liquid", "pbd_particle")
#: Types whose surface persists: the textured mesh is deformed by the particles. The others
#: (sand, liquid, particles) show as particles after the first frame.
SURFACE_TYPES = ("mpm_elastic", "mpm_elastoplastic", "mpm_snow", "mpm_muscle")
NEVER = 1e15
#: The constitutive law of Newton's implicit MPM.
MPM_LAW = "corotated"
#: Particles per grid voxel along each axis (8 per cell), Newton's examples' choice.
PARTICLES_PER_VOXEL = 2
#: Default spacing: the scene's MPM objects hold this many particles per cm³ of them, each counting for no fewer
#: than the least below; one spacing serves them all. Newton's MPM cost grows with the particles and the grid's
#: fineness, and any object may be switched to a particle material: on the desk example with a pencil made
#: ``mpm_elastic`` and the ball ``mpm_sand``, the finest spacing any one object asked for (1,000 particles in
#: the pencil) put 8,955 particles in the ball and took 654 s of stepping for 1 s on a loaded 2-core machine.
PARTICLES_PER_CM3 = 2.0
MIN_OBJECT_PARTICLES = 1000
#: The spacing grows until the whole scene has no more than this many particles.
MAX_PARTICLES = 15_000


def newton_parameters(kind: str, params: dict) -> dict:
    """Newton ``mpm:*`` per-particle values for a paper material (see the module's table)."""
    p = {**CATALOG[kind].defaults, **{k: v for k, v in params.items() if v is not None}}
    e = float(p.get("youngs_modulus", 1e6))
    nu = float(p.get("poissons_ratio", 0.2))
    out = {"young_modulus": e, "poisson_ratio": nu, "friction": 0.0, "yield_stress": NEVER,
           "yield_pressure": NEVER, "tensile_yield_ratio": 1.0, "hardening": 0.0, "viscosity": 0.0}
    if kind == "mpm_elastoplastic":
        out["yield_stress"] = float(p["yield_stress"])
    elif kind in ("mpm_sand", "pbd_particle"):
        angle = float(p.get("friction_angle", math.degrees(math.atan(0.5))))
        out.update(friction=math.tan(math.radians(angle)), yield_stress=0.0, tensile_yield_ratio=0.0)
    elif kind == "mpm_snow":
        out.update(friction=0.3, yield_stress=0.0, yield_pressure=e * float(p["critical_compression"]),
                   tensile_yield_ratio=float(p["critical_stretch"]) / float(p["critical_compression"]),
                   hardening=10.0)
    elif kind in ("mpm_liquid", "pbd_liquid"):
        out.update(yield_stress=0.0, tensile_yield_ratio=0.0,
                   viscosity=float(p.get("viscosity", 1e-3)) if kind == "mpm_liquid" else 1e-3)
    return out


def wave_speed(params: dict, density: float) -> float:
    """P-wave speed √(M/ρ) of an elastic material, m/s (M the constrained modulus)."""
    e, nu = params["young_modulus"], params["poisson_ratio"]
    m = e * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    return math.sqrt(m / max(density, 1e-9))


def choose_spacing(meshes: list, override: float | None = None, max_particles: int = MAX_PARTICLES) -> float:
    """Particle spacing (m) for a set of trimesh meshes: ``override`` if given, else the one that puts in them
    all :data:`PARTICLES_PER_CM3` of each (at least :data:`MIN_OBJECT_PARTICLES` for each), at most
    ``max_particles`` in all, no finer than 1 mm. A thin object may then hold few particles (at least one:
    :func:`sample_inside`)."""
    if override:
        from ..errors import InputError
        from ..settings import MAX_PARTICLES as MOST

        volume = sum(abs(float(m.volume)) if m.is_volume else float(np.prod(m.extents)) for m in meshes)
        count = volume / float(override) ** 3
        if count > MOST:  # refused before a particle is sampled, not after the memory is gone
            raise InputError(f"--particle-spacing {override:g}: the MPM objects would hold about {count:,.0f} "
                             f"particles; at most {MOST:,} (use at least "
                             f"{(volume / MOST) ** (1 / 3):.3g} m)")
        return float(override)
    volumes = [max(abs(float(m.volume)) if m.is_volume else float(np.prod(m.extents)), 1e-12) for m in meshes]
    budget = min(sum(max(MIN_OBJECT_PARTICLES, PARTICLES_PER_CM3 * v * 1e6) for v in volumes), max_particles)
    return max((sum(volumes) / budget) ** (1.0 / 3.0), 1e-3)


def grid_points(lo, hi, spacing: float) -> np.ndarray:
    """Centres (N, 3) of the cubes of side ``spacing`` filling the box from ``lo`` to ``hi`` (m); an axis
    shorter than a cube gets one point at its middle."""
    axes = [np.arange(a + 0.5 * spacing, b, spacing) for a, b in zip(lo, hi)]
    axes = [ax if len(ax) else np.array([(a + b) / 2]) for ax, a, b in zip(axes, lo, hi)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def points_inside(mesh, points: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Which of ``points`` (N, 3) lie inside a trimesh: ray tests for a watertight mesh; for one with
    holes or open edges, its generalised winding number (the solid angle the surface subtends, over 4π;
    Jacobson et al. 2013) above one half, which a hole changes only near the hole."""
    points = np.asarray(points, float)
    if mesh.is_watertight:
        return np.asarray(mesh.contains(points), bool)
    tri = np.asarray(mesh.triangles, float)  # (F, 3, 3)
    w = np.zeros(len(points))
    for i in range(0, len(points), chunk):
        # van Oosterom & Strackee: the solid angle of each triangle seen from each point
        d = tri[None] - points[i:i + chunk, None, None, :]  # (n, F, 3, 3)
        a, b, c = d[..., 0, :], d[..., 1, :], d[..., 2, :]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        num = np.einsum("nfi,nfi->nf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("nfi,nfi->nf", a, b) * lc + np.einsum("nfi,nfi->nf", a, c) * lb
               + np.einsum("nfi,nfi->nf", b, c) * la)
        w[i:i + chunk] = 2.0 * np.arctan2(num, den).sum(axis=1) / (4.0 * np.pi)
    return np.abs(w) > 0.5


def sample_inside(mesh, spacing: float, seed: int = 0) -> np.ndarray:
    """Points (N, 3) on a jittered grid of ``spacing`` inside a trimesh (see :func:`points_inside`);
    at least one point."""
    grid = grid_points(*mesh.bounds, spacing)
    rng = np.random.default_rng(seed)
    grid = grid + rng.uniform(-0.2, 0.2, grid.shape) * spacing
    inside = points_inside(mesh, grid)
    pts = grid[inside]
    return pts if len(pts) else mesh.centroid[None, :].astype(float)


@dataclass
class SurfaceBinding:
    """Each surface vertex follows its ``k`` nearest particles: weights, indices and rest offsets."""
    index: np.ndarray  # (V, k) particle indices (within the object)
    weight: np.ndarray  # (V, k)
    offset: np.ndarray  # (V, k, 3) vertex − particle at rest, world


def bind_surface(vertices: np.ndarray, particles: np.ndarray, k: int = 4) -> SurfaceBinding:
    """Bind world-space surface vertices (V, 3) to rest particles (P, 3) by inverse distance."""
    from scipy.spatial import cKDTree

    k = min(k, len(particles))
    dist, idx = cKDTree(particles).query(vertices, k=k)
    dist, idx = dist.reshape(len(vertices), k), idx.reshape(len(vertices), k)
    w = 1.0 / np.maximum(dist, 1e-6) ** 2
    w /= w.sum(axis=1, keepdims=True)
    return SurfaceBinding(idx, w, vertices[:, None, :] - particles[idx])


def deform_surface(binding: SurfaceBinding, particles: np.ndarray, gradients: np.ndarray | None) -> np.ndarray:
    """Surface vertices (V, 3) from particle positions (P, 3) and deformation gradients (P, 3, 3):
    each particle carries its rest offset through its own gradient; the results are blended."""
    x = particles[binding.index]  # (V, k, 3)
    off = binding.offset
    if gradients is not None:
        off = np.einsum("vkij,vkj->vki", gradients[binding.index], off)
    return np.einsum("vk,vki->vi", binding.weight, x + off)


@dataclass
class MPMObject:
    obj: object  # the SimObject
    start: int
    count: int
    binding: SurfaceBinding | None
    colour: tuple[float, float, float] = (0.6, 0.6, 0.6)


@dataclass
class MPMScene:
    """The MPM half of a shot: its own Newton model and solver, coupled to the rigid model."""
    model: object
    solver: object
    state: object
    objects: list[MPMObject]
    spacing: float
    wave_speed: float
    body_force: object = None  # (bodies,) spatial vectors: the particles' push on each rigid body


@lru_cache(maxsize=1)
def _kernels():
    import warp as wp

    @wp.kernel
    def impulses_to_forces(dt: float, ids: wp.array(dtype=int), impulses: wp.array(dtype=wp.vec3),
                           where: wp.array(dtype=wp.vec3), collider_body: wp.array(dtype=int),
                           body_q: wp.array(dtype=wp.transform), body_com: wp.array(dtype=wp.vec3),
                           out_f: wp.array(dtype=wp.spatial_vector)):
        # the grid's contact impulses on a collider, as a force and torque about the body's centre of mass
        i = wp.tid()
        c = ids[i]
        if c < 0 or c >= collider_body.shape[0]:
            return
        b = collider_body[c]
        if b < 0:
            return
        f = impulses[i] / dt
        r = where[i] - wp.transform_point(body_q[b], body_com[b])
        wp.atomic_add(out_f, b, wp.spatial_vector(f, wp.cross(r, f)))

    @wp.kernel
    def add_forces(extra: wp.array(dtype=wp.spatial_vector), body_f: wp.array(dtype=wp.spatial_vector)):
        i = wp.tid()
        body_f[i] = body_f[i] + extra[i]

    @wp.kernel
    def velocity_before_contact(dt: float, body_q: wp.array(dtype=wp.transform),
                                body_qd: wp.array(dtype=wp.spatial_vector),
                                force: wp.array(dtype=wp.spatial_vector), inv_mass: wp.array(dtype=float),
                                inv_inertia: wp.array(dtype=wp.mat33), out_q: wp.array(dtype=wp.transform),
                                out_qd: wp.array(dtype=wp.spatial_vector)):
        # the grid solves contact against the body's velocity without the particles' last push,
        # otherwise that push would be counted twice
        b = wp.tid()
        f = force[b]
        rot = wp.transform_get_rotation(body_q[b])
        dv = dt * inv_mass[b] * wp.spatial_top(f)
        dw = dt * wp.quat_rotate(rot, inv_inertia[b] * wp.quat_rotate_inv(rot, wp.spatial_bottom(f)))
        out_q[b] = body_q[b]
        out_qd[b] = body_qd[b] - wp.spatial_vector(dv, dw)

    return impulses_to_forces, add_forces, velocity_before_contact


def solver_options(kinds) -> dict:
    """Rheology solve settings for a set of material types. Elastic solids need a converged solve:
    at Newton's looser defaults (50 iterations, 1e-4) the unconverged strain relaxes and a clamped bar
    creeps down instead of oscillating (measured on the elastic-bar bench)."""
    if any(k in SURFACE_TYPES for k in kinds):
        return {"max_iterations": 250, "tolerance": 1e-6}
    return {}


def particle_solver(points: np.ndarray, masses: np.ndarray, values: list, spacing: float, rigid_model, device,
                    max_iterations: int = 50, **config):
    """A Newton particle model, its implicit MPM solver and a state: ``points`` (P, 3) world, ``masses``
    (P,) kg (0 = held in place), ``values`` a list of (count, :func:`newton_parameters` dict) covering the
    points in order; the grid's voxel is ``PARTICLES_PER_VOXEL`` spacings; every particle-colliding shape
    of ``rigid_model`` is a collider."""
    import warp as wp

    from .._warp import load_newton, newton_solver

    newton, SolverImplicitMPM = load_newton(), newton_solver("SolverImplicitMPM")
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    SolverImplicitMPM.register_custom_attributes(builder)
    for p, m in zip(points, masses):
        builder.add_particle(tuple(map(float, p)), (0.0, 0.0, 0.0), mass=float(m), radius=0.5 * spacing)
    model = builder.finalize(device=device)
    start = 0
    for count, v in values:
        for key, value in v.items():
            getattr(model.mpm, key)[start:start + count].fill_(float(value))
        start += count
    cfg = SolverImplicitMPM.Config()
    cfg.voxel_size = PARTICLES_PER_VOXEL * spacing
    cfg.max_iterations = max_iterations
    cfg.tolerance = 1e-4
    for key, value in config.items():
        setattr(cfg, key, value)
    solver = SolverImplicitMPM(model, config=cfg)
    setup_colliders(solver, rigid_model)
    state = model.state()
    if rigid_model.body_count:
        rigid_state = rigid_model.state()
        state.body_q = wp.clone(rigid_state.body_q)
        state.body_qd = wp.clone(rigid_state.body_qd)
        state.body_f = wp.zeros_like(rigid_state.body_f)
    else:  # only static colliders: the solver still reads (empty) body arrays
        state.body_q = wp.zeros(0, dtype=wp.transform, device=model.device)
        state.body_qd = wp.zeros(0, dtype=wp.spatial_vector, device=model.device)
        state.body_f = wp.zeros(0, dtype=wp.spatial_vector, device=model.device)
    return model, solver, state


def build_mpm_scene(objects: list, rigid_model, device, spacing: float | None = None) -> MPMScene:
    """Particles for each :class:`~.objects.SimObject` of the MPM family, a particle model with
    per-particle materials, and a solver whose colliders are the rigid model's shapes (ground included)."""
    import warp as wp

    meshes = [o.trimesh() for o in objects]
    h = choose_spacing(meshes, spacing)
    out, points, masses, values = [], [], [], []
    c_max, start = 0.0, 0
    for n, (obj, mesh) in enumerate(zip(objects, meshes)):
        pts = sample_inside(mesh, h, seed=n)
        density = float(obj.params.get("density") or 1000.0)
        v = newton_parameters(obj.kind, obj.params)
        c_max = max(c_max, wave_speed(v, density))
        points.append(pts)
        masses.append(np.full(len(pts), 0.0 if obj.fixed else density * h ** 3))
        values.append((len(pts), v))
        binding = bind_surface(obj.points, pts) if obj.kind in SURFACE_TYPES else None
        out.append(MPMObject(obj, start, len(pts), binding, texture_colour(obj.prim)))
        start += len(pts)
    model, solver, state = particle_solver(np.concatenate(points), np.concatenate(masses), values, h,
                                           rigid_model, device, **solver_options([o.kind for o in objects]))
    scene = MPMScene(model, solver, state, out, h, c_max)
    scene.body_force = wp.zeros(max(rigid_model.body_count, 1), dtype=wp.spatial_vector, device=model.device)
    return scene


def setup_colliders(solver, rigid_model) -> None:
    """Make every particle-colliding shape of the rigid model (ground, bodies) a collider of the MPM grid.

    Newton's MPM collider turns primitives and triangle meshes into colliders but refuses convex hulls
    — which is what our objects are. A hull's source is a triangle mesh, so for the duration of the
    call the hulls are presented as meshes; the rigid solver's own shape types are restored after."""
    from .._warp import load_newton

    newton = load_newton()
    types = rigid_model.shape_type.numpy()
    hulls = types == int(newton.GeoType.CONVEX_MESH)
    if hulls.any():
        as_mesh = types.copy()
        as_mesh[hulls] = int(newton.GeoType.MESH)
        rigid_model.shape_type.assign(as_mesh)
    try:
        solver.setup_collider(model=rigid_model)
    finally:
        if hulls.any():
            rigid_model.shape_type.assign(types)


def add_particle_forces(scene: MPMScene, rigid_state) -> None:
    """Add the particles' last contact forces to the rigid bodies' ``body_f`` (call each rigid substep)."""
    import warp as wp

    n = rigid_state.body_f.shape[0] if rigid_state.body_f is not None else 0
    if n:
        wp.launch(_kernels()[1], dim=n, inputs=[scene.body_force], outputs=[rigid_state.body_f],
                  device=scene.model.device)


def step_particles(scene: MPMScene, rigid_model, rigid_state, dt: float) -> None:
    """One MPM step of ``dt`` against the rigid bodies' current pose, then turn the grid's contact
    impulses into the forces the bodies feel until the next MPM step."""
    import warp as wp

    to_forces, _, before_contact = _kernels()
    s = scene.state
    n = rigid_model.body_count
    device = scene.model.device
    if n:
        wp.launch(before_contact, dim=n, inputs=[dt, rigid_state.body_q, rigid_state.body_qd, scene.body_force,
                                                 rigid_model.body_inv_mass, rigid_model.body_inv_inertia],
                  outputs=[s.body_q, s.body_qd], device=device)
    scene.solver.step(s, s, None, None, dt)
    # the grid solve keeps particles out of colliders only to within a voxel; put stragglers back outside
    scene.solver.project_outside(s, s, dt)
    if n:
        scene.body_force.zero_()
        impulses, where, ids = scene.solver.collect_collider_impulses(s)
        m = min(impulses.shape[0], where.shape[0], ids.shape[0])
        if m:
            wp.launch(to_forces, dim=m, inputs=[dt, ids, impulses, where, scene.solver.collider_body_index,
                                               rigid_state.body_q, rigid_model.body_com],
                      outputs=[scene.body_force], device=device)


def particle_gradients(scene: MPMScene) -> np.ndarray | None:
    """Per-particle deformation gradients (P, 3, 3) if the solver keeps them."""
    arr = getattr(getattr(scene.state, "mpm", None), "particle_transform", None)
    if arr is None:
        return None
    g = arr.numpy().reshape(-1, 3, 3).astype(np.float64)
    return g if np.isfinite(g).all() else None


def texture_colour(prim) -> tuple[float, float, float]:
    """Mean RGB (0–1, as stored) of the texture of ``prim`` (a Usd.Prim) where it is opaque; grey without one."""
    from ..usd.textures import read_image, texture_file

    path = texture_file(prim)
    if path is None or not path.is_file():
        return (0.6, 0.6, 0.6)
    img = read_image(path, prim.GetName(), rgba=True).astype(np.float64)
    a = img[..., 3] > 127
    if not a.any():
        return (0.6, 0.6, 0.6)
    rgb = img[..., :3][a].mean(axis=0) / 255.0
    return tuple(round(float(c), 4) for c in rgb)
