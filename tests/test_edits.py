"""An artist's edits.usda changes the next simulation and is never rewritten."""

from __future__ import annotations

import shutil

import numpy as np
from pxr import Usd

from .conftest import cli

EDIT = """#usda 1.0
over "World" {{
    over "Objects" {{
        over "{name}" {{
            {body}
        }}
    }}
}}
"""


THROW = """#usda 1.0
over "World" {{
    over "Objects" {{
        over "cup_0" {{
            vector3f physics:velocity = (4, 0, 0)
        }}
        over "box_1" {{
            float physics:density = {density}
        }}
    }}
}}
"""


def _track(folder, name):
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    attr = stage.GetPrimAtPath(f"/World/Objects/{name}").GetAttribute("xformOp:translate")
    return np.array([attr.Get(t) for t in range(int(stage.GetEndTimeCode()) + 1)])


def _simulate_with(folder, edits_text):
    edits = folder / "edits.usda"
    edits.write_text(edits_text)
    original = edits.read_bytes()
    cli("simulate", folder / "shot.usda", "--seconds", "1.5", "-q", check=True)
    assert edits.read_bytes() == original
    return _track(folder, "box_1")


def test_velocity_edit_changes_the_motion(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    before = _track(folder, "box_1")
    after = _simulate_with(folder, EDIT.format(name="box_1", body="vector3f physics:velocity = (0, 1.5, 0)"))
    assert before.shape == after.shape
    assert after[-1, 1] - before[-1, 1] > 0.05


def test_density_edit_changes_the_outcome_of_a_collision(tmp_path, shot):
    # A lone body sliding to rest under Coulomb friction moves the same whatever its
    # mass, so the heavier box is tested where mass matters: the cup is thrown at it.
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    light = _simulate_with(folder, THROW.format(density=20))
    heavy = _simulate_with(folder, THROW.format(density=5000))
    assert light[-1, 0] - heavy[-1, 0] > 0.01  # the light box is knocked further


def test_build_keeps_an_existing_edits_layer(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    edits = folder / "edits.usda"
    edits.write_text(EDIT.format(name="cup_0", body="float physics:density = 900"))
    original = edits.read_bytes()
    cli("build", shot["photo"], "-o", folder, "--mask", f"{shot['cup']}:cup", "-q", check=True)
    assert edits.read_bytes() == original
