"""A tiny version of each reference case, the stiff and extreme matrix, and the step planner's rules."""

from __future__ import annotations

import pytest

import numpy as np

from physomni_usd.bench import deformable, physics
from physomni_usd.bench.stability import run_matrix
from physomni_usd.physics.stability import RIGID_SUBSTEPS, StepPlan, scene_kinds

# the simulator's substeps for each kind of scene (physics.stability.RIGID_SUBSTEPS)
SETTINGS = {"free_fall": 8, "linear_drag": 16, "quadratic_drag": 16, "incline_friction": 8, "restitution": 16,
            "free_rotation": 8}


@pytest.mark.parametrize("case", [c for c in physics.CASES if c.name in SETTINGS], ids=lambda c: c.name)
def test_xpbd_meets_the_closed_form(case):
    error, seconds = case.run("xpbd", SETTINGS[case.name])
    assert error <= case.target and seconds > 0


def test_resting_stack_barely_drifts():
    error, _ = physics.resting_stack("xpbd", RIGID_SUBSTEPS["stacked"], seconds=1.0)
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


def test_cloth_converges_towards_the_fine_step():
    coarse, _ = deformable.cloth_sag(8)
    fine, _ = deformable.cloth_sag(32)
    assert np.isfinite(coarse) and fine < coarse / 3


def test_elastic_bar_oscillates_near_the_beam_theory_frequency():
    error, seconds = deformable.elastic_bar(4, spacing=0.025, seconds=0.6)
    assert error < 0.2 and seconds > 0


def test_dam_break_front_follows_martin_and_moyce():
    error, _ = deformable.dam_break(2, spacing=0.02)
    assert error < 0.25


def test_granular_column_spreads():
    error, _ = deformable.granular_column(2, spacing=0.02)
    assert error < 0.6  # runs out, though short of Lube's 1.2·a (see the bench's table)


def test_small_matrix_passes_and_the_guard_rolls_back_when_overruled():
    rows = {r["case"]: r for r in run_matrix(quick=True, echo=lambda m: None,
                                              only=["elastic_E_1e+09", "mass_ratio_1000_stack",
                                                    "1e4_N_on_10_g_at_20_substeps"])}
    assert all(r["passed"] for r in rows.values()), rows
    assert rows["1e4_N_on_10_g_at_20_substeps"]["rollbacks"] >= 1
    e = rows["mass_ratio_1000_stack"]
    assert e["energy_final_j"] <= 1.05 * (e["energy_initial_j"] + e["work_j"]) + 1e-3


class _Obj:
    def __init__(self, lo, hi, restitution=0.1, family="rigid"):
        self.points = np.array([lo, hi], float)
        self.params = {"restitution": restitution}
        self.family = family


def test_scene_kinds_pick_the_substeps_the_bench_recommends():
    apart = [_Obj((0, 0, 0), (1, 1, 1)), _Obj((2, 0, 0), (3, 1, 1))]
    assert scene_kinds(apart) == ["free"]
    stacked = [_Obj((0, 0, 0), (1, 1, 1)), _Obj((0.2, 0.2, 1.0), (0.8, 0.8, 2.0))]
    assert "stacked" in scene_kinds(stacked)
    assert "bouncy" in scene_kinds([_Obj((0, 0, 0), (1, 1, 1), restitution=0.8)])
    assert "drag" in scene_kinds(apart, ["drag"])


def test_contacts_are_searched_as_often_as_speed_needs():
    plan = StepPlan(30.0, 8, collide_every=8, thinnest=0.2, acceleration=9.81)
    assert plan.collide_interval(0.0) == 8  # resting: once a frame
    assert plan.collide_interval(50.0) == 1  # fast: every substep
    assert StepPlan(30.0, 8, collide_every=1, thinnest=0.2).collide_interval(0.0) == 1  # cloth present


def test_markdown_table_is_dated_and_names_the_machine():
    numbers = {"date": "2026-01-01", "machine": "x86_64, 2 cores", "fps": 30, "default": {"solver": "xpbd"},
               "rows": [{"case": "free_fall", "solver": "xpbd", "dt": 1 / 240, "substeps": 8, "error": 0.008,
                         "target": 0.01, "seconds_per_sim_second": 0.1, "recommended": True}]}
    text = physics.markdown(numbers)
    assert "2026-01-01" in text and "2 cores" in text and "| free_fall | xpbd | 8 |" in text


def test_markdown_replaces_only_the_marked_section():
    doc = "intro\n<!-- bench physics: generated -->\nold table\n<!-- /bench physics -->\noutro\n"
    out = physics.splice_markdown(doc, "new table\n")
    assert out.startswith("intro\n<!-- bench physics: generated -->\n") and "new table" in out
    assert "old table" not in out and out.endswith("<!-- /bench physics -->\noutro\n")
    assert physics.splice_markdown("no markers", "whole") == "whole"
