"""The VLM reply parser: the paper's forms, the reference code's defects, and any text at all."""

from __future__ import annotations

import json

from hypothesis import given, settings
from hypothesis import strategies as st

from physomni_usd.materials.catalog import CATALOG, check_params
from physomni_usd.materials.parse import parse_reply
from physomni_usd.fields import KINDS

VALID = {"objects": [
    {"index": 0, "name": "rubber duck", "material": "mpm_elastic",
     "material_params": {"E": 1e6, "nu": 0.45, "rho": 1100}, "fixed": False, "surface_color": [1, 0.9, 0.1]},
    {"index": 1, "name": "table", "material": "rigid", "material_params": {"rho": 700}, "fixed": True},
], "forces": [{"type": "wind", "direction": [1, 0, 0], "strength": 3, "start_frame": 30}]}


def test_valid_reply():
    cfg = parse_reply(json.dumps(VALID), 2, fps=30)
    duck, table = cfg.objects
    assert duck.material == "mpm_elastic" and duck.params["youngs_modulus"] == 1e6
    assert duck.params["poissons_ratio"] == 0.45 and duck.params["density"] == 1100
    assert table.fixed is True and table.params["density"] == 700
    assert len(cfg.forces) == 1 and cfg.forces[0].kind == "wind" and cfg.forces[0].start_time == 1.0
    assert cfg.warnings == []


def test_fenced_block_inside_prose():
    text = "Sure! Here it is:\n```json\n" + json.dumps(VALID) + "\n```\nHope this helps {not json}."
    assert parse_reply(text, 2).objects[0].material == "mpm_elastic"


def test_legacy_bare_array():
    text = json.dumps([{"index": 1, "material": "mpm_sand"}, {"index": 0, "material": "pbd_cloth"}])
    cfg = parse_reply(text, 2)
    assert [o.material for o in cfg.objects] == ["pbd_cloth", "mpm_sand"]


def test_strings_are_converted_properly():
    text = json.dumps({"objects": [{"index": 0, "material": "rigid", "fixed": "false",
                                    "material_params": {"rho": "2.5e3", "friction": "0.4"}}], "forces": []})
    obj = parse_reply(text, 1).objects[0]
    assert obj.fixed is False  # the reference code made "false" true
    assert obj.params["density"] == 2500 and obj.params["static_friction"] == 0.4


def test_out_of_range_and_unknowns_fall_back_with_warnings():
    text = json.dumps({"objects": [
        {"index": 0, "material": "mpm_elastic", "material_params": {"nu": 0.5, "E": -3, "rho": None, "hue": 3}},
        {"index": 1, "material": "plasma"}],
        "forces": [{"type": "tornado", "strength": 3}, {"type": "constant", "direction": [0, 0, -1], "strength": 9.8}]})
    cfg = parse_reply(text, 3)
    elastic, plasma, missing = cfg.objects
    assert elastic.params == check_params("mpm_elastic", {})
    assert plasma.material == "mpm_elastic" and missing.material == "mpm_elastic"
    assert cfg.forces == []
    joined = " ".join(cfg.warnings)
    for needle in ("poissons_ratio", "youngs_modulus", "hue", "plasma", "tornado", "gravity", "object 2"):
        assert needle in joined


def test_garbage_gives_the_fallback():
    cfg = parse_reply("I cannot help with that.", 2)
    assert [o.material for o in cfg.objects] == ["mpm_elastic", "mpm_elastic"] and cfg.forces == []


json_scalars = st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | st.text(max_size=8)
json_values = st.recursive(json_scalars, lambda inner: st.lists(inner, max_size=4) |
                           st.dictionaries(st.sampled_from(["index", "material", "material_params", "fixed",
                                                            "forces", "objects", "type", "strength", "E", "nu",
                                                            "rho", "direction", "start_frame", "x"]), inner,
                                           max_size=5), max_leaves=20)


def _assert_valid(cfg, n):
    assert len(cfg.objects) == n
    for i, obj in enumerate(cfg.objects):
        assert obj.index == i and obj.material in CATALOG
        assert check_params(obj.material, obj.params) == obj.params
        assert isinstance(obj.fixed, bool)
    for f in cfg.forces:
        assert f.kind in KINDS


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=400), st.integers(min_value=0, max_value=4))
def test_any_text_gives_a_valid_configuration(text, n):
    _assert_valid(parse_reply(text, n), n)


@settings(max_examples=300, deadline=None)
@given(json_values, st.integers(min_value=0, max_value=4))
def test_any_json_gives_a_valid_configuration(value, n):
    text = json.dumps({"objects": value} if not isinstance(value, dict) else value, allow_nan=True)
    _assert_valid(parse_reply("reply: " + text, n), n)
