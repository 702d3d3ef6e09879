"""The guard tells a force field's work from divergence: a wind that speeds a box up is named in the
report's diagnoses as the cause of the growth, and the step is kept, not refined."""

from __future__ import annotations

import trimesh

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.fields import field_from_values
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings


def _box_in_wind(folder, strength: float):
    box = trimesh.creation.box((0.2, 0.2, 0.2))
    box.apply_translation((0.0, 0.0, 0.1))
    wind = field_from_values("wind", {"strength": strength, "direction": (1.0, 0.0, 0.0)})
    return write_bench_shot(folder, [BenchObject("box", box, "rigid", {"density": 500.0})], forces=[wind])


def test_a_wind_that_adds_energy_is_named_and_the_step_kept(tmp_path):
    s = simulate_shot(_box_in_wind(tmp_path, 30.0), SimulateSettings(seconds=1.0))
    guard = s["guard"]
    assert guard["rollbacks"] == []  # kept, not refined
    named = [d for d in guard["diagnoses"] if d["cause"] == "field"]
    assert len(named) == 1, guard["diagnoses"]
    d = named[0]
    assert d["fields"].startswith("wind") and "wind" in d["found"]
    # the growth is real (the box slides) and no more than the work the wind was counted doing
    assert 0.1 < d["energy_growth_j"] <= d["work_j"] * (1 + guard["tolerance"]) + 1e-6
    assert s["max_speed_m_s"] > 0.5
