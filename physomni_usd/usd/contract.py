"""The shot's contract: which prims are its objects, which physics material each is bound to, and the
artist's own values authored on those materials in ``edits.usda``.

Every stage that reads objects (physics, the backends, the preview, validation) finds them here, so that
"an object" means one thing across the package: a child of ``/World/Objects`` with ``PhysOmniObjectAPI``,
in mask order, bound to its physics material through the ``physics`` purpose.
"""

from __future__ import annotations

import pathlib

from pxr import Sdf, Usd, UsdShade

from . import layers
from .author import OBJECTS, set_param

#: The attribute holding a physics material's type (``rigid``, ``mpm_sand``, ...).
MATERIAL_TYPE = "physomni:materialType"


def object_prims(stage: Usd.Stage) -> list[Usd.Prim]:
    """Objects under /World/Objects in mask order (``physomni:maskIndex``), then by name."""
    root = stage.GetPrimAtPath(OBJECTS)
    prims = [p for p in (root.GetChildren() if root else []) if p.HasAPI("PhysOmniObjectAPI")]

    def key(p):
        idx = p.GetAttribute("physomni:maskIndex").Get()
        return (idx if idx is not None else 1 << 30, p.GetName())

    return sorted(prims, key=key)


def bound_material(prim: Usd.Prim) -> Usd.Prim | None:
    """The physics material bound to ``prim`` (``physics`` purpose), or None."""
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
    return mat.GetPrim() if mat else None


def author_user_values(folder: pathlib.Path, values: list[tuple[Sdf.Path, str, object]]) -> None:
    """Author ``(material prim path, attribute name, value)`` in the shot's ``edits.usda``, each with source
    ``user``, in the order given.

    The values are authored on the edits layer itself (the composed stage's edit target), so every spec
    already in it stays; the layer is then exported to a temporary file that replaces ``edits.usda``. A
    layer without a frame rate gets the root's here (without it USD rescales its time samples).
    """
    stage = layers.open_shot(folder, mute_sim=True)
    fps = stage.GetTimeCodesPerSecond() or 30.0
    layers.ensure_edits_layer(folder, fps)
    edits = Sdf.Layer.FindOrOpen(str(folder / layers.EDITS))
    layers.add_edits_time_codes(edits, fps)
    stage.SetEditTarget(Usd.EditTarget(edits))
    for path, name, value in values:
        set_param(stage.GetPrimAtPath(path), name, value, "user")
    layers.save_layer(edits, folder / layers.EDITS)
