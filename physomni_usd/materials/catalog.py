"""The eleven material types of the paper: solver family, parameters, SI units, defaults, valid ranges.

Each parameter has one canonical name (what ``--set NAME.KEY=VALUE`` and VLM
replies use), the USD attribute it is authored as — UsdPhysics' own where one
exists — and a range. :func:`material_model` builds a pydantic model per type,
so a configuration is validated the same way wherever it comes from.

| type | solver | parameters (defaults) |
|---|---|---|
| rigid | rigid | density 200 kg/m³, static_friction 0.7, dynamic_friction 0.7, restitution 0.1 |
| mpm_elastic | mpm | youngs_modulus 3e5 Pa, poissons_ratio 0.2, density 1000, model corotated |
| mpm_elastoplastic | mpm | youngs_modulus 3e4, poissons_ratio 0.4, density 100, yield_stress 1e4 Pa (von Mises) |
| mpm_sand | mpm | youngs_modulus 5e5, poissons_ratio 0.2, density 1800, friction_angle 45° |
| mpm_liquid | mpm | youngs_modulus 1e6, poissons_ratio 0.2, density 1000, viscosity 0 Pa·s |
| mpm_snow | mpm | youngs_modulus 1e6, poissons_ratio 0.2, density 1000, critical_compression 2.5e-2, critical_stretch 4.5e-3 |
| mpm_muscle | mpm | youngs_modulus 1e6, poissons_ratio 0.2, density 1000, model neo_hookean |
| pbd_elastic | pbd | density 1000, stretch/bending/volume compliance 0, relaxation 0.1, dynamic_friction 0.15 |
| pbd_cloth | pbd | density 4 kg/m² (areal), stretch_compliance 1e-7, bending_compliance 1e-5, air_resistance 1e-3, dynamic_friction 0.15 |
| pbd_liquid | pbd | density 1000, density_relaxation 0.2, viscosity_relaxation 0.01 |
| pbd_particle | pbd | density 1000 |
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model

from ..usd.schema import MATERIAL_ATTRS


@dataclass(frozen=True)
class Param:
    key: str
    unit: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False  # lo itself is not allowed
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""

    @property
    def attr(self) -> str:
        """The USD attribute it is authored as (``usd/schema.MATERIAL_ATTRS``)."""
        return MATERIAL_ATTRS[self.key]

    def describe_range(self) -> str:
        if self.choices:
            return "one of " + ", ".join(self.choices)
        left = "(" if self.lo_open else "["
        right = ")" if self.hi_open else "]"
        return f"{left}{self.lo:g}, {self.hi:g}{right} {self.unit}".strip()

    def accepts(self, value) -> bool:
        if self.choices:
            return value in self.choices
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            return False
        if value < self.lo or (self.lo_open and value == self.lo):
            return False
        return not (value > self.hi or (self.hi_open and value == self.hi))


PARAMS = {p.key: p for p in (
    Param("density", "kg/m³ (kg/m² for cloth)", 1e-3, 1e5),
    Param("static_friction", "", 0.0, 10.0),
    Param("dynamic_friction", "", 0.0, 10.0),
    Param("restitution", "", 0.0, 1.0),
    Param("youngs_modulus", "Pa", 0.0, 1e12, lo_open=True),
    Param("poissons_ratio", "", 0.0, 0.5, hi_open=True),
    Param("yield_stress", "Pa", 0.0, 1e10, lo_open=True),
    Param("friction_angle", "degrees", 0.0, 89.0),
    Param("critical_compression", "", 0.0, 1.0, lo_open=True, hi_open=True),
    Param("critical_stretch", "", 0.0, 1.0, lo_open=True, hi_open=True),
    Param("viscosity", "Pa·s", 0.0, 1e6),
    Param("stretch_compliance", "m/N", 0.0, 1.0),
    Param("bending_compliance", "1/(N·m)", 0.0, 1.0),
    Param("volume_compliance", "m²/N", 0.0, 1.0),
    Param("air_resistance", "1/s", 0.0, 10.0),
    Param("relaxation", "", 0.0, 2.0, lo_open=True),
    Param("density_relaxation", "", 0.0, 2.0, lo_open=True),
    Param("viscosity_relaxation", "", 0.0, 2.0),
    Param("model", "", choices=("corotated", "neo_hookean", "linear")),
)}

#: Other spellings accepted from users and VLM replies.
ALIASES = {
    "rho": "density", "e": "youngs_modulus", "youngs": "youngs_modulus", "young_modulus": "youngs_modulus",
    "nu": "poissons_ratio", "poisson_ratio": "poissons_ratio", "poisson": "poissons_ratio",
    "mu": "friction", "yield": "yield_stress", "compliance": "stretch_compliance",
    "yield_lower": "critical_compression", "yield_higher": "critical_stretch",
    "viscous": "viscosity", "model_type": "model",
}


@dataclass(frozen=True)
class MaterialType:
    name: str
    solver: str  # 'rigid' | 'mpm' | 'pbd'
    defaults: dict
    doc: str


_COMMON_RIGID = {"static_friction": 0.7, "dynamic_friction": 0.7, "restitution": 0.1}
CATALOG = {m.name: m for m in (
    MaterialType("rigid", "rigid", {"density": 200.0, **_COMMON_RIGID}, "rigid body"),
    MaterialType("mpm_elastic", "mpm", {"youngs_modulus": 3e5, "poissons_ratio": 0.2, "density": 1000.0,
                                        "model": "corotated"}, "elastic deformable (rubber, jelly)"),
    MaterialType("mpm_elastoplastic", "mpm", {"youngs_modulus": 3e4, "poissons_ratio": 0.4, "density": 100.0,
                                              "yield_stress": 1e4}, "permanent deformation (clay, cream)"),
    MaterialType("mpm_sand", "mpm", {"youngs_modulus": 5e5, "poissons_ratio": 0.2, "density": 1800.0,
                                     "friction_angle": 45.0}, "granular (sand, powder)"),
    MaterialType("mpm_liquid", "mpm", {"youngs_modulus": 1e6, "poissons_ratio": 0.2, "density": 1000.0,
                                       "viscosity": 0.0}, "liquids, viscous fluids"),
    MaterialType("mpm_snow", "mpm", {"youngs_modulus": 1e6, "poissons_ratio": 0.2, "density": 1000.0,
                                     "critical_compression": 2.5e-2, "critical_stretch": 4.5e-3}, "snow, ice"),
    MaterialType("mpm_muscle", "mpm", {"youngs_modulus": 1e6, "poissons_ratio": 0.2, "density": 1000.0,
                                       "model": "neo_hookean"}, "soft tissue"),
    MaterialType("pbd_elastic", "pbd", {"density": 1000.0, "stretch_compliance": 0.0, "bending_compliance": 0.0,
                                        "volume_compliance": 0.0, "relaxation": 0.1, "dynamic_friction": 0.15},
                 "3D soft body (sponge)"),
    MaterialType("pbd_cloth", "pbd", {"density": 4.0, "stretch_compliance": 1e-7, "bending_compliance": 1e-5,
                                      "air_resistance": 1e-3, "dynamic_friction": 0.15}, "thin sheet (fabric, paper)"),
    MaterialType("pbd_liquid", "pbd", {"density": 1000.0, "density_relaxation": 0.2, "viscosity_relaxation": 0.01},
                 "position-based fluid"),
    MaterialType("pbd_particle", "pbd", {"density": 1000.0}, "loose particles"),
)}

#: The one rule for material type names. A type a person authored (on the stage, in any layer, or with
#: ``--set``) must be one of :data:`CATALOG`: anything else is refused with the prim and attribute named
#: (:func:`material_type`). No type authored at all means ``rigid``, what ``build`` writes. Only a VLM's
#: reply, which is not the user's word, falls back: an unknown or missing type there becomes
#: ``FALLBACK_TYPE`` with a warning (the paper's rule; see :mod:`.parse`).
DEFAULT_TYPE = "rigid"
FALLBACK_TYPE = "mpm_elastic"


def material_type(name) -> str:
    """The catalog type an authored ``physomni:materialType`` names (``None``: :data:`DEFAULT_TYPE`);
    raises ValueError for any other name."""
    if name is None:
        return DEFAULT_TYPE
    if name not in CATALOG:
        raise ValueError(f"unknown material type {str(name)!r}; one of {', '.join(CATALOG)}")
    return str(name)


def canonical_key(key: str) -> str | None:
    """The catalog's name for a parameter spelling, or None. ``friction`` stays (it sets both frictions)."""
    k = key.strip().lower().replace("-", "_").replace(" ", "_")
    k = ALIASES.get(k, k)
    return k if k in PARAMS or k == "friction" else None


def keys_of(material_type: str) -> tuple[str, ...]:
    """Parameters a type uses; every type also takes friction and restitution against colliders."""
    base = tuple(CATALOG[material_type].defaults)
    extra = tuple(k for k in ("static_friction", "dynamic_friction", "restitution") if k not in base)
    return base + extra


@lru_cache(maxsize=None)
def material_model(material_type: str) -> type[BaseModel]:
    """A pydantic model of one type's parameters, with its defaults and ranges."""
    fields = {}
    for key in keys_of(material_type):
        p = PARAMS[key]
        default = CATALOG[material_type].defaults.get(key, _COMMON_RIGID.get(key))
        if p.choices:
            from typing import Literal

            fields[key] = (Literal[p.choices], default)  # type: ignore[valid-type]
            continue
        bounds = {("gt" if p.lo_open else "ge"): p.lo, ("lt" if p.hi_open else "le"): p.hi}
        fields[key] = (float, Field(default, allow_inf_nan=False, description=p.unit, **bounds))
    return create_model(f"{material_type}_params", __config__=ConfigDict(extra="forbid"), **fields)


def check_params(material_type: str, params: dict) -> dict:
    """Validated parameters of a type (defaults filled in); raises ValueError naming the bad key and its range."""
    if material_type not in CATALOG:
        raise ValueError(f"unknown material type {material_type!r}; one of {', '.join(CATALOG)}")
    clean = {}
    for key, value in params.items():
        k = canonical_key(key)
        if k == "friction":
            clean["static_friction"] = clean["dynamic_friction"] = value
        elif k is None or k not in keys_of(material_type):
            raise ValueError(f"{material_type} has no parameter {key!r}; it takes {', '.join(keys_of(material_type))}")
        else:
            clean[k] = value
    try:
        return material_model(material_type)(**clean).model_dump()
    except ValidationError as exc:
        err = exc.errors()[0]
        key = str(err["loc"][0]) if err.get("loc") else "?"
        p = PARAMS.get(key)
        rng = f"; valid range {p.describe_range()}" if p else ""
        raise ValueError(f"{key} = {err.get('input')!r} is not valid for {material_type}{rng}") from None
