"""``bench render``: frames per second of ``render`` on a bundled example, plain and with every control pass.

The example is built at ``size`` pixels (longer side; the targets are stated at
880 px) with its push, simulated for ``seconds``, then rendered twice as the
product renders it (``render_shot``: frames, H.264 encoding, and for the second
run the EXR passes and their previews), with the photo's static camera. The
frames per second count the frame loop, not the set-up. The machine's load
average is recorded: on a shared CPU the figures move with it.
"""

from __future__ import annotations

import os
import pathlib
import platform
import tempfile
import time

from .pipeline import _resized_example
from .limits import EXAMPLE, RENDER


def bench_render(example=EXAMPLE, size: int = RENDER["size"].default, seconds: float = RENDER["seconds"].default, fps: float = 30.0, echo=print) -> dict:
    RENDER.check(size=size, seconds=seconds)  # before any work, as the command refuses them

    from ..building import build_shot
    from ..physics.simulate import simulate_shot
    from ..rendering.passes import PASSES
    from ..rendering.video import render_shot
    from ..settings import BuildSettings, RenderSettings, SimulateSettings

    example = pathlib.Path(example)
    with tempfile.TemporaryDirectory(prefix="physomni-bench-") as tmp:
        work = pathlib.Path(tmp)
        ex = _resized_example(example, size, work)
        result = build_shot(ex["photo"], work / "shot", ex["masks"], (), BuildSettings(fps=fps), ex["push"],
                            sizes=ex["sizes"])
        simulate_shot(result.shot, SimulateSettings(seconds=seconds))
        settings = RenderSettings(max_size=size)
        render_shot(result.shot, work / "warm.mp4", settings)  # warp's kernels compiled and loaded once
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        plain = render_shot(result.shot, work / "plain.mp4", settings)
        passes = render_shot(result.shot, work / "passes.mp4", settings, passes=PASSES, passes_dir=work / "passes")
        elapsed = time.perf_counter() - t0
    out = {"example": example.name, "width": plain["width"], "height": plain["height"], "frames": plain["frames"],
           "camera": "static", "device": plain["device"],
           "machine": f"{platform.machine()}, {platform.processor() or platform.system()}, {os.cpu_count()} cores",
           "load_average_1min": round(load, 2),
           "plain_frames_per_second": plain["frames_per_second"],
           "passes_frames_per_second": passes["frames_per_second"], "passes": list(PASSES),
           "seconds": round(elapsed, 2)}
    echo(f"render {out['width']}×{out['height']}, {out['frames']} frames, static camera, {out['device']} "
         f"(load {out['load_average_1min']} on {os.cpu_count()} cores)")
    echo(f"  plain:       {out['plain_frames_per_second']:6.2f} frames/s")
    echo(f"  all passes:  {out['passes_frames_per_second']:6.2f} frames/s ({', '.join(PASSES)})")
    return out
