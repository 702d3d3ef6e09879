"""The shot's contract: which prims are its objects and which physics material each is bound to.

Every stage that reads objects (physics, the backends, the preview, validation) finds them here, so that
"an object" means one thing across the package: a child of ``/World/Objects`` with ``PhysOmniObjectAPI``,
in mask order, bound to its physics material through the ``physics`` purpose. The artist's own values
on those materials are authored by :func:`physomni_usd.usd.overrides.add_overrides`.
"""

from __future__ import annotations

from pxr import Usd, UsdShade

from .author import OBJECTS

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
