"""Every parameter an object's type takes either acts in the simulation or simulate says, per object,
that it was ignored or clamped and why."""

from __future__ import annotations

import json
import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from pxr import Usd

from physomni_usd.materials.catalog import CATALOG
from physomni_usd.physics.cloth import AirDrag
from physomni_usd.physics.objects import family_of
from physomni_usd.physics.params import ignored_parameters

from .conftest import cli


def _obj(kind, name="thing", **params):
    return SimpleNamespace(kind=kind, family=family_of(kind), name=name, path=f"/World/Objects/{name}",
                           params={**CATALOG[kind].defaults, **params})


def _listed(kind, **params):
    return {i["param"]: i for i in ignored_parameters([_obj(kind, **params)]).get("thing", [])}


def test_each_unused_parameter_is_listed_with_why():
    assert set(_listed("pbd_liquid")) == {"density_relaxation", "viscosity_relaxation"}
    assert "bending_compliance" in _listed("pbd_elastic")
    # a soft body's relaxation acts (the catalog's 0.1); one the solver cannot run as given is listed
    assert "relaxation" not in _listed("pbd_elastic")
    assert "ran as 0.1" in _listed("pbd_elastic", relaxation=0.9)["relaxation"]["why"]
    assert "no position-based fluid" in _listed("pbd_liquid")["density_relaxation"]["why"]
    assert _listed("mpm_muscle")["model"]["value"] == "neo_hookean"
    assert "model" not in _listed("mpm_elastic") and "model" in _listed("mpm_elastic", model="linear")
    # cloth compliance beyond what the stiffness clamp lets through, both ways
    cloth = _listed("pbd_cloth", stretch_compliance=1e-7, bending_compliance=1e-5)
    assert "clamped to 0.01" in cloth["stretch_compliance"]["why"]
    assert "clamped to 0.1" in cloth["bending_compliance"]["why"]
    assert "clamped to 0.1 " in _listed("pbd_cloth", stretch_compliance=0.5)["stretch_compliance"]["why"]
    assert "stretch_compliance" not in _listed("pbd_cloth", stretch_compliance=0.05)
    assert "air_resistance" not in cloth  # it acts (a drag on the particles)
    # friction: MPM particles take none; Newton has one coefficient per contact
    assert {"dynamic_friction", "restitution"} <= set(_listed("mpm_sand", dynamic_friction=0.4, restitution=0.2))
    assert "static_friction" in _listed("rigid", static_friction=0.9, dynamic_friction=0.5)
    assert _listed("rigid") == {}


def test_only_values_a_person_or_an_estimator_authored_are_said():
    from physomni_usd.physics.params import authored

    thing = _obj("rigid", static_friction=0.9, dynamic_friction=0.5)
    thing.sources = {"static_friction": "rules", "dynamic_friction": "rules"}
    items = ignored_parameters([thing])["thing"]
    assert [i["source"] for i in items] == ["rules"] and authored(items) == []
    for who in ("user", "vlm"):
        thing.sources["static_friction"] = who
        assert [i["param"] for i in authored(ignored_parameters([thing])["thing"])] == ["static_friction"]


def test_particle_objects_that_disagree_on_friction_are_named():
    a, b = _obj("pbd_cloth", "a", dynamic_friction=0.3), _obj("pbd_elastic", "b", dynamic_friction=0.6)
    out = ignored_parameters([a, b])
    assert "dynamic_friction" not in [i["param"] for i in out.get("a", [])]
    assert "ran with 0.3" in next(i["why"] for i in out["b"] if i["param"] == "dynamic_friction")


def test_air_resistance_is_a_drag_on_the_cloth_particles():
    """Falling particles under air resistance c follow z = z0 − (g/c)(t − (1 − e^{−ct})/c)."""
    import newton

    c, g, seconds, dt = 4.0, 9.81, 0.5, 1.0 / 600
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=(0.0, 0.0, -g))
    for i in range(4):
        builder.add_particle((i * 0.1, 0.0, 5.0), (0.0, 0.0, 0.0), mass=0.02, radius=0.01)
    builder.add_particle((0.0, 1.0, 5.0), (0.0, 0.0, 0.0), mass=0.02, radius=0.01)  # not the cloth's
    model = builder.finalize(device="cpu")
    cloth = SimpleNamespace(family="cloth", path="/c", params={"air_resistance": c})
    air = AirDrag.of([cloth], {"/c": (0, 4)}, model.particle_count, "cpu")
    solver = newton.solvers.SolverXPBD(model, iterations=2)
    a, b = model.state(), model.state()
    for _ in range(int(round(seconds / dt))):
        a.clear_forces()
        air.apply(model, a)
        solver.step(a, b, model.control(), None, dt)
        a, b = b, a
    z = a.particle_q.numpy()[:, 2]
    want = 5.0 - g / c * (seconds - (1 - np.exp(-c * seconds)) / c)
    assert np.allclose(z[:4], want, atol=0.01 * (5.0 - want))
    assert z[4] == pytest.approx(5.0 - 0.5 * g * seconds ** 2, abs=0.02)  # free fall beside it
    assert AirDrag.of([SimpleNamespace(family="cloth", path="/c", params={"air_resistance": 0.0})],
                      {"/c": (0, 4)}, 5, "cpu") is None


def _cloth_run(tmp_path, shot, air):
    out = tmp_path / f"air{air}"
    shutil.copytree(shot["dir"], out)
    # the stretch compliance the user sets is the catalog's: said because the user set it
    cli("estimate", out / "shot.usda", "--set", "cup.material=pbd_cloth", "--set", f"cup.air_resistance={air}",
        "--set", "cup.stretch_compliance=1e-7", check=True)
    proc = cli("simulate", out / "shot.usda", "--seconds", "0.3", check=True)
    report = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    pts = stage.GetPrimAtPath("/World/Objects/cup_0").GetAttribute("points")
    return proc, report, np.array(pts.Get(0)), np.array(pts.Get(stage.GetEndTimeCode()))


def test_simulate_says_what_it_ignored_and_air_resistance_acts(tmp_path, shot):
    proc, report, first, last = _cloth_run(tmp_path, shot, 8)
    listed = {i["param"]: i for i in report["ignored_parameters"]["cup_0"]}
    assert "stretch_compliance" in listed and "air_resistance" not in listed
    line = next(ln for ln in proc.stderr.splitlines() if ln.startswith("simulate: cup_0:"))
    assert "stretch_compliance = 1e-07 is clamped" in line
    # the bending compliance is the catalog's and nobody set it: listed in the report, not said
    assert listed["bending_compliance"]["source"] == "default" and "bending_compliance" not in line
    assert listed["stretch_compliance"]["source"] == "user"
    _, _, first0, last0 = _cloth_run(tmp_path, shot, 0)
    drop, drop_still_air = (first - last)[:, 2].mean(), (first0 - last0)[:, 2].mean()
    assert drop_still_air > 0.02 and drop < 0.9 * drop_still_air, (drop, drop_still_air)
