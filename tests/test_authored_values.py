"""Every authored material and force-field value is checked against the catalog before anything runs:
one line naming the prim and the attribute, exit 2, the previous simulation kept."""

from __future__ import annotations

import shutil

import pytest
from pxr import Sdf, Usd

from physomni_usd.errors import InputError
from physomni_usd.materials.catalog import CATALOG, PARAMS, material_type
from physomni_usd.physics.checks import check_inputs
from physomni_usd.fields import field_from_values

from .conftest import cli

MATERIAL = "/World/Materials/Physics/cup_0"


def _material_over(body: str) -> str:
    return ('#usda 1.0\nover "World" {\n over "Materials" {\n  over "Physics" {\n   over "cup_0" {\n'
            f"    {body}\n   }}\n  }}\n }}\n}}\n")


FIELD = ('#usda 1.0\nover "World" {{\n def Xform "Gust" (prepend apiSchemas = ["PhysOmniForceFieldAPI"]) {{\n'
         "  {body}\n }}\n}}\n")

CASES = {
    "deformable_density_0": (_material_over('token physomni:materialType = "mpm_elastic"\n'
                                            "    float physics:density = 0"),
                             MATERIAL, "physics:density"),
    "negative_youngs_modulus": (_material_over('token physomni:materialType = "mpm_elastic"\n'
                                               "    float physomni:youngsModulus = -3e5"),
                                MATERIAL, "physomni:youngsModulus"),
    "unknown_force_kind": (FIELD.format(body='token physomni:kind = "tornado"'), "/World/Gust", "physomni:kind"),
    "negative_friction": (_material_over("float physics:dynamicFriction = -1"), MATERIAL, "physics:dynamicFriction"),
    "unknown_material_type": (_material_over('token physomni:materialType = "mpm_jelly"'), MATERIAL,
                              "physomni:materialType"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_value_in_edits_stops_simulate_with_one_line(tmp_path, shot, case):
    text, prim, attr = CASES[case]
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    (folder / "edits.usda").write_text(text)
    before = {name: (folder / name).read_bytes() for name in ("sim.usdc", "physics.usda", "edits.usda")}
    proc = cli("simulate", folder / "shot.usda", "--seconds", "0.2")
    lines = [ln for ln in proc.stderr.splitlines() if ln and not ln.startswith(("TORCH_IMPORTED", "Warp"))]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in proc.stderr, proc.stderr
    assert f"{prim}.{attr}" in lines[0], lines[0]
    assert {name: (folder / name).read_bytes() for name in before} == before


@pytest.fixture()
def stage(shot):
    """The shared shot, opened; edits go to its session layer, so nothing on disk changes."""
    st = Usd.Stage.Open(str(shot["shot"]))
    st.SetEditTarget(st.GetSessionLayer())
    return st


def _material(stage, kind):
    mat = stage.GetPrimAtPath(MATERIAL)
    mat.GetAttribute("physomni:materialType").Set(kind)
    return mat


# (type, parameter, a value outside the catalog's range)
BAD = [("mpm_elastic", "poissons_ratio", 0.5), ("mpm_elastoplastic", "yield_stress", 0.0),
       ("mpm_sand", "friction_angle", 95.0), ("mpm_snow", "critical_compression", 1.5),
       ("mpm_liquid", "viscosity", -1.0), ("pbd_cloth", "stretch_compliance", -1e-7),
       ("pbd_cloth", "bending_compliance", float("nan")), ("pbd_cloth", "air_resistance", 50.0),
       ("pbd_elastic", "relaxation", 0.0), ("pbd_liquid", "density_relaxation", -0.2),
       ("mpm_muscle", "model", "hencky"), ("pbd_particle", "density", 0.0), ("rigid", "restitution", 1.5)]


@pytest.mark.parametrize("kind, key, value", BAD)
def test_every_material_type_checks_its_parameters(stage, kind, key, value):
    mat = _material(stage, kind)
    p = PARAMS[key]
    type_name = Sdf.ValueTypeNames.Token if p.choices else Sdf.ValueTypeNames.Float
    mat.CreateAttribute(p.attr, type_name).Set(value)
    with pytest.raises(InputError) as err:
        check_inputs(stage)
    assert f"{MATERIAL}.{p.attr}" in str(err.value) and p.describe_range() in str(err.value)


def test_good_values_of_every_type_pass(stage):
    for kind in CATALOG:
        mat = _material(stage, kind)
        for key, value in CATALOG[kind].defaults.items():
            p = PARAMS[key]
            mat.CreateAttribute(p.attr, Sdf.ValueTypeNames.Token if p.choices else Sdf.ValueTypeNames.Float).Set(value)
        check_inputs(stage)
    # a rigid body's density 0 keeps its UsdPhysics meaning: "compute it"
    _material(stage, "rigid").GetAttribute("physics:density").Set(0.0)
    check_inputs(stage)


@pytest.mark.parametrize("attr, value, kind", [
    ("physomni:strength", 2e6, "wind"), ("physomni:radius", float("inf"), "wind"),
    ("physomni:falloff", -1.0, "point"), ("physomni:startTime", -0.5, "constant"),
    ("physomni:linearDrag", -0.3, "drag"), ("physomni:direction", (0.0, 0.0, 0.0), "wind"),
    ("physomni:frequency", 0.0, "turbulence"), ("physomni:endTime", 0.5, "constant"),
])
def test_force_field_values_are_checked(stage, attr, value, kind):
    prim = stage.DefinePrim("/World/Gust", "Xform")
    prim.AddAppliedSchema("PhysOmniForceFieldAPI")
    prim.CreateAttribute("physomni:kind", Sdf.ValueTypeNames.Token).Set(kind)
    prim.CreateAttribute("physomni:startTime", Sdf.ValueTypeNames.Float).Set(1.0)
    check_inputs(stage)  # the field itself is fine
    type_name = Sdf.ValueTypeNames.Vector3f if attr == "physomni:direction" else Sdf.ValueTypeNames.Float
    prim.CreateAttribute(attr, type_name).Set(value)
    with pytest.raises(InputError) as err:
        check_inputs(stage)
    assert f"/World/Gust.{attr}" in str(err.value)


def test_force_option_shares_the_field_ranges():
    with pytest.raises(ValueError, match="falloff"):
        field_from_values("point", {"falloff": -2})
    with pytest.raises(ValueError, match="never act"):
        field_from_values("wind", {"start": 2, "end": 1})
    assert field_from_values("point", {"falloff": 2}).falloff == 2


def test_unknown_material_type_is_one_rule():
    """Authored by a person: refused. No type at all: rigid. A VLM reply's unknown type: the fallback."""
    from physomni_usd.materials.parse import parse_reply

    with pytest.raises(ValueError, match="mpm_jelly"):
        material_type("mpm_jelly")
    assert material_type(None) == "rigid"
    config = parse_reply('{"objects": [{"index": 0, "material": "mpm_jelly"}]}', 1)
    assert config.objects[0].material == "mpm_elastic" and "mpm_jelly" in " ".join(config.warnings)
