"""The restitution passes chosen substep by substep (``physics.impacts``): the full passes where a contact meets
its pair fast, Newton's default in the rest of a fast frame; and the passes after one that changed nothing
skipped without changing the result."""

from __future__ import annotations

import collections

import pytest
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
        if on_false is not None:  # the substep's choice (the passes' gate branches one way only)
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


def _drop_onto_box(tmp_path, monkeypatch, gated: bool, capture: bool):
    """A box dropped from 0.4 m onto another lying on the ground, stepped launch by launch or from captured
    frames; returns every frame's poses and how many restitution passes were launched (recorded, where
    captured)."""
    import warp as wp

    from physomni_usd.physics import recording, runner
    from physomni_usd.physics.stepping import Stepper

    monkeypatch.setattr(runner, "CAPTURE", capture)
    if not gated:
        monkeypatch.setattr(Stepper, "_make_gate", lambda self: None)
    passes = collections.Counter()
    launch = wp.launch

    def counting(kernel=None, *a, **kw):
        passes[getattr(kernel, "key", "")] += 1
        return launch(kernel, *a, **kw)

    monkeypatch.setattr(wp, "launch", counting)
    seen = []
    init = recording.Recorder.__init__

    def keep(self, *a, **kw):
        init(self, *a, **kw)
        seen.append(self)

    monkeypatch.setattr(recording.Recorder, "__init__", keep)
    lower = trimesh.creation.box((0.2, 0.2, 0.1))
    lower.apply_translation((0.0, 0.0, 0.05))
    upper = trimesh.creation.box((0.1, 0.1, 0.1))
    upper.apply_translation((0.03, 0.0, 0.5))
    objects = [BenchObject("lower", lower, "rigid", {"density": 500.0}),
               BenchObject("upper", upper, "rigid", {"density": 500.0, "restitution": 0.5})]
    shot = write_bench_shot(tmp_path / f"{'gated' if gated else 'plain'}-{capture}", objects)
    simulate_shot(shot, SimulateSettings(seconds=0.7))
    return seen[-1].body_q.copy(), passes["solve_manifold_restitution"]


@pytest.mark.parametrize("capture", [False, True], ids=["launched", "captured"])
def test_the_passes_after_one_that_changed_nothing_are_skipped_with_the_same_result(tmp_path, monkeypatch,
                                                                                    capture):
    """The gate (``impacts.PassGate``) leaves every recorded pose bit for bit as Newton's full loop gives it,
    launch by launch and replayed from captured frames, and launches fewer passes (fails if it skipped a pass
    that mattered, or never skipped one). Captured, a replay runs what was recorded, so only the poses are
    compared."""
    import numpy as np

    with monkeypatch.context() as m:
        plain, plain_passes = _drop_onto_box(tmp_path, m, gated=False, capture=False)
    with monkeypatch.context() as m:
        gated, gated_passes = _drop_onto_box(tmp_path, m, gated=True, capture=capture)
    assert np.array_equal(plain, gated)
    assert float(np.ptp(plain[:, 1, 2])) > 0.2  # the upper box fell and landed: there were passes to skip
    if not capture:
        assert 0 < gated_passes < plain_passes, (gated_passes, plain_passes)
