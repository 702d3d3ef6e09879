"""Every object can be made cloth: a lifted mesh is made fit for the cloth solver (``physics/cloth.py``:
:func:`cloth_sheet`, the particles' masses and the springs' damping). The cup, saucer and spoon photo of
``test_cup_saucer`` is built from its masks; its spoon is a 3 mm extruded outline whose triangles run from slivers
of no area to 4 cm. Switched to ``pbd_cloth`` it diverged in its first frame (6,017 J from 3.1 J, even at 1,184
substeps a frame), and the cup made a light cloth (4 kg/m²) did too; both now simulate."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Usd

import physomni_usd as api
from physomni_usd.metrics.geometry import world_meshes
from physomni_usd.physics.cloth import CLOTH_MIN_QUALITY, cloth_sheet, triangle_quality
from physomni_usd.settings import SimulateSettings


@pytest.fixture(scope="module")
def cup_saucer(cup_saucer_build):
    return cup_saucer_build["out"]  # the session's build, which tests/test_cup_saucer.py checks


def test_the_sheet_has_no_sliver_and_a_sensible_resolution_and_the_surface_follows_it(cup_saucer):
    meshes = world_meshes(Usd.Stage.Open(str(cup_saucer / "shot.usda")), 0)
    spoon = meshes["spoon_2"]
    assert triangle_quality(spoon.vertices, spoon.faces).min() < 0.01  # the lifted mesh has slivers
    for name, mesh in meshes.items():
        sheet = cloth_sheet(mesh.vertices, mesh.faces)
        assert triangle_quality(sheet.particles, sheet.triangles).min() >= CLOTH_MIN_QUALITY, name
        edges = np.linalg.norm(sheet.particles[sheet.triangles] - sheet.particles[np.roll(sheet.triangles, 1, 1)],
                               axis=2)
        diagonal = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
        assert diagonal / 40 <= np.median(edges) <= diagonal / 8, name
        assert edges.max() <= diagonal / 3 and edges.min() >= diagonal / 100, name
        # at rest each surface vertex is where the photo put it
        assert np.allclose(sheet.particles[sheet.index] + sheet.offset, mesh.vertices), name
        assert len(np.unique(sheet.triangles)) == len(sheet.particles), name  # no particle without a triangle


@pytest.mark.parametrize("sets", [["spoon.material=pbd_cloth"],
                                  ["cup.material=pbd_cloth", "cup.density=4"]], ids=["spoon", "light-cup"])
def test_an_object_made_cloth_simulates_without_nan_or_guard_stop(cup_saucer, tmp_path, sets):
    import shutil

    shot = tmp_path / "shot"
    shutil.copytree(cup_saucer, shot)
    api.estimate(shot / "shot.usda", sets=sets)
    section = api.simulate(shot / "shot.usda", SimulateSettings(seconds=0.2))  # it diverged in frame 1
    assert section["frames"] == 7
    stage = Usd.Stage.Open(str(shot / "shot.usda"))
    name = sets[0].split(".")[0]
    points = stage.GetPrimAtPath(f"/World/Objects/{name}_{'2' if name == 'spoon' else '1'}").GetAttribute("points")
    last = np.asarray(points.Get(stage.GetEndTimeCode()))
    first = np.asarray(points.Get(0))
    assert np.isfinite(last).all()
    # a cloth lying where it lay sags and settles: it does not fly off
    assert np.abs(last - first).max() < 0.05
