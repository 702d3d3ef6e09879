"""Turning a VLM's free-text reply into a valid :class:`SceneConfig`, whatever the reply holds.

Rules, from the paper with the reference code's defects fixed:

- take the outermost JSON object holding ``"objects"`` (bare, in a fenced
  block or inside prose), else the older form: a bare JSON array of objects;
- objects map back by their ``index`` (mask order); objects the reply does not
  describe, and every object when nothing parses, become ``mpm_elastic``;
- an unknown material becomes ``mpm_elastic`` (``catalog.FALLBACK_TYPE``), with a warning: the
  catalog's one rule for type names, under which only a model's reply falls back and a type a
  person authored is refused; an unknown force kind is dropped;
- numbers and booleans given as strings are converted properly (``"false"``
  is false, ``"3e5"`` is 300000); ``null`` means "not given";
- parameters unknown to the material are dropped and out-of-range values are
  replaced by the material's default, each with a warning;
- ``start_frame`` (−1 = from the start) becomes a start time in seconds;
- ``size_m`` (the object's real longest dimension; a number in metres or a
  string with a unit, '8 cm') outside 1 mm – 1 km is ignored with a warning.

:func:`parse_reply` never raises.
"""

from __future__ import annotations

import json
import math
import re

from ..fields import doubles_gravity, field_from_values, parse_bool
from .catalog import CATALOG, FALLBACK_TYPE, PARAMS, canonical_key, keys_of
from .config import ObjectConfig, SceneConfig

_MATERIAL_KEYS = ("material", "material_type", "type", "materialtype")
_PARAM_KEYS = ("material_params", "params", "parameters", "material_parameters")
_NAME_KEYS = ("name", "identity", "object", "label", "what")


def _json_values(text: str):
    """Every JSON object or array that starts somewhere in ``text``, outermost first."""
    decoder = json.JSONDecoder()
    i, n = 0, len(text)
    while i < n:
        if text[i] in "{[":
            try:
                value, end = decoder.raw_decode(text, i)
            except ValueError:
                i += 1
                continue
            yield value
            i = end
        else:
            i += 1


def find_payload(text: str):
    """``(objects, forces)`` lists from the reply, or ``(None, None)`` when nothing usable is there."""
    arrays = []
    for value in _json_values(text):
        if isinstance(value, dict):
            found = _find_objects_dict(value)
            if found is not None:
                return found.get("objects"), found.get("forces", [])
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            arrays.append(value)
    if arrays:
        return arrays[0], []
    return None, None


def _find_objects_dict(value, depth=0):
    if isinstance(value, dict):
        if "objects" in value:
            return value
        if depth < 3:
            for v in value.values():
                found = _find_objects_dict(v, depth + 1)
                if found is not None:
                    return found
    return None


def to_number(value) -> float | None:
    """A finite float from a number or a numeric string ('3e5', ' 1,000 ', '45°'); None otherwise."""
    if isinstance(value, bool) or value is None:
        return None
    if isinstance(value, (int, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([-+]?(\d[\d,_]*\.?\d*|\.\d+)([eE][-+]?\d+)?)\s*(°|deg|degrees|pa|kg/m\^?3)?\s*",
                         value, re.IGNORECASE)
        if m:
            try:
                number = float(m.group(1).replace(",", "").replace("_", ""))
            except ValueError:
                return None
            return number if math.isfinite(number) else None
    return None


def _get(d: dict, keys):
    for k in keys:
        for key in d:
            if str(key).strip().lower() == k:
                return d[key]
    return None


def _object_config(index: int, item: dict, warnings: list[str]) -> ObjectConfig:
    where = f"object {index}"
    material = _get(item, _MATERIAL_KEYS)
    material = str(material).strip().lower() if material is not None else ""
    if material not in CATALOG:
        warnings.append(f"{where}: unknown material {material!r}, using {FALLBACK_TYPE}")
        material = FALLBACK_TYPE
    raw = _get(item, _PARAM_KEYS)
    raw = raw if isinstance(raw, dict) else {}
    # parameters are sometimes given beside the material rather than inside material_params
    for key, value in item.items():
        if canonical_key(str(key)) is not None and key not in raw:
            raw[key] = value
    params = {}
    allowed = keys_of(material)
    defaults = CATALOG[material].defaults
    for key, value in raw.items():
        k = canonical_key(str(key))
        targets = ("static_friction", "dynamic_friction") if k == "friction" else (k,)
        if k is None or any(t not in allowed for t in targets):
            warnings.append(f"{where}: {material} has no parameter {key!r}; dropped")
            continue
        for t in targets:
            p = PARAMS[t]
            if p.choices:
                v = str(value).strip().lower() if value is not None else None
            elif t == "viscosity" and isinstance(value, (bool, str)) and to_number(value) is None:
                try:  # the paper's boolean 'viscous'
                    v = 1.0 if parse_bool(value) else 0.0
                except ValueError:
                    v = None
            else:
                v = to_number(value)
            if v is None or not p.accepts(v):
                if value is not None:
                    fallback = defaults.get(t, "the default")
                    warnings.append(f"{where}: {t} = {value!r} is outside {p.describe_range()}; using {fallback}")
                continue
            params[t] = v
    fixed = False
    if "fixed" in item:
        try:
            fixed = parse_bool(item["fixed"])
        except ValueError:
            warnings.append(f"{where}: fixed = {item['fixed']!r} is not a boolean; using false")
    color = None
    raw_color = _get(item, ("surface_color", "color", "colour"))
    if isinstance(raw_color, (list, tuple)) and len(raw_color) == 3:
        c = [to_number(x) for x in raw_color]
        if all(x is not None for x in c):
            scale = 255.0 if max(c) > 1.0 else 1.0
            color = tuple(min(max(x / scale, 0.0), 1.0) for x in c)
    size = None
    raw_size = _get(item, _SIZE_KEYS)
    if raw_size is not None:
        size = to_metres(raw_size)
        if size is None or not SIZE_RANGE_M[0] <= size <= SIZE_RANGE_M[1]:
            warnings.append(f"{where}: size = {raw_size!r} is not a length in [{SIZE_RANGE_M[0]:g}, "
                            f"{SIZE_RANGE_M[1]:g}] m; ignored")
            size = None
    name = _get(item, _NAME_KEYS)
    return ObjectConfig(index, material, params, identity=str(name) if name is not None else "", fixed=fixed,
                        color=color, source="vlm", size_m=size)


#: Keys under which a reply gives an object's longest dimension, and the lengths accepted (metres).
_SIZE_KEYS = ("size_m", "size", "longest_m", "longest_dimension_m", "length_m", "size_metres", "size_meters")
SIZE_RANGE_M = (1e-3, 1e3)
_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "km": 1e3, "in": 0.0254, "inch": 0.0254, "inches": 0.0254,
          "ft": 0.3048, "feet": 0.3048, "foot": 0.3048, "metre": 1.0, "metres": 1.0, "meter": 1.0, "meters": 1.0}


def to_metres(value) -> float | None:
    """A length in metres from a number (metres) or a string with a unit ('8 cm', '0.08 m', '3 in'); None if
    it is not one."""
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*([a-zA-Z]*)\s*\.?\s*", value)
        if not m:
            return None
        number, unit = to_number(m.group(1)), m.group(2).lower()
        if number is None or (unit and unit not in _UNITS):
            return None
        out = number * _UNITS.get(unit, 1.0)
    else:
        out = to_number(value)
    return out if out is not None and math.isfinite(out) else None


def _force(item, fps: float, warnings: list[str]):
    if not isinstance(item, dict):
        warnings.append(f"force {item!r} is not an object; dropped")
        return None
    kind = _get(item, ("type", "kind", "force", "name"))
    values = {}
    for key, value in item.items():
        k = str(key).strip().lower()
        if k in ("type", "kind", "force", "name", "description", "reason"):
            continue
        if k in ("start_frame", "end_frame"):
            frame = to_number(value)
            if frame is not None and frame >= 0:
                values["start_time" if k == "start_frame" else "end_time"] = frame / fps
            continue
        if value is None:
            continue
        if isinstance(value, dict):  # {"params": {...}}
            values.update(value)
            continue
        values[k] = value
    try:
        f = field_from_values(str(kind), values)
    except (ValueError, TypeError) as exc:
        warnings.append(f"force {kind!r}: {exc}; dropped")
        return None
    if doubles_gravity(f):
        warnings.append("a constant field equal to gravity was dropped: the scene already applies gravity")
        return None
    return f


def parse_reply(text, n_objects: int, fps: float = 30.0) -> SceneConfig:
    """A valid configuration for ``n_objects`` objects from any reply text. Never raises."""
    warnings: list[str] = []
    try:
        objects, forces = find_payload(text if isinstance(text, str) else str(text))
    except Exception:  # noqa: BLE001 - a reply must never stop the pipeline
        objects, forces = None, None
    if objects is None:
        warnings.append(f"no JSON configuration found in the reply; every object becomes {FALLBACK_TYPE}")
        objects, forces = [], []
    configs: dict[int, ObjectConfig] = {}
    if not isinstance(objects, list):
        warnings.append("'objects' is not a list; ignored")
        objects = []
    for pos, item in enumerate(objects):
        if not isinstance(item, dict):
            warnings.append(f"objects[{pos}] is not an object; ignored")
            continue
        idx = to_number(item.get("index", item.get("id", pos)))
        idx = int(idx) if idx is not None and float(idx).is_integer() else pos
        if not 0 <= idx < n_objects or idx in configs:
            warnings.append(f"objects[{pos}] has index {idx}, which names no object (0..{n_objects - 1}); ignored")
            continue
        try:
            configs[idx] = _object_config(idx, item, warnings)
        except Exception as exc:  # noqa: BLE001
            warnings.append(f"object {idx}: {exc}; using {FALLBACK_TYPE}")
    for i in range(n_objects):
        if i not in configs:
            if objects:
                warnings.append(f"object {i} is missing from the reply; using {FALLBACK_TYPE}")
            configs[i] = ObjectConfig(i, FALLBACK_TYPE, {}, source="vlm")
    fields = []
    for item in (forces if isinstance(forces, list) else []):
        try:
            f = _force(item, fps, warnings)
        except Exception as exc:  # noqa: BLE001
            warnings.append(f"force {item!r}: {exc}; dropped")
            f = None
        if f is not None:
            fields.append(f)
    return SceneConfig([configs[i] for i in range(n_objects)], fields, warnings, "vlm")
