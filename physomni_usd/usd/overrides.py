"""The artist's layer, added to: values a user chose (``estimate --set``, the preview's "Keep settings")
authored as ``over``s in ``edits.usda`` through Sdf, every opinion already there kept, the file replaced
atomically."""

from __future__ import annotations

import pathlib

from pxr import Sdf

from . import layers

_FALLBACK_TYPES = {bool: Sdf.ValueTypeNames.Bool, float: Sdf.ValueTypeNames.Float, int: Sdf.ValueTypeNames.Int,
                   str: Sdf.ValueTypeNames.Token}


def add_overrides(folder: pathlib.Path, values: list[tuple[str, str, object]], source: str = "user", *,
                  mute_sim: bool = False) -> pathlib.Path:
    """Author ``(prim path, attribute name, value)`` triples in ``folder/edits.usda``; returns its path.

    Each attribute takes the type the composed stage gives it (the schema's where it defines it); a
    value already in the layer for that attribute is replaced, everything else in the layer stays.
    Each authored value records ``physomni:source`` in its customData. ``mute_sim``: the types are read
    without the simulation layer (which may then be missing or damaged), as ``estimate`` reads the shot."""
    folder = pathlib.Path(folder)
    stage = layers.open_shot(folder, mute_sim=mute_sim)
    fps = stage.GetTimeCodesPerSecond() or 30.0
    path = layers.ensure_edits_layer(folder, fps)
    edits = Sdf.Layer.FindOrOpen(str(path))
    copy = Sdf.Layer.CreateAnonymous(".usda")
    copy.TransferContent(edits)
    layers.add_edits_time_codes(copy, fps)  # as estimate --set: without a rate USD rescales the layer's samples
    with Sdf.ChangeBlock():
        for prim_path, name, value in values:
            attr = stage.GetAttributeAtPath(Sdf.Path(prim_path).AppendProperty(name))
            type_name = attr.GetTypeName() if attr else _FALLBACK_TYPES[type(value)]
            spec = copy.GetPrimAtPath(prim_path) or Sdf.CreatePrimInLayer(copy, prim_path)
            attr_spec = spec.attributes.get(name) or Sdf.AttributeSpec(spec, name, type_name)
            attr_spec.default = value
            # the nested form USD's SetCustomDataByKey("physomni:source") writes, as estimate --set leaves it
            ours = dict(attr_spec.customData.get("physomni", {}))
            ours["source"] = source
            attr_spec.customData["physomni"] = ours
    layers.save_layer(copy, path)
    return path
