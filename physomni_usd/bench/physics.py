"""``bench physics``: error against run time on cases with exact or measured answers, the stiff and
extreme matrix, and what the simulator's defaults cost.

Each case runs a tiny Newton scene for a few simulated seconds and compares it
with its reference; the sweep varies the solver and the substeps per frame
(30 frames per second, so dt = 1 / (30·substeps)) and, for MPM, the particle
spacing. For every (case, solver) the cheapest setting that meets the case's
target is marked ``recommended``. The deformable cases (cloth sag, elastic
bar, dam break, granular column) and their references are in
:mod:`physomni_usd.bench.deformable`; the matrix in :mod:`physomni_usd.bench.stability`.

The rigid cases and their references are in :mod:`physomni_usd.bench.rigid`; choosing defaults from
the rows in :mod:`physomni_usd.bench.selection`; ten objects through ``simulate`` in
:mod:`physomni_usd.bench.ten_objects`; the Markdown and the plots in :mod:`physomni_usd.bench.markdown`
and :mod:`physomni_usd.bench.plots`.
"""

from __future__ import annotations

import math
import platform
import statistics
import time

from .._warp import load_warp
from .markdown import markdown, splice_markdown, table  # noqa: F401 - re-exported for the command
from .plots import write_plots  # noqa: F401 - re-exported for the command
from .rigid import CASES, FPS, TARGET, rigid_solvers
from .selection import choose_default, deformable_defaults, scene_defaults
from .ten_objects import ten_objects

#: Deformable cases (bench.deformable): name → (function, solver, target, quick settings, full settings);
#: a setting is (steps per frame, particle spacing or None).
DEFORMABLE = {
    "cloth_sag": ("cloth_sag", "xpbd", TARGET, [(16, None), (32, None)],
                  [(8, None), (16, None), (24, None), (32, None), (48, None), (64, None), (128, None)]),
    "elastic_bar": ("elastic_bar", "implicit_mpm", TARGET, [(16, 0.025)],
                    [(8, 0.025), (16, 0.025), (32, 0.025), (8, 0.0167), (16, 0.0167), (32, 0.0167),
                     (16, 0.0125)]),
    "dam_break": ("dam_break", "implicit_mpm", 0.10, [(2, 0.01)], [(1, 0.01), (2, 0.01), (4, 0.01), (2, 0.0067)]),
    "granular_column": ("granular_column", "implicit_mpm", 0.15, [(4, 0.01)],
                        [(2, 0.01), (4, 0.01), (8, 0.01), (16, 0.01), (4, 0.0067)]),
}


def bench_physics(quick: bool = False, repeats: int = 3, echo=print, matrix: bool = True) -> dict:
    load_warp()
    substeps_list = (1, 4, 16) if quick else (1, 2, 4, 8, 16, 32)
    solvers = rigid_solvers()
    rows = []
    for case in CASES:
        for solver in solvers:
            for n in substeps_list:
                errors, costs = [], []
                for _ in range(1 if quick else repeats):
                    try:
                        err, sec = case.run(solver, n)
                    except Exception as exc:  # noqa: BLE001 - a solver that cannot run this case says so
                        errors, costs = [float("nan")], [float("nan")]
                        echo(f"{case.name} {solver}: {type(exc).__name__}: {exc}")
                        break
                    errors.append(err if math.isfinite(err) else float("inf"))
                    costs.append(sec / case.seconds)
                rows.append({"case": case.name, "solver": solver, "dt": 1.0 / (FPS * n), "substeps": n,
                             "error": float(statistics.median(errors)), "target": case.target,
                             "seconds_per_sim_second": float(statistics.median(costs)), "recommended": False})
    rows += _deformable_rows(quick, echo)
    for case, solver in dict.fromkeys((r["case"], r["solver"]) for r in rows):
        ok = [r for r in rows if r["case"] == case and r["solver"] == solver and r["error"] <= r["target"]]
        if ok:
            min(ok, key=lambda r: r["seconds_per_sim_second"])["recommended"] = True
    default = choose_default([r for r in rows if r["case"] in {c.name for c in CASES}], substeps_list)
    _print(rows, default, echo)
    deformables = deformable_defaults(rows)
    echo(f"deformable defaults (bench vs simulator): {deformables}")
    out = {"machine": machine(), "date": time.strftime("%Y-%m-%d"), "fps": FPS, "quick": quick, "rows": rows, "default": default,
           "scene_defaults": scene_defaults(rows), "deformable_defaults": deformables, "ten_objects": ten_objects(echo)}
    if matrix:
        from .stability import memory_probe, run_matrix

        echo("stiff and extreme matrix:")
        out["matrix"] = run_matrix(quick=quick, echo=echo)
        out["memory"] = memory_probe()
        echo(f"memory: {out['memory']}")
    return out


def machine() -> str:
    import os

    cpu = platform.processor() or platform.machine()
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()}, Python {platform.python_version()}"


def _deformable_rows(quick: bool, echo) -> list[dict]:
    from . import deformable

    rows = []
    for case, (fn, solver, target, quick_settings, full_settings) in DEFORMABLE.items():
        for n, spacing in quick_settings if quick else full_settings:
            kwargs = {} if spacing is None else {"spacing": spacing}
            try:
                err, cost = getattr(deformable, fn)(n, **kwargs)
            except Exception as exc:  # noqa: BLE001 - reported, the sweep goes on
                echo(f"{case} {solver}: {type(exc).__name__}: {exc}")
                err, cost = float("nan"), float("nan")
            rows.append({"case": case, "solver": solver, "dt": 1.0 / (FPS * n), "substeps": n, "spacing": spacing,
                         "error": float(err) if math.isfinite(err) else float("inf"), "target": target,
                         "seconds_per_sim_second": cost, "recommended": False})
    return rows


def _print(rows, default, echo):
    for line in table(rows):
        echo(line)
    echo(f"default: {default}")
