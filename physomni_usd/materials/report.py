"""What the composed stage says about each object's material, value by value, with each value's source."""

from __future__ import annotations

from pxr import Usd, UsdShade

from ..usd.author import OBJECTS
from .catalog import PARAMS


def object_prims(stage: Usd.Stage) -> list[Usd.Prim]:
    """Objects under /World/Objects in mask order (``physomni:maskIndex``), then by name."""
    root = stage.GetPrimAtPath(OBJECTS)
    prims = [p for p in (root.GetChildren() if root else []) if p.HasAPI("PhysOmniObjectAPI")]

    def key(p):
        idx = p.GetAttribute("physomni:maskIndex").Get()
        return (idx if idx is not None else 1 << 30, p.GetName())

    return sorted(prims, key=key)


def bound_material(prim: Usd.Prim) -> Usd.Prim | None:
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
    return mat.GetPrim() if mat else None


def material_report(stage: Usd.Stage, estimator: str) -> dict:
    """``{estimator, objects: {name: {material, source, params: {key: {value, source}}}}}``."""
    out = {}
    for prim in object_prims(stage):
        mat = bound_material(prim)
        if mat is None:
            out[prim.GetName()] = {"material": None}
            continue
        type_attr = mat.GetAttribute("physomni:materialType")
        default_source = mat.GetAttribute("physomni:source").Get() or "rules"
        params = {}
        for key, p in PARAMS.items():
            attr = mat.GetAttribute(p.attr)
            if attr and attr.HasAuthoredValue():
                params[key] = {"value": attr.Get(), "source": attr.GetCustomDataByKey("physomni:source")
                               or default_source}
        material_source = type_attr.GetCustomDataByKey("physomni:source") or default_source
        out[prim.GetName()] = {"label": prim.GetAttribute("physomni:label").Get(),
                               "material": type_attr.Get(), "source": material_source,
                               "fixed": bool(prim.GetAttribute("physomni:fixed").Get()), "params": params}
    return {"estimator": estimator, "objects": out}
