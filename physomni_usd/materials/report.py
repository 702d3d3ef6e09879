"""What the composed stage says about each object's material, value by value, with each value's source."""

from __future__ import annotations

from pxr import Usd

from ..usd.contract import bound_material, object_prims
from .catalog import PARAMS


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
