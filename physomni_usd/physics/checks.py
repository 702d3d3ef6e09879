"""Refusing absurd authored input before anything is built: every object's and collider's physics
material (its type and each of the type's parameters, against the material catalog's ranges), rigid
bodies' masses and velocities, per-object controls, and every force field (its kind and values,
against the field ranges of :mod:`.forces`), from whichever layer they come; and, for every command
(``validate`` and ``render`` included, :func:`check_values`), any non-finite number anywhere in the composed
stage, a position beyond :data:`MAX_DISTANCE` and a gravity beyond :data:`MAX_GRAVITY`. Each refusal is one
line naming the prim and the attribute and what is allowed."""

from __future__ import annotations

import math

from pxr import Usd, UsdPhysics

from ..errors import InputError
from ..materials.catalog import PARAMS, keys_of, material_type
from ..usd.contract import bound_material, object_prims
from ..fields import FIELD_ATTRS, field_value_problem

#: (lowest, highest) accepted per attribute of a body: the material catalog's density, and a mass.
LIMITS = {"physics:density": (PARAMS["density"].lo, PARAMS["density"].hi), "physics:mass": (1e-6, 1e9)}
MAX_SPEED = 1000.0  # m/s
MAX_SPIN = 36000.0  # deg/s
MAX_START = 1e4  # s
MAX_GRAVITY = 1000.0  # m/s², about 100 g: the preview's gravity control stops there too
MAX_DISTANCE = 1e6  # m from the origin: a shot is a photo's scene, metres across


def check_inputs(stage: Usd.Stage) -> None:
    """Raise :class:`InputError` on the first authored value the simulator cannot use as given."""
    seen = set()
    colliders = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)]
    for prim in object_prims(stage) + colliders:
        if prim.GetPath() in seen:
            continue
        seen.add(prim.GetPath())
        mat = bound_material(prim)
        if mat is not None and mat.GetPath() not in seen:
            seen.add(mat.GetPath())
            check_material(mat)
        _check_body(prim)
    for prim in stage.Traverse():
        if prim.HasAPI("PhysOmniForceFieldAPI"):
            check_force_field(prim)
    check_values(stage)  # after the checks above, whose lines also say the allowed range


def check_material(mat: Usd.Prim) -> str:
    """Check one physics material's type and the type's parameters; returns the type."""
    attr = mat.GetAttribute("physomni:materialType")
    try:
        kind = material_type(attr.Get() if attr else None)
    except ValueError as exc:
        raise InputError(f"{mat.GetPath()}.physomni:materialType: {exc}") from None
    for key in keys_of(kind):
        p = PARAMS[key]
        a = mat.GetAttribute(p.attr)
        if not a or not a.HasAuthoredValue():
            continue
        value = a.Get()
        if key == "density" and kind == "rigid" and value == 0:
            continue  # UsdPhysics: 0 means "not set, compute it" (a deformable has no such meaning)
        if not p.accepts(value):
            raise InputError(f"{mat.GetPath()}.{p.attr} = {_show(value)} is outside {p.describe_range()} "
                             f"for material type {kind}")
    return kind


def check_force_field(prim: Usd.Prim) -> None:
    """Check one ``PhysOmniForceFieldAPI`` prim's kind and values against :data:`.forces.FIELD_RANGES`."""
    values = {}
    for attr_name, key in FIELD_ATTRS.items():
        attr = prim.GetAttribute(attr_name)
        value = attr.Get() if attr else None
        if value is None:
            continue
        values[key] = value
        why = field_value_problem(key, value)
        if why:
            raise InputError(f"{prim.GetPath()}.{attr_name} = {_show(value)}: {why}")
    start, end = values.get("start_time", 0.0), values.get("end_time", -1.0)
    if 0 <= end <= start:
        raise InputError(f"{prim.GetPath()}.physomni:endTime = {_show(end)} is not after physomni:startTime = "
                         f"{_show(start)}: the field would never act (a negative end time means never off)")


def _check_body(prim: Usd.Prim) -> None:
    for name in ("physics:density", "physics:mass"):
        attr = prim.GetAttribute(name)
        if not attr or not attr.HasAuthoredValue():
            continue
        value = attr.Get()
        lo, hi = LIMITS[name]
        if value == 0 and not isinstance(value, bool):
            continue  # UsdPhysics: 0 means "not set, compute it"
        if not _number(value) or value < lo or value > hi:
            raise InputError(f"{prim.GetPath()}.{name} = {_show(value)} is outside [{lo:g}, {hi:g}]")
    body = UsdPhysics.RigidBodyAPI(prim)
    for attr, bound, unit in ((body.GetVelocityAttr(), MAX_SPEED, "m/s"),
                              (body.GetAngularVelocityAttr(), MAX_SPIN, "deg/s"),
                              (prim.GetAttribute("physomni:initialVelocity"), MAX_SPEED, "m/s"),
                              (prim.GetAttribute("physomni:initialAngularVelocity"), MAX_SPIN, "deg/s")):
        value = attr.Get() if attr and attr.HasAuthoredValue() else None
        if value is None:
            continue
        if not all(_number(c) for c in value) or max(abs(c) for c in value) > bound:
            raise InputError(f"{prim.GetPath()}.{attr.GetName()} = {tuple(value)} is not a finite value "
                             f"below {bound:g} {unit}")
    for name, lo, hi, unit in (("physomni:velocityStartTime", 0.0, MAX_START, "s"),
                               ("physomni:fixTopRatio", 0.0, 1.0, "")):
        attr = prim.GetAttribute(name)
        value = attr.Get() if attr and attr.HasAuthoredValue() else None
        if value is not None and (not _number(value) or not lo <= value <= hi):
            raise InputError(f"{prim.GetPath()}.{name} = {_show(value)} is outside [{lo:g}, {hi:g}] {unit}".rstrip())


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _show(value) -> str:
    return repr(value) if isinstance(value, str) else f"{value}"


def check_values(stage: Usd.Stage) -> None:
    """Raise :class:`InputError` (one line naming prim and attribute) on the first non-finite number
    authored anywhere in the composed ``stage`` (defaults and every time sample: transforms, velocities,
    materials, fields, points), a translation farther than :data:`MAX_DISTANCE`, a gravity stronger than
    :data:`MAX_GRAVITY` or a rigid body's velocity beyond :data:`MAX_SPEED` / :data:`MAX_SPIN`."""
    import numpy as np

    for prim in stage.TraverseAll():
        for attr in prim.GetAuthoredAttributes():
            if not _numeric(attr):
                continue
            times = attr.GetTimeSamples() if attr.GetNumTimeSamples() else []
            for t in [Usd.TimeCode.Default()] + list(times):
                value = attr.Get(t)
                if value is None:
                    continue
                a = _array(value)
                if a is None:
                    continue
                when = "" if isinstance(t, Usd.TimeCode) else f" at time {t:g}"
                if not np.isfinite(a).all():
                    raise InputError(f"{prim.GetPath()}.{attr.GetName()}{when} is not finite "
                                     f"({_first_bad(a)}): every number in a shot must be finite")
                name = attr.GetName()
                if name == "xformOp:translate" and np.abs(a).max(initial=0) > MAX_DISTANCE:
                    raise InputError(f"{prim.GetPath()}.{name}{when} = {tuple(a.tolist())} is more than "
                                     f"{MAX_DISTANCE:g} m from the origin")
                if name == "physics:gravityMagnitude" and not (abs(float(a.ravel()[0])) <= MAX_GRAVITY):
                    raise InputError(f"{prim.GetPath()}.{name}{when} = {float(a.ravel()[0]):g} is outside "
                                     f"[0, {MAX_GRAVITY:g}] m/s²")
                bound = {"physics:velocity": MAX_SPEED, "physics:angularVelocity": MAX_SPIN}.get(name)
                if bound is not None and np.abs(a).max(initial=0) > bound:
                    raise InputError(f"{prim.GetPath()}.{name}{when} = {tuple(a.tolist())} is beyond "
                                     f"{bound:g} {'m/s' if name == 'physics:velocity' else 'deg/s'}")


def _numeric(attr) -> bool:
    scalar = attr.GetTypeName().scalarType.type.typeName
    return any(k in scalar for k in ("float", "double", "half", "Vec", "Quat", "Matrix"))


def _array(value):
    import numpy as np

    if hasattr(value, "GetReal"):  # a quaternion
        value = (value.GetReal(), *value.GetImaginary())
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return a


def _first_bad(a) -> str:
    import numpy as np

    flat = a.ravel()
    return f"{flat[~np.isfinite(flat)][0]}"
