"""The cost of ten objects through ``simulate`` at its own step choice, as a user's command runs it."""

from __future__ import annotations

import statistics


def ten_objects(echo=print, seconds: float = 2.0) -> dict:
    """Ten boxes dropped on the ground, through ``simulate`` at its own step choice, in a fresh interpreter
    as a user's ``physomni-usd simulate`` would run: its cost, the median of three runs."""
    from .scenes import in_fresh_interpreter

    r = in_fresh_interpreter(__name__, "_ten_objects_run", seconds=seconds)
    if "error" in r:
        echo(f"ten objects: {r}")
        return r
    cost = statistics.median(r["costs"])
    out = {"objects": 10, "solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
           "collide_at_most_every": r["collide_every"], "seconds_per_sim_second": cost,
           "runs_seconds_per_sim_second": r["costs"], "times_real_time": round(1.0 / cost, 2) if cost > 0 else None}
    echo(f"ten objects: {out}")
    return out


def _ten_objects_run(seconds: float) -> dict:
    import pathlib
    import tempfile

    import trimesh

    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings
    from .scenes import BenchObject, write_bench_shot

    objects = []
    for i in range(10):
        box = trimesh.creation.box((0.2, 0.2, 0.2))
        box.apply_translation(((i % 5) * 0.4 - 0.8, (i // 5) * 0.4, 0.3 + 0.05 * i))
        objects.append(BenchObject(f"box_{i}", box, "rigid", {"density": 500.0}))
    with tempfile.TemporaryDirectory() as tmp:
        shot = write_bench_shot(pathlib.Path(tmp), objects)
        simulate_shot(shot, SimulateSettings(seconds=0.2))  # warm the kernel cache
        runs = [simulate_shot(shot, SimulateSettings(seconds=seconds)) for _ in range(3)]
    r = runs[0]
    return {"solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
            "collide_every": r["steps"]["collide_every"], "costs": [x["seconds_per_simulated_second"] for x in runs]}
