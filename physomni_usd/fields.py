"""Force fields as data: the kinds (:data:`FIELD_KINDS`), :class:`ForceField` (named as in
``PhysOmniForceFieldAPI``), the ranges every value must lie in, ``--force KIND:key=value,...`` and VLM values
parsed into fields, and the fields a stage holds.

What a field does to a body (the formulas and the warp kernels) is :mod:`physomni_usd.physics.forces`.
"""

from dataclasses import dataclass

import numpy as np
from pxr import Gf, Usd, UsdGeom

from .usd.schema import FORCE_FIELD_ATTRS


@dataclass(frozen=True)
class FieldKind:
    """One kind of force field. Its law, a(x, v), is the warp function registered under its name in
    :mod:`physomni_usd.physics.forces`; everything else that names the kinds reads :data:`FIELD_KINDS`."""

    name: str
    #: Values that differ from :class:`ForceField`'s defaults for this kind (the paper's), applied before the
    #: given values.
    defaults: dict
    #: The set-up page's starting values for it, after ``KIND:`` (each can be edited in the page).
    preset: str
    #: Whether the VLM is asked to suggest it: the paper's six kinds are motions a photo can suggest; noise
    #: is white-noise forcing, a test of robustness more than a motion.
    suggested: bool = True
    #: Whether its law draws new random values at every step: a rewound model or a replayed frame graph
    #: would repeat its draws instead of moving on.
    draws_each_step: bool = False


#: Every kind of force field, in the order of its id in the kernels, of the CLI's help and of the schema's
#: ``allowedTokens`` (``schemas/generate.py`` writes them from here).
FIELD_KINDS = (
    FieldKind("constant", {"strength": 1.0, "direction": (1.0, 0.0, 0.0)}, "direction=0,1,0,strength=2"),
    FieldKind("wind", {"strength": 1.0, "direction": (1.0, 0.0, 0.0)}, "direction=1,0,0,strength=5"),
    FieldKind("point", {"strength": 1.0}, "position=0,0,0.2,strength=-3"),
    FieldKind("drag", {}, "linear_drag=0.5"),
    FieldKind("vortex", {"strength": 20.0, "direction": (0.0, 0.0, 1.0), "falloff": 2.0}, "strength=3"),
    FieldKind("turbulence", {"strength": 1.0, "frequency": 3.0}, "strength=3"),
    FieldKind("noise", {"strength": 1.0}, "strength=2", suggested=False, draws_each_step=True),
)
KINDS = tuple(k.name for k in FIELD_KINDS)
#: Each kind by its name.
FIELD_KIND = {k.name: k for k in FIELD_KINDS}


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
ATTRS = FORCE_FIELD_ATTRS
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
#: Defaults that differ per kind, by name.
KIND_DEFAULTS = {k.name: k.defaults for k in FIELD_KINDS}


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
    from .errors import InputError

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
