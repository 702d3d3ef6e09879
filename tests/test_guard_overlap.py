"""The guard's roll-back to a state that holds an overlap (physics/runner.py GuardedRun, depenetration.py
Depenetration.rearm): a coarse step can leave a hull's edge a millimetre inside what it rests on between two
contact searches, and the finer step the guard retries with separated it at d/dt — faster the finer the step,
so that a cup resting on a book diverged for being stepped more finely."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics import runner
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import SimulateSettings

SINK_M = 0.0015  # how far the cup's rim is put into the book at the checkpoint
AT_FRAME = 10  # a frame the guard checks (every 5th after the first 5)


def _cup_on_book():
    book = trimesh.creation.box((0.2, 0.15, 0.03))
    book.apply_translation((0.0, 0.0, 0.015))
    cup = trimesh.creation.cylinder(radius=0.04, height=0.09, sections=24)
    cup.apply_translation((0.0, 0.0, 0.03 + 0.045))
    # the book lighter than the cup, as in the scene it comes from: the overlap's pop-out then survives the
    # restitution pass (a heavy book under a light cup separated calmly even without the bound)
    return [BenchObject("book", book, "rigid", {"density": 200.0}),
            BenchObject("cup", cup, "rigid", {"density": 600.0})]


def test_a_roll_back_to_an_overlap_does_not_separate_it_faster_at_the_finer_step(tmp_path, monkeypatch):
    """At frame 10 the cup is tipped so that its rim sinks 1.5 mm into the book, and that state is the one the
    guard keeps; the next check is made to fail once, so the run goes back to it at twice the substeps. The
    finer step must separate the overlap at the bounded speed: the run ends, and nothing moves faster than
    what separating and a 1 cm fall could give."""
    check = runner.GuardedRun._check
    state = {"tipped": False, "failed": False}

    def tipping(self):
        st = self.stepper
        if self.frame == AT_FRAME and not state["tipped"]:
            state["tipped"] = True
            q = st.state.body_q.numpy().copy()
            cup = 1
            # tip the cup about the horizontal axis through its base's centre until one rim point sinks SINK_M
            angle = np.arcsin(SINK_M / 0.04)
            base = q[cup, :3] - np.array([0.0, 0.0, 0.045])
            turn = Rotation.from_rotvec((angle, 0.0, 0.0))
            q[cup, :3] = base + turn.apply(q[cup, :3] - base)
            q[cup, 3:7] = (turn * Rotation.from_quat(q[cup, 3:7])).as_quat()
            st.state.body_q.assign(q)
        if self.frame > AT_FRAME and not state["failed"] and self.frame % self.check_every == 0:
            state["failed"] = True
            self.guard.initial -= 1.0  # this check fails once: the run goes back to the tipped state
            try:
                return check(self)
            finally:
                self.guard.initial += 1.0
        return check(self)

    monkeypatch.setattr(runner.GuardedRun, "_check", tipping)
    report = simulate_shot(write_bench_shot(tmp_path, _cup_on_book()), SimulateSettings(seconds=0.8))
    assert state["failed"] and len(report["guard"]["rollbacks"]) >= 1
    assert "overlaps up to" in report["guard"]["rollbacks"][0]["found"]
    assert report["max_speed_m_s"] <= 0.1 + np.sqrt(2 * 9.81 * 0.01), report["max_speed_m_s"]


def test_a_roll_back_inside_the_start_window_keeps_what_it_bounds(tmp_path, monkeypatch):
    """Two cups start inside a book, one 5 mm deep, one 0.5 mm (below what a roll-back re-arms). The first
    check is made to fail, so the run goes back to t = 0 with the start window open: the re-arm for the deep
    cup widens that window and must keep the shallow cup (and the book) in it, not replace it by the deep
    overlap's bodies alone."""
    check = runner.GuardedRun._check
    state = {"failed": False}

    def failing_once(self):
        if not state["failed"]:
            state["failed"] = True
            self.guard.initial -= 1.0
            try:
                return check(self)
            finally:
                self.guard.initial += 1.0
        return check(self)

    book = trimesh.creation.box((0.3, 0.15, 0.03))
    book.apply_translation((0.0, 0.0, 0.015))
    objects = [BenchObject("book", book, "rigid", {"density": 200.0})]
    for name, x, sink in (("deep", -0.08, 0.005), ("shallow", 0.08, 0.0005)):
        cup = trimesh.creation.cylinder(radius=0.04, height=0.09, sections=24)
        cup.apply_translation((x, 0.0, 0.03 + 0.045 - sink))
        objects.append(BenchObject(name, cup, "rigid", {"density": 600.0}))
    monkeypatch.setattr(runner.GuardedRun, "_check", failing_once)
    report = simulate_shot(write_bench_shot(tmp_path, objects), SimulateSettings(seconds=0.3))
    bound = report["guard"]["depenetration"]
    assert state["failed"] and bound["rearmed"] >= 1, report["guard"]
    assert bound["bodies"] == 3, bound
