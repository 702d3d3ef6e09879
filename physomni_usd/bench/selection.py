"""Choosing from the bench's rows: the cheapest rigid setting meeting every target, and what the bench
recommends for each kind of scene beside what the simulator uses."""

from __future__ import annotations

from ..physics.stability import CLOTH_FACTOR, MPM_STEPS, RIGID_SUBSTEPS
from .rigid import TARGET


def choose_default(rows, substeps_list) -> dict:
    """The cheapest (solver, substeps) meeting every case's target; None where none does."""
    best = None
    for solver in dict.fromkeys(r["solver"] for r in rows):
        for n in substeps_list:
            mine = [r for r in rows if r["solver"] == solver and r["substeps"] == n]
            if mine and all(r["error"] <= r["target"] for r in mine):
                cost = sum(r["seconds_per_sim_second"] for r in mine)
                if best is None or cost < best["cost"]:
                    best = {"solver": solver, "substeps": n, "cost": cost}
    if best is None:
        return {"solver": None, "substeps": None, "reason": "no setting met every target"}
    return {**best, "reason": f"cheapest setting meeting every case's {TARGET:.0%} target "
                              f"(sum of seconds per simulated second over the cases: {best['cost']:.3f})"}


def scene_defaults(rows) -> dict:
    """The XPBD substeps the bench recommends for each kind of rigid scene, beside what the simulator
    uses (``physics.stability.RIGID_SUBSTEPS``)."""
    kinds = {"free": ("free_fall", "incline_friction", "free_rotation"), "drag": ("linear_drag", "quadratic_drag"),
             "bouncy": ("restitution",), "stacked": ("resting_stack",)}
    out = {}
    for kind, cases in kinds.items():
        need = []
        for case in cases:
            ok = [r["substeps"] for r in rows if r["case"] == case and r["solver"] == "xpbd" and r["error"] <= r["target"]]
            need.append(min(ok) if ok else None)
        measured = None if None in need else max(need)
        out[kind] = {"bench": measured, "simulator": RIGID_SUBSTEPS[kind]}
    return out


def deformable_defaults(rows) -> dict:
    """What the deformable cases recommend beside what the simulator uses: the factor c of the cloth
    rule dt ≤ c·√(m/k) (``physics.stability.CLOTH_FACTOR``) and MPM steps per frame for each kind of
    material (``physics.stability.MPM_STEPS``); None where no setting met the case's target."""
    from .deformable import cloth_time_scale

    def recommended(case):
        return next((r for r in rows if r["case"] == case and r["recommended"]), None)

    cloth = recommended("cloth_sag")
    out = {"cloth_factor": {"bench": round(cloth["dt"] / cloth_time_scale(), 3) if cloth else None,
                            "simulator": CLOTH_FACTOR}, "mpm_steps": {}}
    for kind, case in (("elastic", "elastic_bar"), ("granular", "granular_column"), ("liquid", "dam_break")):
        r = recommended(case)
        out["mpm_steps"][kind] = {"case": case, "bench": r["substeps"] if r else None, "simulator": MPM_STEPS[kind]}
    return out
