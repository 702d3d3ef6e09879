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


SPOON = (0.16, 0.025, 0.005)  # a spoon-like bar, 5 mm thick (m)


def _throw_spoon(folder, support, shape: str, restitution: float, seconds: float):
    """A steel spoon (:data:`SPOON`) lying flat, thrown down at 3 m/s from 5 cm above the top of ``support`` (a
    2000 kg/m³ mesh lying on the ground, lifted as ``shape``); both with ``restitution``. Returns the spoon's
    and the support's heights at every frame."""
    spoon = trimesh.creation.box(SPOON)
    spoon.apply_translation((0.0, 0.0, support.bounds[1][2] + SPOON[2] / 2 + 0.05))
    params = {"restitution": restitution}
    shot = write_bench_shot(folder, [
        BenchObject("saucer", support, "rigid", dict(params, density=2000.0), shape=shape),
        BenchObject("spoon", spoon, "rigid", dict(params, density=7800.0), velocity=(0.0, 0.0, -3.0))])
    report = simulate_shot(shot, SimulateSettings(seconds=seconds))
    stage = layers.open_shot(shot)

    def z(name):
        xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"/World/Objects/{name}"))
        return np.array([xf.ComputeLocalToWorldTransform(f).ExtractTranslation()[2] for f in range(report["frames"])])

    return z("spoon"), z("saucer")


def _first_rise(height: np.ndarray, rest: np.ndarray) -> float:
    """How far (m) above where it rests the spoon's centre rises after it first comes within 1 cm of it."""
    first_touch = int(np.argmax(height - rest < 0.01))
    return float((height - rest)[first_touch:].max())


def test_a_thin_object_on_a_curved_support_does_not_bounce_at_restitution_0(tmp_path):
    """Onto a saucer (an open vessel, collided as convex pieces: its floor and the slope of its wall) the spoon
    stops where it lands: the saucer pressed between it and the ground gives back no bounce."""
    from physomni_usd.lift.vessel import vessel_mesh

    saucer = vessel_mesh(np.zeros(2), 0.05, 0.075, 0.018)  # the spoon's ends land on the wall's slope
    spoon, _ = _throw_spoon(tmp_path, saucer, "vessel", 0.0, seconds=0.6)
    assert abs(spoon[-1] - spoon[-4]) < 1e-4  # at rest by the end: where it rests
    assert _first_rise(spoon, np.full_like(spoon, spoon[-1])) < 0.005


def test_a_thin_object_lying_flat_bounces_off_a_flat_support_as_its_restitution_says(tmp_path):
    """Onto a 5 mm plate at restitution 0.9 the spoon rises at least half of e²v²/2g (v = 3.16 m/s on
    arrival: 0.41 m ideal)."""
    plate = trimesh.creation.cylinder(radius=0.08, height=0.005, sections=24)
    plate.apply_translation((0.0, 0.0, 0.0025))
    spoon, saucer = _throw_spoon(tmp_path, plate, "extrude", 0.9, seconds=0.5)
    v = np.hypot(3.0, np.sqrt(2 * 9.81 * 0.05))
    assert _first_rise(spoon, saucer + 0.0025 + SPOON[2] / 2) >= 0.5 * 0.9 ** 2 * v ** 2 / (2 * 9.81)


def test_a_thin_object_lying_flat_does_not_bounce_off_a_flat_support_at_restitution_0(tmp_path):
    """The same throw at restitution 0: the contact's position correction gives back no bounce (it rises
    under 5 mm, where 0.9 sends it up 0.2 m or more)."""
    plate = trimesh.creation.cylinder(radius=0.08, height=0.005, sections=24)
    plate.apply_translation((0.0, 0.0, 0.0025))
    spoon, saucer = _throw_spoon(tmp_path, plate, "extrude", 0.0, seconds=0.5)
    rest = saucer + 0.0025 + SPOON[2] / 2  # the spoon's centre lying on the plate
    assert abs(spoon[-1] - rest[-1]) < 0.003  # it ends lying on the plate, not through it
    assert _first_rise(spoon, rest) < 0.005
