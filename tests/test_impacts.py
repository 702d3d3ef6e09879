"""The restitution passes chosen substep by substep (``physics.impacts``): the full passes where a contact meets
its pair fast, Newton's default in the rest of a fast frame."""

from __future__ import annotations

import collections

import trimesh

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings


def test_a_falling_box_takes_the_full_passes_only_where_it_lands(tmp_path, monkeypatch):
    """A box dropped from 0.5 m: in its fast frames (the per-frame rule's 16 passes) the substeps flagged for
    the full passes are the few around its landing at about 3 m/s, not the ones it falls through the air in."""
    import warp as wp

    from physomni_usd.physics import runner

    monkeypatch.setattr(runner, "CAPTURE", False)  # launch by launch: each substep's choice is seen here
    chosen = collections.Counter()
    branch = wp.capture_if

    def counting(condition, on_true=None, on_false=None, **kw):
        chosen[int(condition.numpy()[0])] += 1
        return branch(condition, on_true=on_true, on_false=on_false, **kw)

    monkeypatch.setattr(wp, "capture_if", counting)
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    box.apply_translation((0.0, 0.0, 0.55))
    shot = write_bench_shot(tmp_path, [BenchObject("box", box, "rigid", {"density": 500.0})])
    report = simulate_shot(shot, SimulateSettings(seconds=0.6))
    fast = chosen[0] + chosen[1]
    assert fast >= 5 * report["substeps"]  # its falling frames went substep by substep
    assert 1 <= chosen[1] <= 2 * report["substeps"], chosen  # the full passes only about the landing
