"""Registration of the codeless PhysOmni schema with OpenUSD's plugin registry."""

from __future__ import annotations

import importlib.util
import pathlib

from pxr import Plug

API_SCHEMAS = ("PhysOmniSceneAPI", "PhysOmniMaterialAPI", "PhysOmniObjectAPI", "PhysOmniForceFieldAPI")

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
