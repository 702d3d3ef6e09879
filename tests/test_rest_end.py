"""A take that comes to rest early ends a second after the last motion when its length was not asked for:
the video is not a photo held still for seconds."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import trimesh
from pxr import UsdGeom

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.runner import at_rest
from physomni_usd.physics.simulate import simulate_shot
from physomni_usd.settings import REST_SECONDS, SimulateSettings
from physomni_usd.usd import layers


def _slide(folder, rest_seconds):
    """A 10 cm box pushed along the ground at 1 m/s (friction 0.5 stops it in about 0.2 s), simulated for 3 s.
    Returns the report's section (with ``said``: the lines simulate echoed), the box's x at every frame written
    and the stage."""
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    box.apply_translation((0.0, 0.0, 0.05))
    shot = write_bench_shot(folder, [BenchObject("box", box, "rigid", {"dynamic_friction": 0.5, "static_friction": 0.5},
                                                 velocity=(1.0, 0.0, 0.0))])
    said = []
    report = simulate_shot(shot, SimulateSettings(seconds=3.0, rest_seconds=rest_seconds), echo=said.append)
    report["said"] = said
    stage = layers.open_shot(shot)
    xf = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Objects/box"))
    x = np.array([xf.ComputeLocalToWorldTransform(f).ExtractTranslation()[0] for f in range(report["frames"])])
    return report, x, stage


def test_a_take_at_rest_ends_a_second_after_the_last_motion(tmp_path):
    report, x, stage = _slide(tmp_path / "rest", REST_SECONDS)
    rest = report["ended_at_rest"]
    assert rest is not None and rest["ended_s"] - rest["still_from_s"] == REST_SECONDS
    fps = report["fps"]
    assert report["frames"] == round(rest["ended_s"] * fps) + 1 < round(3.0 * fps) + 1
    assert report["simulated_seconds"] == rest["ended_s"] and report["asked_seconds"] == 3.0
    assert stage.GetEndTimeCode() == report["frames"] - 1  # the shot (and so the video) ends there
    assert x[-1] - x[0] > 0.05  # the slide is all in it
    still = round(REST_SECONDS * fps)
    assert np.ptp(x[-still - 1:]) < 1e-3 and np.ptp(x[-still - 3:]) > 0  # its last second, and only that, still
    # and it says so, with the times it went by
    line = f"everything at rest from {rest['still_from_s']:.2f} s; the take ends at {rest['ended_s']:.2f} s of the 3 s"
    assert any(line in m for m in report["said"]), report["said"]


def test_asked_seconds_are_simulated_to_the_end(tmp_path):
    report, x, _ = _slide(tmp_path / "all", None)
    assert report["ended_at_rest"] is None and report["frames"] == round(3.0 * report["fps"]) + 1
    assert not any("at rest" in m for m in report["said"]), report["said"]


def test_a_push_or_a_field_still_to_come_keeps_the_take_going():
    """Still for a second, but something is still to act: no end."""
    rec = SimpleNamespace(still=lambda f0, f1, bound: True)
    quiet = SimpleNamespace(pending=[], fields=None)
    assert at_rest(rec, 40, 30, quiet, 40 / 30)
    assert not at_rest(rec, 20, 30, quiet, 20 / 30)  # not a second yet
    assert not at_rest(rec, 40, 30, SimpleNamespace(pending=["a push at 2 s"], fields=None), 40 / 30)
    wind = SimpleNamespace(enabled=True, end_time=-1.0)  # never off
    assert not at_rest(rec, 40, 30, SimpleNamespace(pending=[], fields=SimpleNamespace(fields=[wind])), 40 / 30)
    over = SimpleNamespace(enabled=True, end_time=1.0)
    assert at_rest(rec, 40, 30, SimpleNamespace(pending=[], fields=SimpleNamespace(fields=[over])), 40 / 30)


def test_a_take_at_rest_ends_on_a_frame_the_guard_checked(tmp_path, monkeypatch):
    """The guard checks every few frames; a take that ends early at rest ends on a checked frame, as the last
    frame of a full take is, so its last pose is one the guard passed."""
    from physomni_usd.physics import runner

    checked, check, init = [], runner.GuardedRun._check, runner.GuardedRun.__init__

    def counting(self):
        checked.append(self.frame)
        return check(self)

    def every_fourth(self, *a, **k):  # this slide comes to rest on a multiple of the default cadence
        init(self, *a, **k)
        self.check_every = 4

    monkeypatch.setattr(runner.GuardedRun, "_check", counting)
    monkeypatch.setattr(runner.GuardedRun, "__init__", every_fourth)
    report, _, _ = _slide(tmp_path / "rest", REST_SECONDS)
    last = report["frames"] - 1
    assert report["ended_at_rest"] is not None and last % 4  # an end between the guard's checks
    assert last in checked, (last, checked[-5:])
