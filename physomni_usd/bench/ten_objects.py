"""The cost of ten boxes through ``simulate`` at its own step choice, each figure against the stepping of the
same run: the whole ``simulate_shot`` call, first in a process (importing Newton, loading its kernels from
the cache, capturing the frames' graphs), repeated (the model and graphs reused) and on a new shot after
another (a new model, the kernels loaded: each shot of a batch after the first), and the whole
``physomni-usd simulate`` command a user runs (a new process: Python, USD, warp and Newton starting up and
exiting), in wall and in CPU seconds, with the load average, since on a shared machine wall time is
mostly waiting for a core."""

from __future__ import annotations

import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

RUNS = 3
#: TARGETS.md: the whole ``simulate`` call within this many times its stepping.
CALL_TARGET = 3.0
#: The scenes: ten boxes dropped from 0.3–0.75 m (``bench physics``' ten objects, the preview bench's ten),
#: and ten standing on the ground (``bench peer``'s case against Genesis).
CASES = ("dropped", "at_rest")


def ten_objects(echo=print, seconds: float = 2.0, case: str = "dropped") -> dict:
    """The ten boxes of ``case`` (one of :data:`CASES`) simulated for ``seconds``: in one fresh interpreter
    the first ``simulate_shot`` call and :data:`RUNS` more, then :data:`RUNS` ``physomni-usd simulate``
    commands. Each call's and command's seconds are also given over its own stepping (the report's
    ``seconds.step``); the top-level figures are medians. Prints :func:`lines` through ``echo``."""
    from .scenes import in_fresh_interpreter, write_bench_shot

    load = [_load()]
    with tempfile.TemporaryDirectory() as tmp:
        shot = write_bench_shot(pathlib.Path(tmp), _boxes(case))
        others = [str(write_bench_shot(pathlib.Path(tmp) / f"other_{k}", _boxes(case, shift=0.01 * (k + 1))))
                  for k in range(RUNS)]
        r = in_fresh_interpreter(__name__, "_calls", shot=str(shot), seconds=seconds, others=others)
        if "error" in r:
            echo(f"ten objects ({case}): {r}")
            return r
        command = {"wall_seconds": [], "cpu_seconds": [], "step_seconds": []}
        for _ in range(RUNS):
            before = _children_cpu()
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "physomni_usd.cli", "simulate", str(shot), "--seconds",
                                   str(seconds), "-q"], capture_output=True, text=True)
            command["wall_seconds"].append(round(time.perf_counter() - t0, 4))
            command["cpu_seconds"].append(round(_children_cpu() - before, 4))
            if proc.returncode:
                out = {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
                echo(f"ten objects ({case}): {out}")
                return out
            report = json.loads((pathlib.Path(tmp) / "report.json").read_text())
            command["step_seconds"].append(report["stages"]["simulate"]["seconds"]["step"])
    load.append(_load())
    first, calls, new = r["first"], r["repeated"], r["new_shots"]
    step = statistics.median(calls["step_seconds"])
    command["times_its_stepping"] = _over(command["wall_seconds"], command["step_seconds"])
    command["cpu_times_its_stepping"] = _over(command["cpu_seconds"], command["step_seconds"])
    calls["times_its_stepping"] = _over(calls["seconds"], calls["step_seconds"])
    new["times_its_stepping"] = _over(new["seconds"], new["step_seconds"])
    first["times_its_stepping"] = _over([first["seconds"]], [first["step_seconds"]])[0]
    cost = step / seconds
    out = {"case": case, "objects": 10, "simulated_seconds": seconds, "solver": r["solver"], "substeps": r["substeps"],
           "iterations": r["iterations"], "collide_at_most_every": r["collide_every"],
           "load_average": {"start": load[0], "end": load[1]},
           "step_seconds": round(step, 4), "seconds_per_sim_second": round(cost, 4),
           "times_real_time": round(1.0 / cost, 2) if cost > 0 else None,
           "simulate_call_seconds": round(statistics.median(calls["seconds"]), 4),
           "simulate_call_parts": r["parts"],
           "command_seconds": round(statistics.median(command["wall_seconds"]), 4),
           "importing_the_simulator_seconds": r["import_seconds"],
           "first_call": first, "repeated_calls": calls, "new_shots": new, "command": command,
           "call_target": CALL_TARGET}
    for line in lines(out):
        echo(line)
    return out


def lines(t: dict) -> list[str]:
    """What :func:`ten_objects` found, one figure a line, each against its own run's stepping."""
    def med(xs):
        return statistics.median(xs)

    def verdict(ratio):
        return f"{'within' if ratio <= t['call_target'] else 'not within'} {t['call_target']:g}×"

    f, c, n, k = t["first_call"], t["repeated_calls"], t.get("new_shots"), t["command"]
    load = t["load_average"]
    return [
        f"ten boxes {t['case'].replace('_', ' ')}, {t['simulated_seconds']:g} simulated s ({t['solver']}, "
        f"{t['substeps']} substeps, {t['iterations']} iterations); load average {load['start']:.2f} at the start, "
        f"{load['end']:.2f} at the end",
        f"  stepping (simulate_shot's seconds.step, repeated calls, median of {len(c['step_seconds'])}): "
        f"{t['step_seconds']:.3f} s, {t['times_real_time']}× real time",
        f"  the first simulate_shot call in a process: {f['seconds']:.2f} s against its stepping of "
        f"{f['step_seconds']:.3f} s, {f['times_its_stepping']:.1f}× ({verdict(f['times_its_stepping'])}; "
        f"read {f['parts']['read']:.2f} s, building the model {f['parts']['build_model']:.2f} s, "
        f"writing {f['parts']['write']:.2f} s; importing the simulator's modules before it "
        f"{t['importing_the_simulator_seconds']:.2f} s)",
        f"  repeated simulate_shot calls (model and graphs reused): median {med(c['seconds']):.3f} s, "
        f"{med(c['times_its_stepping']):.1f}× its stepping ({verdict(med(c['times_its_stepping']))}; runs "
        f"{', '.join(f'{x:.1f}×' for x in c['times_its_stepping'])})",
    ] + ([
        f"  a new shot in the same process (the boxes moved 1–3 cm: a new model, as each shot of a batch after "
        f"the first): median {med(n['seconds']):.3f} s, {med(n['times_its_stepping']):.1f}× its stepping "
        f"({verdict(med(n['times_its_stepping']))}; runs {', '.join(f'{x:.1f}×' for x in n['times_its_stepping'])})",
    ] if n else []) + [
        f"  the physomni-usd simulate command (a new process): median {med(k['wall_seconds']):.2f} s of wall time, "
        f"{med(k['cpu_seconds']):.2f} s of CPU, against its stepping of {med(k['step_seconds']):.3f} s: "
        f"{med(k['times_its_stepping']):.0f}× in wall time, {med(k['cpu_times_its_stepping']):.0f}× in CPU "
        f"({verdict(med(k['times_its_stepping']))})",
    ]


def _boxes(case: str, shift: float = 0.0) -> list:
    """The ten boxes of ``case``, moved ``shift`` metres along x."""
    from .scenes import boxes_at_rest, falling_boxes

    if case not in CASES:
        raise ValueError(f"case {case!r}: one of {CASES}")
    boxes = falling_boxes(10) if case == "dropped" else boxes_at_rest(10)
    for b in boxes:
        b.mesh.apply_translation((shift, 0.0, 0.0))
    return boxes


def _over(totals, steps) -> list[float]:
    return [round(a / b, 2) if b > 0 else None for a, b in zip(totals, steps)]


def _load() -> float:
    return round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else float("nan")


def _children_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _calls(shot: str, seconds: float, others: tuple = ()) -> dict:
    """In a fresh interpreter: import the simulator, then the first ``simulate_shot`` call and
    :data:`RUNS` more, then one on each of the ``others`` shots."""
    t0 = time.perf_counter()
    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings

    imported = time.perf_counter() - t0
    def timed(path):  # from outside: the call's own total leaves out writing the report
        t0 = time.perf_counter()
        section = simulate_shot(path, SimulateSettings(seconds=seconds))
        return section, round(time.perf_counter() - t0, 4)

    runs = [timed(shot) for _ in range(RUNS + 1)]
    new = [timed(other) for other in others]
    r, first_wall = runs[0]

    def figures(calls):
        return {"seconds": [wall for _, wall in calls], "step_seconds": [x["seconds"]["step"] for x, _ in calls]}

    return {"solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
            "collide_every": r["steps"]["collide_every"], "import_seconds": round(imported, 4),
            "first": {"seconds": first_wall, "step_seconds": r["seconds"]["step"], "parts": r["seconds"]},
            "repeated": figures(runs[1:]), "new_shots": figures(new),
            "parts": {k: statistics.median(x["seconds"][k] for x, _ in runs[1:]) for k in r["seconds"]}}
