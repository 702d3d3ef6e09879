"""The cost of ten objects through ``simulate`` at its own step choice: its stepping alone, the whole
``simulate_shot`` call (reading the stage, building the model, stepping, writing, the checks) and the
whole ``physomni-usd simulate`` command a user runs (a new process: imports and warp's start-up too)."""

from __future__ import annotations

import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

RUNS = 3


def ten_objects(echo=print, seconds: float = 2.0) -> dict:
    """Ten boxes dropped on the ground, simulated for ``seconds`` at ``simulate``'s own step choice: the
    median of three runs of the stepping and of the ``simulate_shot`` call, measured in a fresh interpreter,
    and of three runs of the ``physomni-usd simulate`` command."""
    from .scenes import in_fresh_interpreter

    with tempfile.TemporaryDirectory() as tmp:
        shot = _ten_boxes(pathlib.Path(tmp))
        r = in_fresh_interpreter(__name__, "_ten_objects_run", shot=str(shot), seconds=seconds)
        if "error" in r:
            echo(f"ten objects: {r}")
            return r
        command = []
        for _ in range(RUNS):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "physomni_usd.cli", "simulate", str(shot), "--seconds",
                                   str(seconds), "-q"], capture_output=True, text=True)
            command.append(time.perf_counter() - t0)
            if proc.returncode:
                out = {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
                echo(f"ten objects: {out}")
                return out
    step = statistics.median(r["step_seconds"])
    cost = step / seconds
    out = {"objects": 10, "simulated_seconds": seconds, "solver": r["solver"], "substeps": r["substeps"],
           "iterations": r["iterations"], "collide_at_most_every": r["collide_every"],
           "step_seconds": round(step, 4), "seconds_per_sim_second": round(cost, 4),
           "times_real_time": round(1.0 / cost, 2) if cost > 0 else None,
           "simulate_call_seconds": round(statistics.median(r["total_seconds"]), 4),
           "simulate_call_parts": r["parts"],
           "command_seconds": round(statistics.median(command), 4),
           "runs": {"step_seconds": r["step_seconds"], "simulate_call_seconds": r["total_seconds"],
                    "command_seconds": [round(c, 4) for c in command]}}
    echo(f"ten objects: {out}")
    return out


def _ten_boxes(folder: pathlib.Path) -> pathlib.Path:
    import trimesh

    from .scenes import BenchObject, write_bench_shot

    objects = []
    for i in range(10):
        box = trimesh.creation.box((0.2, 0.2, 0.2))
        box.apply_translation(((i % 5) * 0.4 - 0.8, (i // 5) * 0.4, 0.3 + 0.05 * i))
        objects.append(BenchObject(f"box_{i}", box, "rigid", {"density": 500.0}))
    return write_bench_shot(folder, objects)


def _ten_objects_run(shot: str, seconds: float) -> dict:
    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings

    simulate_shot(shot, SimulateSettings(seconds=0.2))  # warm the kernel cache
    runs = [simulate_shot(shot, SimulateSettings(seconds=seconds)) for _ in range(RUNS)]
    r = runs[0]
    return {"solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
            "collide_every": r["steps"]["collide_every"], "step_seconds": [x["seconds"]["step"] for x in runs],
            "total_seconds": [x["total_seconds"] for x in runs],
            "parts": {k: statistics.median(x["seconds"][k] for x in runs) for k in r["seconds"]}}
