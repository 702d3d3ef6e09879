"""The simulator's stepping, through ``simulate`` itself where it can be: restitution, the guard's account
of the work force fields do, and a noise field whose effect does not depend on the step."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import trimesh
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings
from physomni_usd.usd import layers


def _heights(shot, name, frames) -> np.ndarray:
    stage = layers.open_shot(shot)  # held: a prim is valid only while its stage lives
    xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/Objects/{name}"))
    return np.array([xf.ComputeLocalToWorldTransform(f).ExtractTranslation()[2] for f in range(frames)])


@pytest.mark.parametrize("restitution", [0.9, 0.0])
def test_a_ball_thrown_at_the_ground_bounces_as_its_restitution_says(tmp_path, restitution):
    """A 5 cm ball thrown down at 3 m/s from 5 cm above the ground: with restitution 0.9 it rises at
    least 0.1 m afterwards (the ground's 0.1 averages in: e = 0.5), with 0 less than 3 cm."""
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    ball.apply_translation((0.0, 0.0, 0.1))
    shot = write_bench_shot(tmp_path, [BenchObject("ball", ball, "rigid", {"restitution": restitution},
                                                   velocity=(0.0, 0.0, -3.0))])
    report = simulate_shot(shot, SimulateSettings(seconds=0.5))
    rise = _heights(shot, "ball", report["frames"])[1:].max() - 0.05  # above resting on the ground
    if restitution:
        assert rise >= 0.1, rise
    else:
        assert rise < 0.03, rise
