"""Contacts that meet every impact: restitution acts between two objects, a thin one included, through
``simulate`` itself (its contact cadence, its captured frames)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings
from physomni_usd.usd import layers

THICK = 0.02  # the thrown object's thickness (m)
SAUCER_TOP = 0.015


def _throw(folder, restitution: float):
    """A 8 × 8 × 2 cm tile thrown down at 3 m/s from 5 cm above a 1.5 cm thick disc (a saucer) lying on
    the ground; both with ``restitution``. Returns the tile's and the disc's heights at every frame."""
    saucer = trimesh.creation.cylinder(radius=0.08, height=SAUCER_TOP, sections=24)
    saucer.apply_translation((0.0, 0.0, SAUCER_TOP / 2))
    tile = trimesh.creation.box((0.08, 0.08, THICK))
    tile.apply_translation((0.0, 0.0, SAUCER_TOP + THICK / 2 + 0.05))
    params = {"restitution": restitution, "density": 1000.0}
    shot = write_bench_shot(folder, [BenchObject("saucer", saucer, "rigid", dict(params)),
                                     BenchObject("tile", tile, "rigid", dict(params), velocity=(0.0, 0.0, -3.0))])
    report = simulate_shot(shot, SimulateSettings(seconds=0.6))
    stage = layers.open_shot(shot)

    def z(name):
        xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/Objects/{name}"))
        return np.array([xf.ComputeLocalToWorldTransform(f).ExtractTranslation()[2] for f in range(report["frames"])])

    return z("tile"), z("saucer"), report


def test_a_thin_object_bounces_off_another_as_its_restitution_says(tmp_path):
    """Restitution 0.9 sends the tile at least 3× higher than 0 does, and it never passes into the disc."""
    rises = {}
    for e in (0.9, 0.0):
        tile, saucer, report = _throw(tmp_path / str(e), e)
        rest = saucer + SAUCER_TOP / 2 + THICK / 2  # the tile's centre resting on the disc
        assert (tile - rest).min() > -0.005, (tile - rest).min()  # never more than 5 mm into it
        assert tile[-1] > rest[-1] - 0.005  # and not through it
        first_touch = int(np.argmax(tile - rest < 0.01))
        rises[e] = float((tile - rest)[first_touch:].max())
        assert report["steps"]["restitution"] is True
    assert rises[0.9] >= 3 * max(rises[0.0], 0.01), rises
    assert rises[0.9] > 0.1, rises
