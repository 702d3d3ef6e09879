"""Registration of the codeless PhysOmni schema with OpenUSD's plugin registry."""

from __future__ import annotations

import importlib.util
import pathlib

from pxr import Plug

API_SCHEMAS = ("PhysOmniSceneAPI", "PhysOmniMaterialAPI", "PhysOmniObjectAPI", "PhysOmniForceFieldAPI")

#: PhysOmniForceFieldAPI's attributes → the field value each holds (see :class:`physomni_usd.fields.ForceField`).
FORCE_FIELD_ATTRS = {
    "physomni:kind": "kind", "physomni:enabled": "enabled", "physomni:strength": "strength",
    "physomni:direction": "direction", "physomni:position": "position", "physomni:radius": "radius",
    "physomni:falloff": "falloff", "physomni:startTime": "start_time", "physomni:endTime": "end_time",
    "physomni:flow": "flow", "physomni:linearDrag": "linear_drag", "physomni:quadraticDrag": "quadratic_drag",
    "physomni:radialStrength": "radial_strength", "physomni:innerRadius": "inner_radius",
    "physomni:damping": "damping", "physomni:frequency": "frequency", "physomni:seed": "seed",
}

#: Each material parameter (its canonical key, see ``materials/catalog.py``) → the USD attribute it is
#: authored as: UsdPhysics' own where one exists, ``physomni:`` otherwise.
MATERIAL_ATTRS = {
    "density": "physics:density",
    "static_friction": "physics:staticFriction",
    "dynamic_friction": "physics:dynamicFriction",
    "restitution": "physics:restitution",
    "youngs_modulus": "physomni:youngsModulus",
    "poissons_ratio": "physomni:poissonsRatio",
    "yield_stress": "physomni:yieldStress",
    "friction_angle": "physomni:frictionAngle",
    "critical_compression": "physomni:criticalCompression",
    "critical_stretch": "physomni:criticalStretch",
    "viscosity": "physomni:viscosity",
    "stretch_compliance": "physomni:stretchCompliance",
    "bending_compliance": "physomni:bendingCompliance",
    "volume_compliance": "physomni:volumeCompliance",
    "air_resistance": "physomni:airResistance",
    "relaxation": "physomni:relaxation",
    "density_relaxation": "physomni:densityRelaxation",
    "viscosity_relaxation": "physomni:viscosityRelaxation",
    "model": "physomni:constitutiveModel",
}

_registered = False


def schema_dir() -> pathlib.Path:
    """Folder holding ``plugInfo.json`` and ``generatedSchema.usda``.

    Installed, it is the ``physomni_usd._schema`` package; run from a source
    checkout, it is ``schemas/physomni`` beside the package.
    """
    spec = importlib.util.find_spec("physomni_usd._schema")
    for location in (spec.submodule_search_locations or []) if spec else []:
        if (pathlib.Path(location) / "plugInfo.json").is_file():
            return pathlib.Path(location)
    return pathlib.Path(__file__).resolve().parents[2] / "schemas" / "physomni"


def register_schema() -> None:
    """Make the PhysOmni API schemas known to USD (idempotent)."""
    global _registered
    if _registered:
        return
    Plug.Registry().RegisterPlugins(str(schema_dir().resolve()))
    _registered = True
