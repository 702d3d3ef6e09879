"""Every object can be made any material kind (issue 38, part 1): on the desk example, built from its boxes with
nothing pushed, each object is switched in turn to ``rigid``, ``mpm_elastic``, ``mpm_sand`` and ``pbd_cloth``
(``estimate --set NAME.material=KIND``) and the shot simulated 1 s at its own resolution. Four runs cover every
pair: in run ``r`` object ``k`` is kind ``(k + r) mod 4``, so each run mixes the solvers as a user's edits
would. Each run must end (no guard stop: ``simulate`` raises on one), write only finite values, and give each
object the solver its kind asks for; the MPM objects take the default particle spacing, which must stay coarse
enough for a second of five small objects to be simulated in minutes."""

from __future__ import annotations

import json
import pathlib
import shutil

import pytest

import physomni_usd as api
from physomni_usd.bench.general import _non_finite
from physomni_usd.settings import SimulateSettings
from physomni_usd.usd import layers

#: Five objects, four 1 s runs of mixed solvers: several minutes on a loaded 2-core machine.
pytestmark = pytest.mark.slow

KINDS = ("rigid", "mpm_elastic", "mpm_sand", "pbd_cloth")
FAMILY = {"rigid": "rigid", "mpm_elastic": "mpm", "mpm_sand": "mpm", "pbd_cloth": "cloth"}
DESK = pathlib.Path(__file__).resolve().parents[1] / "examples" / "desk"


@pytest.fixture(scope="module")
def desk(built_case):
    # the session's build of the desk (tests/conftest.py), its boxes as example.json gives them: the same build
    # tests/test_examples_frame0.py checks, made once
    spec = json.loads((DESK / "example.json").read_text())
    assert not spec.get("masks") and not spec.get("size"), "the desk is meant to be built from its boxes alone"
    result, _ = built_case("example:desk")
    names = [o["name"] for o in json.loads((result.folder / "report.json").read_text())["objects"]]
    assert len(names) == len(spec["boxes"]), names
    return result.folder, names


@pytest.mark.parametrize("turn", range(len(KINDS)))
def test_each_object_made_each_kind_simulates_a_second(desk, turn, tmp_path):
    folder, names = desk
    shot = tmp_path / "shot"
    shutil.copytree(folder, shot)
    kinds = {n: KINDS[(k + turn) % len(KINDS)] for k, n in enumerate(names)}
    api.estimate(shot / layers.SHOT, sets=[f"{n}.material={kind}" for n, kind in kinds.items()])
    section = api.simulate(shot / layers.SHOT, SimulateSettings(seconds=1.0))
    bad = _non_finite(layers.open_shot(shot))
    assert not bad, f"{kinds}: non-finite values in {bad[:3]}"
    got = {n: (o["material"], o["solver"]) for n, o in section["objects"].items()}
    assert got == {n: (kind, FAMILY[kind]) for n, kind in kinds.items()}, got
    print(f"{kinds}: {section['seconds']} s, "
          f"mpm {section.get('mpm')}")  # the figures, under -s
