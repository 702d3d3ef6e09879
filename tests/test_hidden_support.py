"""An object the photo shows at rest stays at rest: a lifted mesh whose hidden part would have held it up
(a bench with its far legs behind something) stands on its footprint instead of tipping over."""

from __future__ import annotations

import numpy as np
import trimesh
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.physics.support import needs_support
from physomni_usd.settings import SimulateSettings
from physomni_usd.usd import layers


def _one_legged_bench() -> trimesh.Trimesh:
    """A 0.6 m seat 0.2 m up on the one leg the photo shows, at its left end: the centre of mass hangs
    0.2 m beyond the leg."""
    leg = trimesh.creation.box((0.06, 0.2, 0.2))
    leg.apply_translation((-0.27, 0.0, 0.1))
    seat = trimesh.creation.box((0.6, 0.2, 0.05))
    seat.apply_translation((0.0, 0.0, 0.225))
    return trimesh.util.concatenate([leg, seat])


def _rotation_deg(stage, path, frame) -> float:
    xf = UsdGeom.Xformable(stage.GetPrimAtPath(path))
    r0 = np.array(xf.ComputeLocalToWorldTransform(0).ExtractRotationMatrix())
    r = np.array(xf.ComputeLocalToWorldTransform(frame).ExtractRotationMatrix())
    return float(np.degrees(np.arccos(np.clip((np.trace(r0.T @ r) - 1) / 2, -1, 1))))


def test_an_object_standing_where_the_photo_put_it_stays_put(tmp_path):
    """Nothing pushes it: over 2 s it turns less than 2° and moves less than 1 cm; a ball beside it (its
    contact right under its centre) is left to roll as a ball."""
    bench = _one_legged_bench()
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    ball.apply_translation((1.0, 0.0, 0.1))
    assert needs_support(bench.vertices, bench.faces, 0.0)
    assert not needs_support(ball.vertices, ball.faces, 0.0)
    shot = write_bench_shot(tmp_path, [BenchObject("bench", bench, "rigid", {"density": 500.0}),
                                       BenchObject("ball", ball, "rigid", {"density": 500.0})])
    report = simulate_shot(shot, SimulateSettings(seconds=2.0))
    stage = layers.open_shot(shot)
    last = report["frames"] - 1
    assert _rotation_deg(stage, "/World/Objects/bench", last) < 2.0
    xf = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Objects/bench"))
    moved = xf.ComputeLocalToWorldTransform(last).ExtractTranslation() - xf.ComputeLocalToWorldTransform(0).ExtractTranslation()
    assert moved.GetLength() < 0.01
