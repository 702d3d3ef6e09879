"""The guard's count of rigid contacts (physics/stability.py ContactTally, runner GuardedRun): logged on the
solver's device at each check passed and read back once per take, with the numbers a read-back at every check
gives (report ``guard.rigid_contacts``)."""

from __future__ import annotations

import numpy as np

from physomni_usd.bench.scenes import falling_boxes, write_bench_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.physics.stability import ContactTally
from physomni_usd.settings import SimulateSettings


def test_the_tally_keeps_every_count_in_order_past_its_first_log():
    import warp as wp

    tally = ContactTally()
    assert tally.summary() is None
    count = wp.zeros(1, dtype=wp.int32, device="cpu")
    values = [(7 * i) % 23 for i in range(150)]  # past the first log of 64 and its first doubling
    for v in values:
        count.fill_(v)
        tally.add(count)
    assert tally.counts().tolist() == values
    assert tally.summary() == {"mean": round(float(np.mean(values)), 1), "max": max(values), "checks": 150}


def test_the_report_counts_what_a_read_back_at_each_check_reads(tmp_path, monkeypatch):
    read = []
    add = ContactTally.add

    def reading(self, count):  # the count read back where the check logs it: what the guard used to do
        read.append(int(count.numpy()[0]))
        add(self, count)

    monkeypatch.setattr(ContactTally, "add", reading)
    shot = write_bench_shot(tmp_path / "boxes", falling_boxes(6))
    report = simulate_shot(shot, SimulateSettings(seconds=1.0))
    counted = report["guard"]["rigid_contacts"]
    assert len(read) > 5 and max(read) > 0 and len(set(read)) > 1  # boxes in the air, then on the ground
    assert counted == {"mean": round(float(np.mean(read)), 1), "max": max(read), "checks": len(read)}
