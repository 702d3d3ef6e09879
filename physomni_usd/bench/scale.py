"""``bench scale``: what a larger photo costs each stage, as ratios to the smallest; and what more objects cost
``simulate`` (:func:`bench_objects`).

One example (the motorcycle by default) is scaled to each size asked for (photo by cubic interpolation, masks
by their pixels' majority), and ``build``, ``simulate`` and ``render`` run on it each in a fresh process, the
sizes alternating within each repeat so that they share the machine's load. Per stage: wall seconds, CPU
seconds (user + system, of the process and its children: what the load does not inflate) and peak resident
memory (the process's own, from ``wait4``), and the load average over the run. Each size's whole ``run`` is
also put over the first size's of the same repeat (:func:`_paired`), so that a load that swings between
repeats weighs on both sides of each ratio.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

from ..perceive.masks import box_spec, photo_size
from .limits import EXAMPLE, SCALE, SCALE_SIZES_MP, SCALE_STAGES, WHOLE_BOX

#: Megapixels of the photos and the stages by default (``bench.limits``, where the command reads them too).
SIZES_MP = SCALE_SIZES_MP
STAGES = SCALE_STAGES


def scaled_example(folder: pathlib.Path, megapixels: float | None, out: pathlib.Path) -> list[str]:
    """The example of ``folder`` (its example.json) at ``megapixels`` (None: as it is) in ``out``; returns the
    arguments of its ``build`` (photo, masks, boxes, sizes and pushes)."""
    spec = json.loads((folder / "example.json").read_text())
    photo = cv2.imread(str(folder / spec["photo"]), cv2.IMREAD_COLOR)
    h, w = photo.shape[:2]
    s = 1.0 if megapixels is None else float(np.sqrt(megapixels * 1e6 / (h * w)))
    size = (max(16, int(w * s)), max(16, int(h * s)))
    out.mkdir(parents=True, exist_ok=True)
    if megapixels is None:
        name = folder / spec["photo"]
    else:
        name = out / "photo.png"
        cv2.imwrite(str(name), cv2.resize(photo, size, interpolation=cv2.INTER_CUBIC if s > 1 else cv2.INTER_AREA))
    args = [str(name)]
    for m in spec.get("masks", []):
        path, _, label = m.partition(":")
        mask = cv2.imread(str(folder / path), cv2.IMREAD_GRAYSCALE)
        if megapixels is not None:
            mask = (cv2.resize((mask > 0).astype(np.uint8) * 255, size, interpolation=cv2.INTER_LINEAR) >= 128)
            mask = mask.astype(np.uint8) * 255
            target = out / pathlib.Path(path).name
            cv2.imwrite(str(target), mask)
        else:
            target = folder / path
        args += ["--mask", f"{target}:{label}" if label else str(target)]
    for b in spec.get("boxes", []):
        coords, _, rest = b.partition(":")
        scaled = ",".join(str(int(round(float(c) * s))) for c in coords.split(","))
        args += ["--box", scaled + (":" + rest if rest else "")]
    for key in ("size", "push"):
        for v in spec.get(key, []):
            args += [f"--{key}", v]
    return args


def whole_box_example(folder: pathlib.Path, size: tuple[int, int], out: pathlib.Path, on: int = WHOLE_BOX["on"],
                      off: int = WHOLE_BOX["off"], seed: int = WHOLE_BOX["seed"]) -> list[str]:
    """``build``'s arguments for the example of ``folder`` stretched to ``size`` (W, H) in ``out``, its objects
    given as ONE box over the whole frame labelled as the first mask, with ``on`` clicks on the masks (shared
    among them in turn, each at least 6 px inside one) and ``off`` clicks at least 30 px from every mask, drawn
    from ``seed``: the case of a user who boxes the whole photo and clicks."""
    from ..errors import InputError

    spec = json.loads((folder / "example.json").read_text())
    if not spec.get("masks"):
        raise InputError(f"--example {folder}: its example.json names no masks to draw the clicks from")
    w, h = size
    photo = cv2.imread(str(folder / spec["photo"]), cv2.IMREAD_COLOR)
    grow = w * h > photo.shape[0] * photo.shape[1]
    out.mkdir(parents=True, exist_ok=True)
    name = out / "photo.png"
    cv2.imwrite(str(name), cv2.resize(photo, (w, h), interpolation=cv2.INTER_CUBIC if grow else cv2.INTER_AREA))
    masks, labels = [], []
    for m in spec["masks"]:
        path, _, label = m.partition(":")
        mask = cv2.imread(str(folder / path), cv2.IMREAD_GRAYSCALE)
        masks.append(cv2.resize((mask > 0).astype(np.uint8) * 255, (w, h), interpolation=cv2.INTER_LINEAR) >= 128)
        labels.append(label or pathlib.Path(path).stem)
    rng = np.random.default_rng(seed)
    clicks = []
    inside = [np.nonzero(cv2.distanceTransform(m.astype(np.uint8), cv2.DIST_L2, 5) > 6) for m in masks]
    for (ys, _), label in zip(inside, labels):
        if not len(ys):
            raise InputError(f"--whole-box {w}x{h}: the mask of {label!r} has no pixel 6 px inside it to click on "
                             f"at this size; give a larger size")
    for k in range(on):  # the masks in turn: 12 on three masks is 4 on each
        ys, xs = inside[k % len(masks)]
        i = int(rng.integers(len(ys)))
        clicks.append((int(xs[i]), int(ys[i]), True))
    anywhere = np.any(masks, axis=0).astype(np.uint8)
    ys, xs = np.nonzero(cv2.distanceTransform(1 - anywhere, cv2.DIST_L2, 5) > 30)
    if len(ys) < off:
        raise InputError(f"--whole-box {w}x{h}: {len(ys)} pixels lie 30 px off every mask, fewer than the {off} "
                         f"clicks to draw there; give a larger size")
    clicks += [(int(xs[i]), int(ys[i]), False) for i in rng.choice(len(ys), off, replace=False)]
    return [str(name), "--box", box_spec((0, 0, w, h), labels[0], clicks)]


def bench_whole_box(example: pathlib.Path = EXAMPLE, size: tuple[int, int] = WHOLE_BOX["size"],
                    repeats: int = SCALE["repeats"].default, echo=print) -> dict:
    """``build`` (a fresh process each repeat) of :func:`whole_box_example` at ``size``: wall seconds, CPU
    seconds, peak memory and build's own per-stage wall and CPU seconds (report.json's ``build.seconds`` and
    ``build.cpu_seconds``), each repeat's and their medians."""
    from ..errors import InputError

    SCALE.check(repeats=repeats)
    try:
        SCALE.check(whole_box=tuple(size))
    except InputError:  # the option as typed, not the one side
        limit = SCALE["whole_box"]
        raise InputError(f"{limit.flag} {'x'.join(map(str, size))}: must be WxH with each side a whole number, "
                         f"{limit.span()}") from None

    if not (pathlib.Path(example) / "example.json").is_file():
        raise InputError(f"--example {example}: no example.json in it")
    w, h = size
    cli = [sys.executable, "-m", "physomni_usd.cli"]
    runs = []
    with tempfile.TemporaryDirectory(prefix="physomni-wholebox-") as tmp:
        root = pathlib.Path(tmp)
        args = whole_box_example(pathlib.Path(example), (w, h), root / "in")
        for r in range(repeats):
            shot = root / f"shot-{r}"
            row = _timed(cli + ["build", *args, "-o", str(shot), "-q"], dict(os.environ))
            built = json.loads((shot / "report.json").read_text())["stages"]["build"]
            row["stages_wall_s"] = built["seconds"]
            row["stages_cpu_s"] = built.get("cpu_seconds", {})
            runs.append(row)
            echo(f"whole box: {w}×{h}, repeat {r + 1}: build {row['wall_s']:.1f} s wall / {row['cpu_s']:.1f} s cpu / "
                 f"{row['peak_mb']:.0f} MB (load {row['load']:.1f})")
    median = {m: float(np.median([run[m] for run in runs])) for m in ("wall_s", "cpu_s", "peak_mb", "load")}
    stages = {k: {"wall_s": round(float(np.median([run["stages_wall_s"].get(k, 0.0) for run in runs])), 2),
                  "cpu_s": round(float(np.median([run["stages_cpu_s"].get(k, 0.0) for run in runs])), 2)}
              for k in runs[0]["stages_wall_s"]}
    table = [f"{'stage':>18} {'wall s':>8} {'cpu s':>8}"]
    table += [f"{k:>18} {v['wall_s']:8.2f} {v['cpu_s']:8.2f}" for k, v in stages.items()]
    table.append(f"{'build (process)':>18} {median['wall_s']:8.2f} {median['cpu_s']:8.2f}   peak "
                 f"{median['peak_mb']:.0f} MB, load {median['load']:.1f} (medians of {repeats})")
    echo("\n".join(table))
    return {"example": str(example), "width": w, "height": h, "box": args[2], "repeats": repeats,
            "median": median, "stages": stages, "runs": runs}


def _timed(cmd: list[str], env: dict) -> dict:
    """Run ``cmd``; its wall seconds, CPU seconds (user + system) and peak resident memory (MB)."""
    load = os.getloadavg()[0]
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd[:4])} ... failed ({proc.returncode}): {err.strip()[-400:]}")
    return {"wall_s": round(wall, 2), "cpu_s": round(usage.ru_utime + usage.ru_stime, 2),
            "peak_mb": round(usage.ru_maxrss / 1024.0, 1), "load": round((load + os.getloadavg()[0]) / 2, 2)}


def bench_scale(example: pathlib.Path = EXAMPLE, sizes=SIZES_MP, repeats: int = SCALE["repeats"].default,
                seconds: float = SCALE["seconds"].default, stages=STAGES, max_size: int = SCALE["max_size"].default,
                echo=print) -> dict:
    """Each size's stages, ``repeats`` times with the sizes alternating; medians and ratios to the smallest.
    A size of 0 means the example as it is. A folder without example.json is refused (InputError)."""
    SCALE.check(repeats=repeats, seconds=seconds, max_size=max_size)  # before any work, as the command refuses them

    from ..errors import InputError

    if not (pathlib.Path(example) / "example.json").is_file():
        raise InputError(f"--example {example}: no example.json in it")
    env = dict(os.environ)
    cli = [sys.executable, "-m", "physomni_usd.cli"]
    runs: dict[float, list[dict]] = {s: [] for s in sizes}
    pixels = {}
    with tempfile.TemporaryDirectory(prefix="physomni-scale-") as tmp:
        root = pathlib.Path(tmp)
        inputs = {s: scaled_example(example, s or None, root / f"in-{s}") for s in sizes}
        for s in sizes:
            pixels[s] = photo_size(pathlib.Path(inputs[s][0]))
        for r in range(repeats):
            for s in sizes:
                shot = root / f"shot-{s}"
                row = {}
                if "build" in stages:
                    row["build"] = _timed(cli + ["build", *inputs[s], "-o", str(shot), "-q"], env)
                if "simulate" in stages:
                    row["simulate"] = _timed(cli + ["simulate", str(shot / "shot.usda"), "--seconds", str(seconds),
                                                    "-q"], env)
                if "render" in stages:
                    row["render"] = _timed(cli + ["render", str(shot / "shot.usda"), "--max-size", str(max_size),
                                                  "-q"], env)
                runs[s].append(row)
                w, h = pixels[s]
                echo(f"scale: {w}×{h} ({w * h / 1e6:.2f} MP), repeat {r + 1}: " + ", ".join(
                    f"{k} {v['wall_s']:.1f} s wall / {v['cpu_s']:.1f} s cpu / {v['peak_mb']:.0f} MB "
                    f"(load {v['load']:.1f})" for k, v in row.items()))
    rows = []
    base = None
    first = sizes[0] if sizes else None
    for s in sizes:
        w, h = pixels[s]
        med = {k: {m: float(np.median([run[k][m] for run in runs[s]])) for m in ("wall_s", "cpu_s", "peak_mb",
                                                                                   "load")}
               for k in runs[s][0]}
        total = {m: sum(med[k][m] for k in med) for m in ("wall_s", "cpu_s")}
        total["peak_mb"] = max(med[k]["peak_mb"] for k in med)
        total["load"] = float(np.mean([med[k]["load"] for k in med]))  # the run's stages' mean
        med["run"] = total
        base = base or med
        ratios = {k: {m: round(med[k][m] / max(base[k][m], 1e-9), 2) for m in ("wall_s", "cpu_s", "peak_mb")}
                  for k in med}
        rows.append({"megapixels": round(w * h / 1e6, 2), "width": w, "height": h, "median": med,
                     "ratio_to_smallest": ratios, "runs": runs[s], "run_by_repeat": _paired(runs[s], runs[first])})
    table = [f"{'photo':>14} {'stage':>9} {'wall s':>8} {'cpu s':>8} {'peak MB':>8} {'× wall':>7} {'× cpu':>7} "
             f"{'× peak':>7} {'load':>5}"]
    for row in rows:
        for k, v in row["median"].items():
            q = row["ratio_to_smallest"][k]
            table.append(f"{row['width']}×{row['height']:<7} {k:>9} {v['wall_s']:8.1f} {v['cpu_s']:8.1f} "
                         f"{v['peak_mb']:8.0f} {q['wall_s']:7.2f} {q['cpu_s']:7.2f} {q['peak_mb']:7.2f} "
                         f"{v['load']:5.1f}")
    for row in rows[1:]:
        paired = row["run_by_repeat"]
        w0, h0 = rows[0]["width"], rows[0]["height"]
        echo(f"{row['width']}×{row['height']} run against {w0}×{h0}, repeat by repeat (each pair at one round's "
             f"load): CPU ×{', '.join(f'{q:.2f}' for q in paired['cpu_s'])} (min {paired['min']['cpu_s']:.2f}, "
             f"median {paired['median']['cpu_s']:.2f}); wall ×{', '.join(f'{q:.2f}' for q in paired['wall_s'])} "
             f"(min {paired['min']['wall_s']:.2f}, median {paired['median']['wall_s']:.2f}); load "
             f"{', '.join(f'{x:.1f}' for x in paired['load'])}")
    echo("\n".join(table))
    return {"example": str(example), "repeats": repeats, "seconds": seconds, "max_size": max_size, "rows": rows}


def _paired(runs: list[dict], base: list[dict]) -> dict:
    """Each repeat's whole ``run`` (its stages' sum) over the first size's in the same repeat: the two ran one
    after the other, so a shared machine's load, which swings between repeats, weighs on both alike. The
    ratios per repeat, their min and median, and each pair's mean load."""
    def total(run: dict, m: str) -> float:
        return sum(v[m] for v in run.values())

    out = {m: [round(total(a, m) / max(total(b, m), 1e-9), 3) for a, b in zip(runs, base)] for m in ("wall_s", "cpu_s")}
    out["load"] = [round(float(np.mean([v["load"] for v in (*a.values(), *b.values())])), 2) for a, b in zip(runs, base)]
    out["min"] = {m: min(out[m]) for m in ("wall_s", "cpu_s")}
    out["median"] = {m: float(np.median(out[m])) for m in ("wall_s", "cpu_s")}
    return out


#: Object counts of the second axis: boxes dropped onto the ground five to a row (``bench physics``' ten objects'
#: scene, :func:`~physomni_usd.bench.scenes.falling_boxes`), each landing on its own: the rigid contacts are
#: those of each box's base with the ground, as many as the boxes.
COUNTS = (3, 10, 30, 100)


def bench_objects(counts=COUNTS, seconds: float = 2.0, echo=print) -> dict:
    """``simulate`` (each a fresh process) on ``counts`` dropped boxes for ``seconds``: the command's wall and
    CPU seconds and peak memory, and its stepping's seconds (the report's ``seconds.step``), as ratios to the
    fewest; ``exponent``: the slope of log(stepping seconds) over log(boxes), least squares (1: the stepping
    grows as the boxes and their contacts do), in wall seconds and in the stepping's CPU seconds
    (``seconds.step_cpu``: what a shared machine's load, which swings the wall's between counts, does not
    inflate); ``exponent_cpu_by_contacts``: the CPU seconds' slope over the rigid contacts the solver held (the
    mean over the guard's checks, ``guard.rigid_contacts``), the growth the stepping should not outrun."""
    from ..errors import InputError
    from .scenes import falling_boxes, write_bench_shot

    if not counts:
        raise InputError("--objects: give at least one count of boxes, e.g. 3,10,30,100")
    SCALE.check(objects=tuple(counts), seconds=seconds)

    env = dict(os.environ)
    rows = []
    with tempfile.TemporaryDirectory(prefix="physomni-objects-") as tmp:
        for n in counts:
            folder = pathlib.Path(tmp) / f"boxes-{n}"
            shot = write_bench_shot(folder, falling_boxes(n))
            row = _timed([sys.executable, "-m", "physomni_usd.cli", "simulate", str(shot), "--seconds",
                          str(seconds), "-q"], env)
            report = json.loads((folder / "report.json").read_text())
            times = report["stages"]["simulate"]["seconds"]
            row["step_s"], row["step_cpu_s"] = float(times["step"]), float(times["step_cpu"])
            contacts = report["stages"]["simulate"]["guard"].get("rigid_contacts") or {}
            row["contacts"] = contacts.get("mean")
            row["objects"] = n
            rows.append(row)
            echo(f"objects: {n} boxes: simulate {row['wall_s']:.1f} s wall / {row['cpu_s']:.1f} s cpu / "
                 f"{row['peak_mb']:.0f} MB, stepping {row['step_s']:.2f} s wall / {row['step_cpu_s']:.2f} s cpu "
                 f"(load {row['load']:.1f})")
    base = rows[0]
    for row in rows:
        row["ratio_to_fewest"] = {k: round(row[k] / max(base[k], 1e-9), 2)
                                  for k in ("wall_s", "cpu_s", "step_s", "step_cpu_s")}
    x = np.log([r["objects"] for r in rows])

    def slope(key: str) -> float:
        y = np.log([max(r[key], 1e-9) for r in rows])
        return float(np.polyfit(x, y, 1)[0]) if len(rows) > 1 else float("nan")

    exponent, exponent_cpu = slope("step_s"), slope("step_cpu_s")
    # against the contacts the solver held (their mean over the guard's checks), not the boxes assumed to make them
    counted = len(rows) > 1 and all(r["contacts"] for r in rows)
    by_contacts = (float(np.polyfit(np.log([r["contacts"] for r in rows]),
                                    np.log([max(r["step_cpu_s"], 1e-9) for r in rows]), 1)[0])
                   if counted else float("nan"))
    table = [f"{'boxes':>6} {'contacts':>8} {'wall s':>8} {'cpu s':>8} {'step s':>8} {'step cpu':>8} {'peak MB':>8} "
             f"{'× step':>7} {'× cpu':>6} {'load':>5}"]
    for r in rows:
        table.append(f"{r['objects']:>6} {r['contacts'] or 0:8.0f} {r['wall_s']:8.1f} {r['cpu_s']:8.1f} "
                     f"{r['step_s']:8.2f} {r['step_cpu_s']:8.2f} {r['peak_mb']:8.0f} "
                     f"{r['ratio_to_fewest']['step_s']:7.2f} {r['ratio_to_fewest']['step_cpu_s']:6.2f} {r['load']:5.1f}")
    table.append(f"stepping grows as boxes^{exponent:.2f} in wall seconds, boxes^{exponent_cpu:.2f} in CPU seconds "
                 f"(least squares over {len(rows)} counts); against the rigid contacts, contacts^{by_contacts:.2f} "
                 "in CPU seconds")
    echo("\n".join(table))
    return {"seconds": seconds, "rows": rows, "exponent": round(exponent, 3), "exponent_cpu": round(exponent_cpu, 3),
            "exponent_cpu_by_contacts": round(by_contacts, 3) if np.isfinite(by_contacts) else None}
