"""Force fields: read from USD prims with ``PhysOmniForceFieldAPI``, evaluated by warp kernels.

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


from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from pxr import Gf, Usd, UsdGeom

from .._warp import load_warp

KINDS = ("constant", "wind", "point", "drag", "vortex", "turbulence", "noise")
#: Softening of the point field's distance, m² (keeps a at the centre finite).
POINT_EPSILON = 1e-4
#: The step (s) at which a noise field's draws are s·U[−1, 1]³; at a step dt they are scaled by √(τ/dt),
#: so that the velocity they give, a sum of independent kicks, spreads the same whatever the step.
NOISE_TIME = 1.0 / 240.0
#: Sample points per rigid body for force and torque quadrature.
BODY_SAMPLES = 32


@dataclass
class ForceField:
    """One field in world coordinates; attribute names as in ``PhysOmniForceFieldAPI``."""

    kind: str
    strength: float = 1.0
    direction: tuple = (1.0, 0.0, 0.0)
    position: tuple = (0.0, 0.0, 0.0)
    radius: float = -1.0
    falloff: float = 0.0
    start_time: float = 0.0
    end_time: float = -1.0
    enabled: bool = True
    flow: float = 0.0
    linear_drag: float = 0.0
    quadratic_drag: float = 0.0
    radial_strength: float = 0.0
    inner_radius: float = 0.01
    damping: float = 0.0
    frequency: float = 3.0
    seed: int = 0
    path: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown force field kind {self.kind!r}; one of {', '.join(KINDS)}")
        d = np.asarray(self.direction, float)
        n = np.linalg.norm(d)
        if not np.isfinite(n) or n == 0:
            raise ValueError(f"force field {self.path or self.kind}: direction must be a non-zero vector")
        self.direction = tuple(float(x) for x in d / n)
        self.position = tuple(float(x) for x in self.position)

    def active(self, t: float) -> bool:
        return self.enabled and t >= self.start_time and (self.end_time < 0 or t < self.end_time)


#: USD attribute → dataclass field.
ATTRS = {
    "physomni:kind": "kind", "physomni:enabled": "enabled", "physomni:strength": "strength",
    "physomni:direction": "direction", "physomni:position": "position", "physomni:radius": "radius",
    "physomni:falloff": "falloff", "physomni:startTime": "start_time", "physomni:endTime": "end_time",
    "physomni:flow": "flow", "physomni:linearDrag": "linear_drag", "physomni:quadraticDrag": "quadratic_drag",
    "physomni:radialStrength": "radial_strength", "physomni:innerRadius": "inner_radius",
    "physomni:damping": "damping", "physomni:frequency": "frequency", "physomni:seed": "seed",
}
FIELD_ATTRS = ATTRS

#: What each field value may be, wherever it comes from (a layer, ``--force``, a VLM reply):
#: (lowest, highest, unit). Negative radius and end time have a meaning (unbounded, never off); a
#: negative falloff, flow, drag or damping would feed energy in instead of taking it out. Strengths
#: reach 1e6 m/s²: the step planner and the guard carry a body pressed that hard (``bench stability``).
FIELD_RANGES = {
    "strength": (-1e6, 1e6, "m/s²"), "radius": (-1e6, 1e6, "m"), "falloff": (0.0, 10.0, ""),
    "start_time": (0.0, 1e4, "s"), "end_time": (-1e4, 1e4, "s"), "flow": (0.0, 1e3, "1/s"),
    "linear_drag": (0.0, 1e4, "1/s"), "quadratic_drag": (0.0, 1e4, "1/m"), "radial_strength": (-1e6, 1e6, "1/s²"),
    "inner_radius": (0.0, 1e6, "m"), "damping": (0.0, 1e4, "1/s"), "frequency": (1e-6, 1e4, "1/m"),
    "seed": (0, 2**31 - 1, ""),
}
#: Largest |coordinate| of a field's position, m.
MAX_POSITION = 1e6


def field_value_problem(key: str, value) -> str | None:
    """What is wrong with ``value`` for the field value ``key`` (a :class:`ForceField` attribute), or None."""
    if key == "kind":
        return None if value in KINDS else f"not a force field kind; one of {', '.join(KINDS)}"
    if key == "enabled":
        return None if isinstance(value, (bool, int)) else "must be true or false"
    if key in VECTOR_FIELDS:
        try:
            vec = np.asarray(tuple(value), float)
        except (TypeError, ValueError):
            return "must be three finite numbers"
        if vec.shape != (3,) or not np.isfinite(vec).all():
            return "must be three finite numbers"
        if key == "direction" and not np.linalg.norm(vec):
            return "must be a non-zero vector"
        if key == "position" and np.abs(vec).max() > MAX_POSITION:
            return f"must be within {MAX_POSITION:g} m of the origin"
        return None
    lo, hi, unit = FIELD_RANGES[key]
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value) and lo <= value <= hi
    if key == "seed":
        ok = ok and float(value).is_integer()
    return None if ok else f"must be a finite number in [{lo:g}, {hi:g}] {unit}".rstrip()


#: Spellings accepted in ``--force KIND:key=value,...`` and VLM replies → dataclass field.
SPEC_KEYS = {
    "strength": "strength", "s": "strength", "magnitude": "strength", "direction": "direction", "dir": "direction",
    "position": "position", "pos": "position", "center": "position", "centre": "position", "radius": "radius",
    "range": "radius", "falloff": "falloff", "pow": "falloff", "start": "start_time", "start_time": "start_time",
    "end": "end_time", "end_time": "end_time", "enabled": "enabled", "flow": "flow", "k1": "linear_drag",
    "linear": "linear_drag", "linear_drag": "linear_drag", "k2": "quadratic_drag", "quadratic": "quadratic_drag",
    "quadratic_drag": "quadratic_drag", "radial": "radial_strength", "radial_strength": "radial_strength",
    "inner_radius": "inner_radius", "r_min": "inner_radius", "damping": "damping", "frequency": "frequency",
    "freq": "frequency", "seed": "seed",
}
VECTOR_FIELDS = ("direction", "position")
#: Defaults that differ per kind (the paper's), applied before the given values.
KIND_DEFAULTS = {
    "constant": {"strength": 1.0, "direction": (1.0, 0.0, 0.0)},
    "wind": {"strength": 1.0, "direction": (1.0, 0.0, 0.0)},
    "point": {"strength": 1.0},
    "drag": {},
    "vortex": {"strength": 20.0, "direction": (0.0, 0.0, 1.0), "falloff": 2.0},
    "turbulence": {"strength": 1.0, "frequency": 3.0},
    "noise": {"strength": 1.0},
}


def parse_bool(value) -> bool:
    """'true'/'1'/'yes'/'on' → True, 'false'/'0'/'no'/'off' → False; anything else is refused."""
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)) and value in (0, 1):
        return bool(value)
    text = str(value).strip().lower()
    if text in ("true", "1", "yes", "on"):
        return True
    if text in ("false", "0", "no", "off"):
        return False
    raise ValueError(f"{value!r} is not a boolean (true/false)")


def field_from_values(kind: str, values: dict, path: str = "") -> "ForceField":
    """A field of ``kind`` from loosely typed values (strings, lists, numbers), checked and converted."""
    kind = str(kind).strip().lower()
    if kind not in KINDS:
        raise ValueError(f"unknown force field kind {kind!r}; one of {', '.join(KINDS)}")
    out = dict(KIND_DEFAULTS[kind])
    for key, value in values.items():
        name = SPEC_KEYS.get(str(key).strip().lower())
        if name is None:
            raise ValueError(f"{kind} has no parameter {key!r}")
        if name in VECTOR_FIELDS:
            parts = value.split(",") if isinstance(value, str) else list(value)
            vec = tuple(float(x) for x in parts)
            if len(vec) != 3 or not all(np.isfinite(vec)):
                raise ValueError(f"{key} must be three finite numbers, got {value!r}")
            out[name] = vec
        elif name == "enabled":
            out[name] = parse_bool(value)
        else:
            out[name] = float(value)
            if name == "seed" and float(value).is_integer():
                out[name] = int(float(value))
        why = field_value_problem(name, out[name])
        if why:
            raise ValueError(f"{key} = {value!r}: {why}")
    if 0 <= out.get("end_time", -1.0) <= out.get("start_time", 0.0):
        raise ValueError("the end time is not after the start time: the field would never act")
    return ForceField(kind, path=path, **out)


def doubles_gravity(f: "ForceField", gravity=(0.0, 0.0, -9.81)) -> bool:
    """Whether a constant field just repeats gravity (the paper's configs did, silently doubling it)."""
    g = np.asarray(gravity, float)
    if f.kind != "constant" or not np.linalg.norm(g):
        return False
    a = f.strength * np.asarray(f.direction)
    return bool(np.linalg.norm(a - g) < 0.1 * np.linalg.norm(g))


def parse_force_options(specs) -> list["ForceField"]:
    """``--force KIND:key=value,...`` options → fields; a bad one stops with one line naming it."""
    from ..errors import InputError

    fields = []
    for spec in specs or ():
        try:
            f = parse_force_spec(spec)
        except ValueError as exc:
            raise InputError(f"--force {spec!r}: {exc}") from None
        if doubles_gravity(f):
            raise InputError(f"--force {spec!r} repeats gravity, which the scene already applies; "
                             "change /World/PhysicsScene's gravity instead")
        fields.append(f)
    return fields


def parse_force_spec(spec: str) -> "ForceField":
    """``'wind:direction=1,0,0,strength=30'`` → a :class:`ForceField`; vectors keep their commas."""
    kind, _, rest = spec.partition(":")
    values, key = {}, None
    for token in filter(None, (t.strip() for t in rest.split(","))):
        if "=" in token:
            key, _, value = token.partition("=")
            values[key.strip()] = value.strip()
        elif key is not None:
            values[key] += "," + token
        else:
            raise ValueError(f"expected key=value after '{kind}:', got {token!r}")
    return field_from_values(kind, values)


def read_force_fields(stage: Usd.Stage, time=Usd.TimeCode.Default()) -> list[ForceField]:
    """Every prim with ``PhysOmniForceFieldAPI`` on the composed stage, in world coordinates."""
    out = []
    cache = UsdGeom.XformCache(time)
    for prim in stage.Traverse():
        if not prim.HasAPI("PhysOmniForceFieldAPI"):
            continue
        values = {}
        for attr_name, key in ATTRS.items():
            attr = prim.GetAttribute(attr_name)
            value = attr.Get(time) if attr else None
            if value is not None:
                values[key] = value
        values["kind"] = str(values.get("kind", "wind"))
        m = cache.GetLocalToWorldTransform(prim) if prim.IsA(UsdGeom.Xformable) else Gf.Matrix4d(1.0)
        values["position"] = tuple(m.Transform(Gf.Vec3d(*values.get("position", (0, 0, 0)))))
        values["direction"] = tuple(m.TransformDir(Gf.Vec3d(*values.get("direction", (1, 0, 0)))))
        values["enabled"] = bool(values.get("enabled", True))
        values["seed"] = int(values.get("seed", 0))
        out.append(ForceField(path=str(prim.GetPath()), **values))
    return out


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

    @wp.func
    def accel(f: Field, x: wp.vec3, v: wp.vec3, salt: int, noise_scale: float):
        d = f.direction
        a = wp.vec3(0.0, 0.0, 0.0)
        if f.kind == 0:  # constant
            a = f.strength * d
        elif f.kind == 1:  # wind
            off = x - f.position
            perp = off - wp.dot(off, d) * d
            if f.radius < 0.0 or wp.length(perp) <= f.radius:
                a = f.strength * d
        elif f.kind == 2:  # point
            delta = x - f.position
            r = wp.sqrt(wp.dot(delta, delta) + POINT_EPSILON)
            if f.radius < 0.0 or r <= f.radius:
                a0 = f.strength * delta / r
                a = (a0 + f.flow * (a0 - v)) / wp.pow(r + 1.0, f.falloff)
        elif f.kind == 3:  # drag
            a = -f.k1 * v - f.k2 * wp.length(v) * v
        elif f.kind == 4:  # vortex
            off = x - f.position
            delta = off - wp.dot(off, d) * d
            rho = wp.length(delta)
            g = 1.0
            if rho > f.inner:
                g = 1.0 / wp.pow(rho - f.inner + 1.0, f.falloff)
            if f.radius >= 0.0 and rho > f.radius:
                g = 0.0
            a = g * (f.strength * wp.cross(d, delta) - f.radial * delta) - f.damping * v
        elif f.kind == 5:  # turbulence
            p = f.frequency * x
            a0 = f.strength * wp.vec3(wp.noise(wp.rand_init(f.seed), p), wp.noise(wp.rand_init(f.seed + 1), p),
                                      wp.noise(wp.rand_init(f.seed + 2), p))
            a = a0 + f.flow * (a0 - v)
        elif f.kind == 6:  # noise
            state = wp.rand_init(f.seed, salt)
            a = f.strength * noise_scale * wp.vec3(wp.randf(state, -1.0, 1.0), wp.randf(state, -1.0, 1.0),
                                                   wp.randf(state, -1.0, 1.0))
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
