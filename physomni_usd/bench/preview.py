"""``bench preview``: the live preview's loop (step, read back, publish) on shots of 1 to 20 rigid boxes,
with a headless browser attached where one is installed; ``simulate``'s cost on ten boxes, the whole call
and the command against its stepping (:mod:`.ten_objects`); and ``bench peer``'s ten boxes at rest against
Genesis, when ``genesis-world`` is installed (the ``peer`` extra)."""

from __future__ import annotations

import pathlib
import statistics
import tempfile
import threading

#: Where the bench looks for a browser to attach (Debian's chromium; Playwright's own download is not needed).
CHROMIUM = "/usr/bin/chromium"
BROWSER_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]
#: TARGETS.md: ``simulate``'s stepping as it runs at least this many times as fast as Genesis's on ten boxes.
GENESIS_TARGET = 1.5


def browser_available() -> bool:
    try:
        import playwright  # noqa: F401
    except ImportError:
        return False
    return pathlib.Path(CHROMIUM).is_file()


class _Browser:
    """A headless chromium showing ``url`` in a thread of its own until :meth:`close`."""

    def __init__(self, url: str):
        self.url = url
        self.ready, self.done = threading.Event(), threading.Event()
        self.error = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        self.ready.wait(120)

    def _run(self) -> None:
        try:
            from playwright.sync_api import sync_playwright

            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=BROWSER_ARGS)
                page = browser.new_page(viewport={"width": 1280, "height": 720})
                page.goto(self.url)
                page.get_by_role("button", name="Save take").wait_for(timeout=60000)
                self.ready.set()
                self.done.wait()
                browser.close()
        except Exception as exc:  # reported in the table, the loop is measured without it
            self.error = f"{type(exc).__name__}: {exc}".splitlines()[0]
        finally:
            self.ready.set()

    def close(self) -> None:
        self.done.set()
        self.thread.join(60)


def stirred(n: int) -> list:
    """The force field of the preview rows: a vortex about a vertical axis through the boxes' middle
    (20 m/s² per metre from the axis, falling off as 1/(1 + r), pulling inward at 4 /s², damped at 2 /s,
    nothing beyond 3 m) that keeps them sliding and knocking into each other, so that every pose changes
    every frame and all of them are sent."""
    from ..fields import field_from_values

    rows = (n + 4) // 5
    return [field_from_values("vortex", {"strength": 20.0, "falloff": 1.0, "radial": 4.0, "damping": 2.0, "radius": 3.0,
                                         "position": (0.0, 0.2 * (rows - 1), 0.0)})]


def preview_rate(n: int, seconds: float = 9.0, browser: bool = True, capture: bool = True) -> dict:
    """The preview loop's frames per second on ``n`` boxes kept moving by :func:`stirred`, unpaced (as
    fast as it goes), the first report window (connection, first captures) left out; with where the
    time went."""
    import socket

    from ..preview.app import Options, Preview
    from .scenes import falling_boxes, write_bench_shot

    with tempfile.TemporaryDirectory() as tmp, socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        s.close()
        shot = write_bench_shot(pathlib.Path(tmp), falling_boxes(n), forces=stirred(n))
        said = []
        preview = Preview(shot, Options(port=port, duration=None, paced=False, open_browser=False,
                                        capture=capture, echo=said.append, report_every=2.0))
        url = preview.start()
        attached = _Browser(url) if browser else None
        preview.options.duration = seconds
        result = preview.run()
        if attached:
            attached.close()
    rates = result["rates"][1:] or result["rates"]
    frames = max(result["frames"], 1)
    eng = preview.engine
    q, qd = eng.body_state()
    return {"objects": n, "fps": round(statistics.median(rates), 1) if rates else None,
            "mean_speed_at_end_m_s": round(float(abs(qd[:, :3]).sum(axis=1).mean()), 3),
            "browser": bool(attached and attached.error is None),
            "browser_error": attached.error if attached else None, "captured": eng.captured_frames > 0,
            "substeps": eng.plan.substeps, "iterations": eng.plan.iterations,
            "ms_per_frame": {"advance": round(1000 * eng.seconds["advance"] / frames, 3),
                             "snapshot_readback_record": round(1000 * eng.seconds["frame_other"] / frames, 3),
                             "publish": round(1000 * result["seconds"]["publish"] / frames, 3)}}


def stepping_ten_boxes(capture: bool = True, seconds: float = 2.0) -> dict:
    """``simulate``'s own model and schedule for the ten boxes (the preview's engine, which reuses them),
    stepping only, with and without the frame captured as a graph: seconds per simulated second, three runs."""
    from ..preview.engine import Engine
    from .scenes import falling_boxes, write_bench_shot

    with tempfile.TemporaryDirectory() as tmp:
        e = Engine(write_bench_shot(pathlib.Path(tmp), falling_boxes(10)), capture=capture)
        frames = int(round(seconds * e.fps))
        for _ in range(frames):  # warm: kernels loaded, each schedule the run meets captured once
            e.step()
        costs = []
        for _ in range(3):
            e._reset()
            before = e.seconds["advance"]
            for _ in range(frames):
                e.step()
            costs.append((e.seconds["advance"] - before) / seconds)
    return {"captured": e.captured_frames > 0, "substeps": e.plan.substeps, "iterations": e.plan.iterations,
            "graphs": e.captures, "runs_seconds_per_sim_second": costs, "seconds_per_sim_second": round(statistics.median(costs), 4)}


def bench_preview(quick: bool = False, echo=print) -> dict:
    """Run the preview bench; prints a table and returns the numbers."""
    import os

    from . import peer
    from .peer import genesis_available
    from .physics import machine
    from .scenes import in_fresh_interpreter
    from .ten_objects import CASES, ten_objects

    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    echo(f"machine: {machine()}; load average {', '.join(f'{x:.2f}' for x in load) if load else 'unknown'}")
    attach = browser_available()
    if not attach:
        echo("browser: none found (pip install playwright; apt-get install chromium): loop measured without one")
    sizes = (1, 20) if quick else (1, 5, 10, 20)
    seconds = 6.0 if quick else 9.0
    rows = []
    for n in sizes:
        r = in_fresh_interpreter(__name__, "preview_rate", n=n, seconds=seconds, browser=attach)
        rows.append(r)
        echo(f"preview, {n:2d} rigid objects: {_row(r)}")
    eager = in_fresh_interpreter(__name__, "preview_rate", n=20, seconds=seconds, browser=attach, capture=False)
    echo(f"preview, 20 rigid objects, step launched kernel by kernel (no graph): {_row(eager)}")
    ten = {case: ten_objects(echo=echo, case=case) for case in (("at_rest",) if quick else CASES)}
    stepping = {k: in_fresh_interpreter(__name__, "stepping_ten_boxes", capture=k == "graph")
                for k in ("graph", "launches")}
    for k, r in stepping.items():
        echo(f"the preview engine's step on ten boxes dropped, "
             f"{'captured as one graph a frame' if k == 'graph' else 'kernel by kernel'} (stepping only): "
             f"{r.get('seconds_per_sim_second', r)} s per simulated second")
    out = {"load_average": load, "browser_attached": attach, "preview": rows, "preview_20_without_graph": eager,
           "simulate_ten_boxes": ten, "stepping_ten_boxes": stepping}
    if not genesis_available():
        echo("genesis: not installed (pip install 'physomni-usd[peer]'); no ratio")
        out["genesis"] = None
        return out
    g = in_fresh_interpreter(peer.__name__, "run_case", name="boxes_at_rest")
    out["genesis"] = g
    if "error" in g:
        echo(f"genesis: {g['error']}")
        return out
    median = g["ratio"]["median"]
    echo(f"bench peer's {peer.case_line(g)}; {'meets' if median >= GENESIS_TARGET else 'misses'} the target of "
         f"≥ {GENESIS_TARGET:g}× Genesis")
    return out


def _row(r: dict) -> str:
    if "error" in r:
        return f"failed: {r['error']}"
    ms = r["ms_per_frame"]
    return (f"{r['fps']} fps ({'browser attached' if r['browser'] else 'no browser'}"
            f"{', graph' if r['captured'] else ''}; {r['substeps']} substeps; ms a frame: advance {ms['advance']}, "
            f"snapshot+read-back {ms['snapshot_readback_record']}, publish {ms['publish']})")
