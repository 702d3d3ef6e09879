"""``bench pipeline``: wall time of ``build`` and of a whole ``run`` on a bundled example.

The example's photo and masks are resized so that the longer side has
``size`` pixels (the targets are stated at 880 px). ``build`` runs ``repeats``
times and the median is reported with its per-stage breakdown; then one whole
``run`` (build + simulate + render) of ``seconds`` of motion. Run it twice to
measure with warm warp kernel caches.
"""

from __future__ import annotations

import json
import pathlib
import platform
import statistics
import tempfile
import time

import cv2

from ..errors import InputError
from .limits import EXAMPLE, PIPELINE


def _resized_example(example: pathlib.Path, size: int, work: pathlib.Path) -> dict:
    spec_path = example / "example.json"
    if not spec_path.is_file():
        raise InputError(f"{example} has no example.json (photo, masks, push)")
    spec = json.loads(spec_path.read_text())
    photo = cv2.imread(str(example / spec["photo"]), cv2.IMREAD_COLOR)
    if photo is None:
        raise InputError(f"cannot read {example / spec['photo']}")
    h, w = photo.shape[:2]
    scale = size / max(h, w)
    dsize = (round(w * scale), round(h * scale))
    cv2.imwrite(str(work / "photo.png"), cv2.resize(photo, dsize, interpolation=cv2.INTER_CUBIC))
    masks = []
    for m in spec["masks"]:
        name, _, label = m.partition(":")
        mask = cv2.imread(str(example / name), cv2.IMREAD_GRAYSCALE)
        cv2.imwrite(str(work / name), cv2.resize(mask, dsize, interpolation=cv2.INTER_NEAREST))
        masks.append(f"{work / name}:{label}" if label else str(work / name))
    return {"photo": work / "photo.png", "masks": masks, "push": spec.get("push", []), "size": dsize,
            "sizes": spec.get("size", [])}


def bench_pipeline(example=EXAMPLE, size: int = PIPELINE["size"].default, repeats: int = PIPELINE["repeats"].default,
                   seconds: float = PIPELINE["seconds"].default, fps: float = 30.0,
                   echo=print) -> dict:
    PIPELINE.check(size=size, repeats=repeats)  # before any work, as the command refuses them

    import physomni_usd as api

    from ..settings import BuildSettings, SimulateSettings

    example = pathlib.Path(example)
    with tempfile.TemporaryDirectory(prefix="physomni-bench-") as tmp:
        work = pathlib.Path(tmp)
        ex = _resized_example(example, size, work)
        builds = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            result = api.build(ex["photo"], work / "shot", ex["masks"], (), BuildSettings(fps=fps), pushes=ex["push"],
                           sizes=ex["sizes"])
            builds.append((time.perf_counter() - t0, result.seconds))
        median = statistics.median(t for t, _ in builds)
        stages = min(builds, key=lambda b: abs(b[0] - median))[1]
        t0 = time.perf_counter()
        result = api.build(ex["photo"], work / "run", ex["masks"], (), BuildSettings(fps=fps), pushes=ex["push"],
                           sizes=ex["sizes"])
        t_build = time.perf_counter() - t0
        sim = api.simulate(result.shot, SimulateSettings(seconds=seconds))
        ren = api.render(result.shot)
        t_run = time.perf_counter() - t0
    out = {
        "example": example.name, "width": ex["size"][0], "height": ex["size"][1], "objects": len(ex["masks"]),
        "machine": f"{platform.machine()}, {platform.processor() or platform.system()}, "
                   f"{__import__('os').cpu_count()} cores",
        "build_seconds_median": round(median, 3), "build_stages": stages,
        "run_seconds": round(t_run, 3), "run_breakdown": {
            "build": round(t_build, 3), "simulate": sim["total_seconds"], "simulate_model": sim["seconds"]["build_model"],
            "simulate_step": sim["seconds"]["step"], "render": ren["total_seconds"],
            "render_frames_per_second": ren["frames_per_second"]},
        "simulated_seconds": seconds, "fps": fps, "frames": sim["frames"],
    }
    echo(f"{'example':<12}{'size':>10}{'objects':>9}{'build s':>10}{'run s':>9}{'sim s':>8}{'render s':>10}")
    echo(f"{example.name:<12}{ex['size'][0]:>5}x{ex['size'][1]:<4}{len(ex['masks']):>9}{median:>10.2f}"
         f"{t_run:>9.2f}{sim['total_seconds']:>8.2f}{ren['total_seconds']:>10.2f}")
    echo("build stages: " + ", ".join(f"{k} {v:.3f}" for k, v in stages.items()))
    return out
