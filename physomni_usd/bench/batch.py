"""``bench batch``: wall time of N small shots through ``batch`` against ``run`` one after another.

Every shot is the same bundled example, resized and simulated briefly, each
into its own folder. The sequential side runs ``physomni-usd run`` processes one
after another (the times after 1, 2, 4 … runs are read off one pass of the
largest N); the batch side runs ``physomni-usd batch`` on a list of N shots in a
fresh process each time, so Ray's start-up is counted as a user pays it. Ray's
start-up alone is timed too.
"""

from __future__ import annotations

import os
import pathlib
import platform
import shlex
import subprocess
import sys
import tempfile
import time

from ..errors import PhysOmniError
from .pipeline import _resized_example
from .limits import BATCH, BATCH_COUNTS, EXAMPLE

_CLI = "import sys\nfrom physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n"


def _cli(*args) -> float:
    """Seconds a ``physomni-usd ARGS`` process takes; raises if it fails."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _CLI, *map(str, args)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        raise PhysOmniError(f"bench batch: physomni-usd {args[0]} failed: {last}")
    return seconds


def _ray_start_seconds() -> float:
    import ray

    from ..batch.runner import start_ray

    t0 = time.perf_counter()
    start_ray(None)
    seconds = time.perf_counter() - t0
    ray.shutdown()
    return seconds


#: Most shots one timing of ``bench batch`` runs.
MAX_COUNT = 64


def bench_batch(example=EXAMPLE, counts=BATCH_COUNTS, size: int = BATCH["size"].default,
                seconds: float = BATCH["seconds"].default, fps: float = BATCH["fps"].default,
                echo=print) -> dict:
    """``batch`` against ``run`` one after another for each count of shots in ``counts`` (each 1 to
    :data:`MAX_COUNT`); refused (InputError) before any work without Ray or with a count out of range."""
    BATCH.check(size=size, seconds=seconds, fps=fps)  # before any work, as the command refuses them

    from ..errors import InputError

    try:
        import ray  # noqa: F401
    except ImportError:
        raise InputError("bench batch needs Ray: pip install 'physomni-usd[batch]'") from None
    if not counts or min(counts) < 1 or max(counts) > MAX_COUNT:
        raise InputError(f"--counts {','.join(map(str, counts))!r}: each count must be 1 to {MAX_COUNT}")
    example = pathlib.Path(example)
    counts = sorted(set(counts))
    with tempfile.TemporaryDirectory(prefix="physomni-bench-batch-") as tmp:
        work = pathlib.Path(tmp)
        ex = _resized_example(example, size, work)
        args = [str(ex["photo"])]
        for mask in ex["masks"]:
            args += ["--mask", mask]
        for push in ex["push"]:
            args += ["--push", push]
        args += ["--seconds", str(seconds), "--fps", str(fps)]
        ray_start = _ray_start_seconds()
        # warm the warp kernel cache so that neither side pays for compiling
        _cli("run", *args, "-o", work / "warm")
        sequential, total = [], 0.0
        for i in range(max(counts)):
            total += _cli("run", *args, "-o", work / "seq" / f"shot{i}", "-q")
            sequential.append(total)
        rows = []
        for n in counts:
            shots = work / f"shots{n}.txt"
            shots.write_text("".join(shlex.join([*args, "-o", str(work / f"batch{n}" / f"shot{i}")]) + "\n"
                                     for i in range(n)))
            t_batch = _cli("batch", shots, "-q")
            t_seq = sequential[n - 1]
            rows.append({"shots": n, "sequential_seconds": round(t_seq, 2), "batch_seconds": round(t_batch, 2),
                         "sequential_shots_per_hour": round(3600 * n / t_seq, 1),
                         "batch_shots_per_hour": round(3600 * n / t_batch, 1),
                         "speedup": round(t_seq / t_batch, 2)})
    out = {
        "example": example.name, "width": ex["size"][0], "height": ex["size"][1], "objects": len(ex["masks"]),
        "simulated_seconds": seconds, "fps": fps,
        "machine": f"{platform.machine()}, {platform.processor() or platform.system()}, {os.cpu_count()} cores",
        "ray_start_seconds": round(ray_start, 2), "rows": rows,
    }
    echo(f"{example.name} at {ex['size'][0]}x{ex['size'][1]}, {len(ex['masks'])} objects, {seconds:g} s at "
         f"{fps:g} fps per shot; {out['machine']}; Ray starts in {ray_start:.1f} s")
    echo(f"{'shots':>5}{'run after run s':>17}{'batch s':>10}{'run shots/h':>13}{'batch shots/h':>15}"
         f"{'speed-up':>10}")
    for r in rows:
        echo(f"{r['shots']:>5}{r['sequential_seconds']:>17.1f}{r['batch_seconds']:>10.1f}"
             f"{r['sequential_shots_per_hour']:>13.0f}{r['batch_shots_per_hour']:>15.0f}{r['speedup']:>10.2f}")
    return out
