"""Refusing absurd physical input before the solver sees it, with the prim and attribute named."""

from __future__ import annotations

import math

from pxr import Usd, UsdPhysics, UsdShade

from ..errors import InputError
from ..materials.catalog import PARAMS

#: (lowest, highest) accepted per attribute: the material catalog's ranges, plus a body's mass.
LIMITS = {PARAMS[k].attr: (PARAMS[k].lo, PARAMS[k].hi)
          for k in ("density", "static_friction", "dynamic_friction", "restitution")}
LIMITS["physics:mass"] = (1e-6, 1e9)
MAX_SPEED = 1000.0  # m/s
MAX_SPIN = 36000.0  # deg/s


def check_rigid_inputs(stage: Usd.Stage, bodies: list[Usd.Prim]) -> None:
    """Raise :class:`InputError` on the first out-of-range value that would reach the solver."""
    seen = set()
    for prim in bodies:
        _check_attrs(prim, ("physics:density", "physics:mass"))
        mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
        if mat and mat.GetPath() not in seen:
            seen.add(mat.GetPath())
            _check_attrs(mat.GetPrim(), ("physics:density", "physics:staticFriction", "physics:dynamicFriction",
                                         "physics:restitution"))
        body = UsdPhysics.RigidBodyAPI(prim)
        for attr, bound, unit in ((body.GetVelocityAttr(), MAX_SPEED, "m/s"),
                                  (body.GetAngularVelocityAttr(), MAX_SPIN, "deg/s")):
            value = attr.Get() if attr and attr.HasAuthoredValue() else None
            if value is None:
                continue
            if not all(math.isfinite(c) for c in value) or max(abs(c) for c in value) > bound:
                raise InputError(f"{prim.GetPath()}.{attr.GetName()} = {tuple(value)} is not a finite value "
                                 f"below {bound:g} {unit}")


def _check_attrs(prim: Usd.Prim, names) -> None:
    for name in names:
        attr = prim.GetAttribute(name)
        if not attr or not attr.HasAuthoredValue():
            continue
        value = attr.Get()
        lo, hi = LIMITS[name]
        if name in ("physics:density", "physics:mass") and value == 0:
            continue  # UsdPhysics: 0 means "not set, compute it"
        if value is None or not math.isfinite(value) or value < lo or value > hi:
            raise InputError(f"{prim.GetPath()}.{name} = {value} is out of range [{lo:g}, {hi:g}]")
