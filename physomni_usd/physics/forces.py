"""Force fields evaluated by warp kernels; the fields as data, their checks and their reading from USD prims with ``PhysOmniForceFieldAPI`` are :mod:`physomni_usd.fields`.

Every field is an acceleration a(x, v, t) in m/s², x the world position and v
the velocity of the point it acts on. It acts from ``startTime`` until
``endTime`` (seconds; negative = never ends) while ``enabled``. The field's
``position`` and ``direction`` are in its prim's space, so moving the prim in a
DCC tool moves the field. Gravity is not a field: it lives on the physics
scene, so a ``constant`` field always comes on top of it.

| kind | a(x, v) with d̂ the unit direction, s the strength, c the position |
|---|---|
| constant | s·d̂ |
| wind | s·d̂ within ``radius`` of the axis through c along d̂ (everywhere if radius < 0) |
| point | δ = x − c, r = √(‖δ‖² + ε), a₀ = s·δ/r; a = (a₀ + flow·(a₀ − v)) / (r + 1)^falloff; zero beyond ``radius``. **s > 0 pushes away from c, s < 0 pulls towards it.** |
| drag | −linearDrag·v − quadraticDrag·‖v‖·v |
| vortex | δ = offset of x from the axis through c along d̂, ρ = ‖δ‖; g = 1 for ρ ≤ innerRadius, 1/(ρ − innerRadius + 1)^falloff beyond, 0 beyond ``radius``; a = g·(s·d̂×δ − radialStrength·δ) − damping·v (spins counter-clockwise about d̂ for s > 0) |
| turbulence | a₀ = s·(P₀, P₁, P₂)(frequency·x), three seeded Perlin fields; a = a₀ + flow·(a₀ − v) |
| noise | s·√(τ/dt)·U[−1, 1]³, a new draw at every step (seeded), τ = ``NOISE_TIME``: white noise whose velocity kicks add up as a random walk of variance s²·τ·t/3 per axis whatever the step dt |

Names follow Omniverse's force-field schemas where they share a concept
(``enabled``, ``position``, ``direction``, ``radius``/range, ``linear``/``quadratic``
drag). Rigid bodies receive the field at sample points spread over their
collision shape: force = Σ mᵢ·a(xᵢ) and torque = Σ (xᵢ − x_com) × mᵢ·a(xᵢ), so a
field with curl (a vortex) also spins what it carries; particles receive m·a(x).
"""


from functools import lru_cache

import numpy as np

from .._warp import load_warp
from ..fields import KINDS, ForceField

#: Softening of the point field's distance, m² (keeps a at the centre finite).
POINT_EPSILON = 1e-4
#: The step (s) at which a noise field's draws are s·U[−1, 1]³; at a step dt they are scaled by √(τ/dt),
#: so that the velocity they give, a sum of independent kicks, spreads the same whatever the step.
NOISE_TIME = 1.0 / 240.0
#: Sample points per rigid body for force and torque quadrature.
BODY_SAMPLES = 32


@lru_cache(maxsize=1)
def _kernels():
    wp = load_warp()

    @wp.struct
    class Field:
        kind: int
        strength: float
        direction: wp.vec3
        position: wp.vec3
        radius: float
        falloff: float
        flow: float
        k1: float
        k2: float
        radial: float
        inner: float
        damping: float
        frequency: float
        seed: int

    # One law per kind, a(x, v), registered under the kind's name; ``accel`` dispatches on the kind's id,
    # its place in fields.FIELD_KINDS. ``salt`` and ``noise_scale`` serve the noise field's draws.
    laws = {}

    def law(kind: str):
        def register(fn):
            laws[kind] = wp.func(fn)
            return laws[kind]
        return register

    @law("constant")
    def constant(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        return f.strength * f.direction

    @law("wind")
    def wind(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        d = f.direction
        a = wp.vec3(0.0, 0.0, 0.0)
        off = x - f.position
        perp = off - wp.dot(off, d) * d
        if f.radius < 0.0 or wp.length(perp) <= f.radius:
            a = f.strength * d
        return a

    @law("point")
    def point(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        a = wp.vec3(0.0, 0.0, 0.0)
        delta = x - f.position
        r = wp.sqrt(wp.dot(delta, delta) + POINT_EPSILON)
        if f.radius < 0.0 or r <= f.radius:
            a0 = f.strength * delta / r
            a = (a0 + f.flow * (a0 - v)) / wp.pow(r + 1.0, f.falloff)
        return a

    @law("drag")
    def drag(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        return -f.k1 * v - f.k2 * wp.length(v) * v

    @law("vortex")
    def vortex(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        d = f.direction
        off = x - f.position
        delta = off - wp.dot(off, d) * d
        rho = wp.length(delta)
        g = 1.0
        if rho > f.inner:
            g = 1.0 / wp.pow(rho - f.inner + 1.0, f.falloff)
        if f.radius >= 0.0 and rho > f.radius:
            g = 0.0
        return g * (f.strength * wp.cross(d, delta) - f.radial * delta) - f.damping * v

    @law("turbulence")
    def turbulence(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        p = f.frequency * x
        a0 = f.strength * wp.vec3(wp.noise(wp.rand_init(f.seed), p), wp.noise(wp.rand_init(f.seed + 1), p),
                                  wp.noise(wp.rand_init(f.seed + 2), p))
        return a0 + f.flow * (a0 - v)

    @law("noise")
    def white_noise(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        state = wp.rand_init(f.seed, salt)
        return f.strength * noise_scale * wp.vec3(wp.randf(state, -1.0, 1.0), wp.randf(state, -1.0, 1.0),
                                                  wp.randf(state, -1.0, 1.0))

    missing = [k for k in KINDS if k not in laws]
    if missing:
        raise RuntimeError(f"force field kinds without a law in physics/forces.py: {', '.join(missing)}")
    by_id = [laws[k] for k in KINDS]

    @wp.func
    def accel(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        a = wp.vec3(0.0, 0.0, 0.0)
        for i in range(wp.static(len(by_id))):  # unrolled when the kernels are built: one branch per kind
            if f.kind == i:
                a = wp.static(by_id[i])(f, x, v, salt, noise_scale)
        return a

    @wp.func
    def total(fields: wp.array(dtype=Field), active: wp.array(dtype=wp.int32), x: wp.vec3, v: wp.vec3,
              salt: int, noise_scale: float):
        a = wp.vec3(0.0, 0.0, 0.0)
        for k in range(fields.shape[0]):
            if active[k] != 0:
                a += accel(fields[k], x, v, salt * 7 + k, noise_scale)
        return a

    @wp.kernel
    def on_points(fields: wp.array(dtype=Field), active: wp.array(dtype=wp.int32), x: wp.array(dtype=wp.vec3),
                  v: wp.array(dtype=wp.vec3), step: int, noise_scale: float, out: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        out[i] = total(fields, active, x[i], v[i], step * 1000003 + i, noise_scale)

    @wp.kernel
    def on_particles(fields: wp.array(dtype=Field), active: wp.array(dtype=wp.int32),
                     q: wp.array(dtype=wp.vec3), qd: wp.array(dtype=wp.vec3), mass: wp.array(dtype=float),
                     step: int, noise_scale: float, f: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        if mass[i] > 0.0:
            f[i] = f[i] + mass[i] * total(fields, active, q[i], qd[i], step * 1000003 + i, noise_scale)

    @wp.kernel
    def on_bodies(fields: wp.array(dtype=Field), active: wp.array(dtype=wp.int32),
                  body_q: wp.array(dtype=wp.transform), body_qd: wp.array(dtype=wp.spatial_vector),
                  body_com: wp.array(dtype=wp.vec3), body_mass: wp.array(dtype=float),
                  samples: wp.array2d(dtype=wp.vec3), step: int, noise_scale: float,
                  body_f: wp.array(dtype=wp.spatial_vector)):
        b, s = wp.tid()
        m = body_mass[b]
        if m <= 0.0:
            return
        n = samples.shape[1]
        xf = body_q[b]
        com = wp.transform_point(xf, body_com[b])
        p = wp.transform_point(xf, samples[b, s])
        qd = body_qd[b]
        lin = wp.spatial_top(qd)
        ang = wp.spatial_bottom(qd)
        r = p - com
        v = lin + wp.cross(ang, r)
        force = (m / float(n)) * total(fields, active, p, v, (step * 1000003 + b) * 64 + s, noise_scale)
        wp.atomic_add(body_f, b, wp.spatial_vector(force, wp.cross(r, force)))

    return Field, on_points, on_particles, on_bodies


KIND_IDS = {k: i for i, k in enumerate(KINDS)}


class FieldSet:
    """The fields of a scene packed for warp; :meth:`apply` adds their forces to a Newton state."""

    def __init__(self, fields: list[ForceField], device: str = "cpu"):
        wp = load_warp()
        self.wp = wp
        self.fields = list(fields)
        self.device = device
        self.samples = None
        if not self.fields:  # a scene without fields compiles no field kernels
            return
        Field, self._on_points, self._on_particles, self._on_bodies = _kernels()
        packed = []
        for f in self.fields:
            s = Field()
            s.kind = KIND_IDS[f.kind]
            s.strength = float(f.strength)
            s.direction = wp.vec3(*map(float, f.direction))
            s.position = wp.vec3(*map(float, f.position))
            s.radius, s.falloff, s.flow = float(f.radius), float(f.falloff), float(f.flow)
            s.k1, s.k2 = float(f.linear_drag), float(f.quadratic_drag)
            s.radial, s.inner, s.damping = float(f.radial_strength), float(f.inner_radius), float(f.damping)
            s.frequency, s.seed = float(f.frequency), int(f.seed)
            packed.append(s)
        self._fields = wp.array(packed, dtype=Field, device=device) if packed else None
        self._active = wp.zeros(max(1, len(packed)), dtype=wp.int32, device=device)
        self._active_key = None

    def __bool__(self) -> bool:
        return bool(self.fields)

    def _set_time(self, t: float) -> bool:
        key = tuple(f.active(t) for f in self.fields)
        if key != self._active_key:
            self._active.assign(np.array(key, np.int32))
            self._active_key = key
        return any(key)

    def set_body_samples(self, samples: np.ndarray) -> None:
        """Sample points (bodies, n, 3) in each body's frame, where the field is evaluated."""
        self.samples = self.wp.array(np.ascontiguousarray(samples, np.float32), dtype=self.wp.vec3,
                                     device=self.device)

    def apply(self, model, state, t: float, step: int, dt: float | None = None) -> None:
        """Add the active fields' forces at time ``t`` to ``state.body_f`` and ``state.particle_f`` for a step
        of ``dt`` seconds (which scales noise; None: ``NOISE_TIME``)."""
        if not self.fields or not self._set_time(t):
            return
        wp = self.wp
        scale = noise_scale(dt)
        if model.body_count and self.samples is not None:
            wp.launch(self._on_bodies, dim=(model.body_count, self.samples.shape[1]),
                      inputs=[self._fields, self._active, state.body_q, state.body_qd, model.body_com,
                              model.body_mass, self.samples, int(step), scale], outputs=[state.body_f],
                      device=self.device)
        if model.particle_count:
            wp.launch(self._on_particles, dim=model.particle_count,
                      inputs=[self._fields, self._active, state.particle_q, state.particle_qd, model.particle_mass,
                              int(step), scale], outputs=[state.particle_f], device=self.device)

    def acceleration(self, x: np.ndarray, v: np.ndarray, t: float, step: int = 0,
                     dt: float | None = None) -> np.ndarray:
        """a(x, v, t) for points (N, 3) in a step of ``dt`` s: the same kernels, for checks and closed-form
        comparisons."""
        wp = self.wp
        x = np.atleast_2d(np.asarray(x, np.float32))
        if not self.fields or not self._set_time(t):
            return np.zeros_like(x, dtype=np.float64)
        out = wp.zeros(len(x), dtype=wp.vec3, device=self.device)
        wp.launch(self._on_points, dim=len(x),
                  inputs=[self._fields, self._active, wp.array(x, dtype=wp.vec3, device=self.device),
                          wp.array(np.atleast_2d(np.asarray(v, np.float32)), dtype=wp.vec3, device=self.device),
                          int(step), noise_scale(dt)], outputs=[out], device=self.device)
        return out.numpy().astype(np.float64)


def noise_scale(dt: float | None) -> float:
    """√(NOISE_TIME / dt): what a noise field's draws are scaled by in a step of ``dt`` seconds."""
    return 1.0 if dt is None or dt <= 0 else float(np.sqrt(NOISE_TIME / dt))


def body_samples(points_per_body: list[np.ndarray], n: int = BODY_SAMPLES) -> np.ndarray:
    """(bodies, n, 3) points spread over each body's vertices (body frame), by farthest-point sampling."""
    out = np.zeros((len(points_per_body), n, 3))
    for b, pts in enumerate(points_per_body):
        pts = np.asarray(pts, float)
        chosen = [int(np.argmin(np.linalg.norm(pts - pts.mean(0), axis=1)))]
        dist = np.linalg.norm(pts - pts[chosen[0]], axis=1)
        while len(chosen) < min(n, len(pts)):
            chosen.append(int(np.argmax(dist)))
            dist = np.minimum(dist, np.linalg.norm(pts - pts[chosen[-1]], axis=1))
        sel = pts[chosen]
        out[b] = sel[np.arange(n) % len(sel)]
    return out
