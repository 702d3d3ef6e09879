"""A tiny version of each reference case, the stiff and extreme matrix, and the step planner's rules."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

import numpy as np

from physomni_usd.bench import deformable, markdown, rigid, selection
from physomni_usd.bench.stability import run_matrix
from physomni_usd.physics.stability import (CLOTH_FACTOR, MAX_SUBSTEPS, MPM_STEPS, PARTICLE_CONTACT_GAP,
                                            RIGID_SUBSTEPS, PlanInputs, StepPlan, plan_steps, scene_kinds)

from .conftest import cli

# the simulator's substeps for each kind of scene (physics.stability.RIGID_SUBSTEPS)
SETTINGS = {"free_fall": 8, "linear_drag": 16, "quadratic_drag": 16, "incline_friction": 8, "restitution": 16,
            "free_rotation": 8}


@pytest.mark.parametrize("case", [c for c in rigid.CASES if c.name in SETTINGS], ids=lambda c: c.name)
def test_xpbd_meets_the_closed_form(case):
    error, seconds = case.run("xpbd", SETTINGS[case.name])
    assert error <= case.target and seconds > 0


def test_resting_stack_barely_drifts():
    error, _ = rigid.resting_stack("xpbd", RIGID_SUBSTEPS["stacked"], seconds=1.0)
    assert error <= rigid.TARGET


def test_error_falls_with_the_step():
    coarse, _ = rigid.free_fall("xpbd", 1)
    fine, _ = rigid.free_fall("xpbd", 8)
    assert fine < coarse / 4  # first order in dt


def test_default_is_the_cheapest_setting_meeting_every_target():
    rows = [{"case": c, "solver": s, "substeps": n, "error": e, "target": 0.01, "seconds_per_sim_second": t}
            for c, s, n, e, t in [("a", "x", 1, 0.5, 0.1), ("a", "x", 4, 0.001, 0.4), ("b", "x", 1, 0.001, 0.1),
                                  ("b", "x", 4, 0.001, 0.4), ("a", "y", 1, 0.001, 0.3), ("b", "y", 1, 0.002, 0.3)]]
    best = selection.choose_default(rows, (1, 4))
    assert (best["solver"], best["substeps"]) == ("y", 1)


@pytest.mark.slow  # 73 s on a loaded 2-core machine
def test_cloth_sag_meets_the_fine_step_only_at_the_simulators_cloth_step():
    """The simulator's rule dt ≤ CLOTH_FACTOR·√(m/k) lands within the bench's 1 % on the bench cloth;
    four times that step does not."""
    frame = 1.0 / deformable.FPS
    substeps = math.ceil(frame / (CLOTH_FACTOR * deformable.cloth_time_scale()))
    fine, _ = deformable.cloth_sag(substeps, seconds=4.0, reference_substeps=96)
    coarse, _ = deformable.cloth_sag(max(substeps // 4, 1), seconds=4.0, reference_substeps=96)
    assert fine < 0.01 and not coarse < 0.01


def test_frequency_of_a_swing_decaying_onto_its_rest_position():
    """A bar released straight swings about its sagged rest position, not about its mean; the estimate
    must not depend on where the mean falls."""
    t = np.linspace(0.0, 1.0, 241)
    z = 0.53 + np.exp(-1.5 * t) * 0.02 * np.cos(2 * np.pi * 4.5 * t) + 0.0005 * np.sin(2 * np.pi * 28.0 * t)
    assert deformable._frequency(np.c_[t, z]) == pytest.approx(4.5, rel=1e-3)
    assert math.isnan(deformable._frequency(np.c_[t, np.full_like(t, 0.5)]))


@pytest.mark.slow  # 66 s on a loaded 2-core machine
def test_elastic_bar_oscillates_near_the_beam_theory_frequency():
    error, seconds = deformable.elastic_bar(4, spacing=0.025, seconds=0.6)
    assert error < 0.2 and seconds > 0


@pytest.mark.slow  # 38 s on a loaded 2-core machine
def test_dam_break_front_follows_martin_and_moyce():
    error, _ = deformable.dam_break(2, spacing=0.02)
    assert error < 0.25


def test_granular_column_spreads():
    error, _ = deformable.granular_column(2, spacing=0.02)
    assert error < 0.6  # runs out, though short of Lube's 1.2·a (see the bench's table)


@pytest.mark.slow  # 83 s on a loaded 2-core machine
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
    in_a_bowl = [_Obj((0, 0, 0), (1, 1, 0.3)), _Obj((0.4, 0.4, 0.05), (0.6, 0.6, 0.25))]  # on its inner floor
    assert "stacked" in scene_kinds(in_a_bowl)
    side_by_side = [_Obj((0, 0, 0), (1, 1, 0.3)), _Obj((0.4, 0.4, 0.0), (0.6, 0.6, 0.25))]  # both on the ground
    assert scene_kinds(side_by_side) == ["free"]
    assert "bouncy" in scene_kinds([_Obj((0, 0, 0), (1, 1, 1), restitution=0.8)])
    assert "drag" in scene_kinds(apart, ["drag"])


def test_contacts_are_searched_as_often_as_speed_needs():
    plan = StepPlan(30.0, 8, collide_every=8, thinnest=0.2, acceleration=9.81)
    assert plan.collide_interval(0.0) == 8  # resting: once a frame
    assert plan.collide_interval(50.0) == 1  # fast: every substep
    assert StepPlan(30.0, 8, collide_every=1, thinnest=0.2).collide_interval(0.0) == 1  # searched every substep


def test_a_light_cloth_is_searched_for_contacts_at_the_rate_the_rest_of_the_scene_asks():
    """A cloth that asks the cap's substeps does not take the contact search along: it searches as often as the
    rigid scene would step (8 a frame), more often when a particle could close half its contact gap between
    searches; a scene whose cloth asks no more than the rest, and a soft body's own rate, keep every substep."""
    light = plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.array([5e-7, 7.5e-7]), cloth_stiffness=100.0,
                                  particles=True))
    assert light.substeps == MAX_SUBSTEPS and light.collide_every == MAX_SUBSTEPS // 8
    assert light.particle_gap == PARTICLE_CONTACT_GAP
    assert light.reasons["contacts"]["searches_a_frame"] == 8, light.reasons
    assert light.collide_interval(0.0) == MAX_SUBSTEPS // 8  # at rest: 8 searches a frame
    # falling at 1 m/s: half the gap is crossed in 0.005 / (1 + g/30) s, fewer substeps than a rigid step's
    want = int(0.5 * PARTICLE_CONTACT_GAP / ((1.0 + 9.81 / 30.0) * light.dt))
    assert light.collide_interval(1.0) == want < MAX_SUBSTEPS // 8
    assert light.collide_interval(100.0) == 1
    # a retried frame keeps searching at most half as many substeps apart, not every one of its 2000
    retried = light.refined()
    assert retried.substeps == 2 * MAX_SUBSTEPS and retried.collide_every == MAX_SUBSTEPS // 16
    assert retried.collide_interval(0.0) == MAX_SUBSTEPS // 16
    assert StepPlan(30.0, 8, collide_every=8, thinnest=0.2).refined().collide_every == 1  # rigid: every substep
    heavy = plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.array([1.0]), cloth_stiffness=100.0, particles=True))
    assert heavy.substeps == 8 and heavy.collide_every == 1
    soft = plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.array([5e-7]), cloth_stiffness=100.0,
                                 soft_dt=1.0 / (30 * 500), particles=True))
    assert soft.collide_every == MAX_SUBSTEPS // 500
    # the user's --substeps set the substeps, not the search's rate: the rules' 8 a frame still hold
    given = plan_steps(PlanInputs([], 30.0, MAX_SUBSTEPS, cloth_masses=np.array([5e-7]), cloth_stiffness=100.0,
                                  particles=True, fixed_substeps=True))
    assert given.substeps == MAX_SUBSTEPS and given.collide_every == MAX_SUBSTEPS // 8, given.reasons
    # beside MPM the substeps round up to a whole multiple of its steps; the reuse is read from those that run
    mpm = SimpleNamespace(wave_speed=1.0, spacing=0.01,
                          objects=[SimpleNamespace(obj=SimpleNamespace(kind="mpm_elastic"))])
    beside = plan_steps(PlanInputs([], 30.0, 8, mpm_steps=300, mpm=mpm, cloth_masses=np.array([5e-7]),
                                   cloth_stiffness=100.0, particles=True))
    assert beside.substeps == 1200 and beside.collide_every == 1200 // 8, beside.as_dict()


def test_mpm_steps_follow_the_material_the_bench_measured():
    """Stiff materials want hundreds of CFL steps; the plan caps them at the bench's accurate setting for
    the scene's stiffest kind of material, scaled to the frame rate, and never exceeds what CFL asks."""
    from types import SimpleNamespace

    def plan(kinds, wave_speed=100.0, fps=30.0):
        mpm = SimpleNamespace(wave_speed=wave_speed, spacing=0.01,
                              objects=[SimpleNamespace(obj=SimpleNamespace(kind=k)) for k in kinds])
        return plan_steps(PlanInputs([], fps, 8, mpm=mpm))

    assert plan(["mpm_liquid"]).mpm_steps == MPM_STEPS["liquid"]
    assert plan(["mpm_sand"]).mpm_steps == MPM_STEPS["granular"]
    assert plan(["mpm_liquid", "mpm_elastic"]).mpm_steps == MPM_STEPS["elastic"]
    assert plan(["mpm_elastic"], fps=60.0).mpm_steps == MPM_STEPS["elastic"] // 2
    assert plan(["mpm_elastic"], wave_speed=0.5).mpm_steps == 4  # CFL asks for 4 only
    p = plan(["mpm_elastic"])
    assert p.substeps % p.mpm_steps == 0 and p.reasons["mpm_cfl"]["capped"]


def test_cloth_rule_reads_the_quickest_particle_and_says_when_the_cap_bit():
    """dt ≤ CLOTH_FACTOR·√(m/k) on the moving particle (a pinned one, mass 0, is left out) of the shortest
    √(m/k); beyond MAX_SUBSTEPS the plan takes the cap and the report says the rule asked more."""
    def plan(masses, k=100.0):
        return plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.asarray(masses, float), cloth_stiffness=k))

    p = plan([0.0, 1e-3, 4e-3])
    want = math.ceil((1 / 30) / (CLOTH_FACTOR * math.sqrt(1e-3 / 100.0)))
    assert p.substeps == want and p.reasons["cloth"]["substeps"] == want
    assert p.reasons["cloth"]["particle_kg"] == 1e-3 and not p.reasons["cloth"]["capped"]
    light = plan([5e-7, 7.5e-7])  # the desk's coin made cloth
    assert light.substeps == MAX_SUBSTEPS and light.reasons["cloth"]["substeps"] > MAX_SUBSTEPS
    assert light.reasons["cloth"]["capped"] and light.reasons["cloth"]["stiffness_n_m"] == 100.0
    # per particle: a light cloth softened to 4.5 N/m beside a heavy one at 100 pairs neither's mass with the
    # other's springs; the shortest √(m/k) is the light one's
    both = plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.array([5e-7, 5e-3]),
                                 cloth_stiffness=np.array([4.5, 100.0])))
    assert both.reasons["cloth"]["particle_kg"] == 5e-7 and both.reasons["cloth"]["stiffness_n_m"] == 4.5
    stiff = plan_steps(PlanInputs([], 30.0, 8, cloth_masses=np.array([1e-3, 2e-3, 0.0]),
                                  cloth_stiffness=np.array([1.0, 100.0, 100.0])))
    assert stiff.reasons["cloth"]["particle_kg"] == 2e-3 and stiff.reasons["cloth"]["stiffness_n_m"] == 100.0


def test_markdown_table_is_dated_and_names_the_machine():
    numbers = {"date": "2026-01-01", "machine": "x86_64, 2 cores", "fps": 30, "default": {"solver": "xpbd"},
               "rows": [{"case": "free_fall", "solver": "xpbd", "dt": 1 / 240, "substeps": 8, "error": 0.008,
                         "target": 0.01, "seconds_per_sim_second": 0.1, "recommended": True}]}
    text = markdown.markdown(numbers)
    assert "2026-01-01" in text and "2 cores" in text and "| free_fall | xpbd | 8 |" in text
    rows = [{"case": "cloth_sag", "dt": 1 / 960, "substeps": 32, "recommended": True},
            {"case": "dam_break", "dt": 1 / 60, "substeps": 2, "recommended": True}]
    numbers["deformable_defaults"] = selection.deformable_defaults(rows)
    text = markdown.markdown(numbers)
    assert f"c = {CLOTH_FACTOR}" in text and "| liquid | dam_break | 2 |" in text
    assert "| granular | granular_column | none met the target |" in text


def test_markdown_replaces_only_the_marked_section():
    doc = "intro\n<!-- bench physics: generated -->\nold table\n<!-- /bench physics -->\noutro\n"
    out = markdown.splice_markdown(doc, "new table\n")
    assert out.startswith("intro\n<!-- bench physics: generated -->\n") and "new table" in out
    assert "old table" not in out and out.endswith("<!-- /bench physics -->\noutro\n")
    with pytest.raises(ValueError):  # a file without the markers is not the bench's to replace
        markdown.splice_markdown("no markers", "whole")


def test_markdown_into_a_file_without_markers_is_refused_before_running(tmp_path):
    target = tmp_path / "notes.md"
    target.write_text("my own notes\n")
    proc = cli("bench", "physics", "--quick", "--markdown", target)
    assert proc.returncode == 2, proc.stderr
    lines = [x for x in proc.stderr.splitlines() if not x.startswith("TORCH_IMPORTED")]
    assert len(lines) == 1 and "--markdown" in lines[0] and "notes.md" in lines[0]
    assert target.read_text() == "my own notes\n" and proc.stdout == ""  # nothing ran, nothing changed


def test_plots_without_matplotlib_are_refused_before_running(tmp_path):
    import os

    fake = tmp_path / "site" / "matplotlib"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('matplotlib is not installed here')\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")]))
    proc = cli("bench", "physics", "--quick", "--plots", tmp_path / "plots", env=env)
    assert proc.returncode == 2, proc.stderr
    lines = [x for x in proc.stderr.splitlines() if not x.startswith("TORCH_IMPORTED")]
    assert len(lines) == 1 and "--plots" in lines[0] and "physomni-usd[bench]" in lines[0]
    assert proc.stdout == "" and not (tmp_path / "plots").exists()
