"""A tiny version of each rigid reference case: XPBD meets the 1 % target at a setting the sweep marks."""

from __future__ import annotations

import pytest

from physomni_usd.bench import physics

SETTINGS = {"free_fall": 16, "linear_drag": 16, "quadratic_drag": 4, "incline_friction": 4, "restitution": 16,
            "free_rotation": 4}


@pytest.mark.parametrize("case", [c for c in physics.CASES if c.name in SETTINGS], ids=lambda c: c.name)
def test_xpbd_meets_the_closed_form(case):
    error, seconds = case.run("xpbd", SETTINGS[case.name])
    assert error <= case.target and seconds > 0


def test_resting_stack_barely_drifts():
    error, _ = physics.resting_stack("xpbd", 32, seconds=1.0)
    assert error <= physics.TARGET


def test_error_falls_with_the_step():
    coarse, _ = physics.free_fall("xpbd", 1)
    fine, _ = physics.free_fall("xpbd", 8)
    assert fine < coarse / 4  # first order in dt


def test_default_is_the_cheapest_setting_meeting_every_target():
    rows = [{"case": c, "solver": s, "substeps": n, "error": e, "target": 0.01, "seconds_per_sim_second": t}
            for c, s, n, e, t in [("a", "x", 1, 0.5, 0.1), ("a", "x", 4, 0.001, 0.4), ("b", "x", 1, 0.001, 0.1),
                                  ("b", "x", 4, 0.001, 0.4), ("a", "y", 1, 0.001, 0.3), ("b", "y", 1, 0.002, 0.3)]]
    best = physics.choose_default(rows, (1, 4))
    assert (best["solver"], best["substeps"]) == ("y", 1)
