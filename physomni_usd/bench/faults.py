"""``bench faults``: the reliability matrix. Each case plays one hostile or unlucky thing a user or a farm
does to a finished shot (a signal mid-render, a kill, a photo bomb, two writers, a NaN, a page on another
origin, a redirect that would take the API key, a full disk) through the real CLI in a fresh interpreter,
and says per trial whether it ended clean: one line, the right exit code, nothing the user had changed.

The same case functions are the assertions of ``tests/test_faults.py``; a case takes a finished shot
(``base``: its folder and the photo and masks it was run from) and a scratch folder, and returns its
trials as ``(clean, what happened)``.
"""

from __future__ import annotations

import http.server
import json
import os
import pathlib
import shutil
import signal
import struct
import subprocess
import sys
import threading
import time
import zlib

from .fault_tools import cli, command, copy_shot, one_error_line, run_args, snapshot
from .hostile_folders import (case_huge_label, case_planted_journal, case_preview_keep, case_symlinked_layer,
                              case_symlinked_lock, case_uncomposable)


def signal_when(args, marker: str, signum: int, timeout: float = 600) -> tuple[int, str]:
    """Start ``physomni-usd ARGS``, send ``signum`` once a stderr line starts with ``marker``; returns the
    exit code and stderr."""
    # a SIGHUP the parent inherited ignored (a suite started under nohup) the command rightly keeps ignored:
    # the trial is of a terminal's hang-up, so its child starts with the default
    hangup = (lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL)) if signum == signal.SIGHUP else None
    proc = subprocess.Popen(command(*args), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            preexec_fn=hangup)
    seen, sent = [], False
    deadline = time.monotonic() + timeout
    for line in proc.stderr:
        seen.append(line)
        if not sent and line.startswith(marker):
            if proc.poll() is not None:  # ended before we read its line: no signal sent, said as exit -999
                break
            proc.send_signal(signum)
            sent = True
        if time.monotonic() > deadline:
            proc.kill()
            break
    rc = proc.wait()
    return (rc if sent else -999), "".join(seen)


# --- the cases ---------------------------------------------------------------------------------------

def _signal_trial(base, folder, signum, args, marker):
    before = snapshot(folder)
    cmd = run_args(base, folder) if args is None else [args, folder / "shot.usda"]
    rc, err = signal_when(cmd, marker, signum)
    same = snapshot(folder) == before
    ok = rc == 128 + signum and same and one_error_line(err, f"interrupted by {signum.name}")
    return ok, f"{signum.name} at '{marker}': exit {rc}, shot {'unchanged' if same else 'CHANGED'}"


def case_terminated_rerun(base, work):
    """SIGTERM during a re-`run`'s render, SIGHUP during a `simulate`: the old shot, byte for byte."""
    trials = []
    for signum, args, marker in ((signal.SIGTERM, None, "render"), (signal.SIGHUP, "simulate", "simulate: frame")):
        trials.append(_signal_trial(base, copy_shot(base, work / f"rerun_{signum.name}"), signum, args, marker))
    return trials


def sighup_under_load(base, work, runs: int = 20, load: int = 8):
    """The SIGHUP re-`simulate` trial ``runs`` times in a row beside ``load`` CPU-bound processes: a signal
    whose exception a library swallowed (trimesh's optional imports catch BaseException) used to be lost
    there now and then (exit 0, the new sim.usdc kept). Not in :data:`CASES`: it takes minutes and loads the
    machine."""
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(load)]
    trials = []
    try:
        for k in range(runs):
            folder = copy_shot(base, work / f"loaded_{k}")
            ok, said = _signal_trial(base, folder, signal.SIGHUP, "simulate", "simulate: frame")
            trials.append((ok, f"run {k + 1}/{runs} beside {load} busy processes: {said}"))
            shutil.rmtree(folder)
    finally:
        for p in burners:
            p.kill()
            p.wait()
    return trials


def case_terminated_new_folder(base, work):
    """SIGTERM while `run` builds a new folder: no half-built shot is left."""
    out = work / "fresh" / "shot"
    rc, err = signal_when(run_args(base, out), "simulate: frame", signal.SIGTERM)
    left = out.parent.exists()
    return [(rc == 143 and not left and one_error_line(err, "SIGTERM"),
             f"exit {rc}, {'folder left behind' if left else 'no folder left'}")]


def case_killed_leftovers(base, work):
    """SIGKILL mid-render leaves a temporary video and a journal; the next command on the shot cleans them
    and the old video is still there. A kill between two writes of one command (the commit window) is
    undone by the next writer: the old sim.usdc with the old report.json."""
    folder = copy_shot(base, work / "killed")
    video = (folder / "video.mp4").read_bytes()
    rc, _ = signal_when(["render", folder / "shot.usda"], "render: frame", signal.SIGKILL)
    hidden = sorted(p.name for p in folder.iterdir() if p.name.startswith("."))
    proc = cli("estimate", folder / "shot.usda", "-q")
    after = sorted(p.name for p in folder.iterdir() if p.name.startswith("."))
    kept = (folder / "video.mp4").read_bytes() == video
    trials = [(rc == -9 and bool(hidden) and proc.returncode == 0 and not after and kept,
               f"killed render left {hidden}; after the next command: {after}, video "
               f"{'kept' if kept else 'LOST'}")]
    folder = copy_shot(base, work / "commit_window")
    before = snapshot(folder)
    child = ("import os, sys\nfrom physomni_usd._files import all_or_nothing, write_bytes\n"
             "with all_or_nothing():\n    write_bytes(sys.argv[1] + '/sim.usdc', b'new')\n"
             "    os._exit(9)  # killed before report.json\n")
    subprocess.run([sys.executable, "-c", child, str(folder)], check=False)
    torn = (folder / "sim.usdc").read_bytes() == b"new"
    proc = cli("estimate", folder / "shot.usda", "-q")
    now = snapshot(folder)
    same = all(now.get(k) == v for k, v in before.items() if k not in ("physics.usda", "report.json"))
    trials.append((torn and proc.returncode == 0 and same and set(now) == set(before),
                   f"kill in the commit window: next command put the old sim.usdc back: {same}"))
    return trials


def huge_png(path: pathlib.Path, w: int = 30000, h: int = 30000) -> pathlib.Path:
    """A valid grey PNG of ``w`` × ``h`` black pixels, a few MB on disk."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    comp = zlib.compressobj(1)
    rows = 1000
    block = b"\0" * ((w + 1) * rows)
    parts = [comp.compress(block) for _ in range(h // rows)]
    parts += [comp.compress(b"\0" * ((w + 1) * (h % rows))), comp.flush()]
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", b"".join(parts))
                     + chunk(b"IEND", b""))
    return path


def case_photo_bomb(base, work):
    """A 30000 × 30000 PNG is refused from its header: under 5 s and under 1 GB; 65 boxes and 600 s × 1000
    substeps are refused before any work."""
    photo = huge_png(work / "huge.png")
    t0 = time.perf_counter()
    # A child's peak memory starts at its parent's when it forks (Linux carries the high-water mark across
    # exec), so a large parent (a test run) would read as a large build: a small Python forks the build
    # and tells its own children's peak, which is the build's alone.
    probe = ("import resource, subprocess, sys\n"
             "code = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode\n"
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
             "sys.exit(code)\n")
    proc = subprocess.run([sys.executable, "-c", probe, *command("build", photo, "-o", work / "bomb", "--box",
                                                                 "1,1,50,50")],
                          capture_output=True, text=True)
    err = proc.stderr
    seconds, peak_mb = time.perf_counter() - t0, int(proc.stdout.split()[-1]) / 1024
    trials = [(proc.returncode == 2 and seconds < 5 and peak_mb < 1024 and one_error_line(err, "--max-pixels"),
               f"30000×30000 PNG: exit {proc.returncode} in {seconds:.1f} s, peak {peak_mb:.0f} MB")]
    boxes = [a for i in range(65) for a in ("--box", f"{i},{i},{i + 20},{i + 20}")]
    proc = cli("build", base["photo"], "-o", work / "boxes", *boxes)
    trials.append((proc.returncode == 2 and one_error_line(proc.stderr, "at most") and not (work / "boxes").exists(),
                   f"65 boxes: exit {proc.returncode}"))
    folder = copy_shot(base, work / "steps")
    before = snapshot(folder)
    proc = cli("simulate", folder / "shot.usda", "--seconds", 600, "--substeps", 1000)
    trials.append((proc.returncode == 2 and one_error_line(proc.stderr, "--substeps", "solver steps")
                   and snapshot(folder) == before, f"600 s × 1000 substeps: exit {proc.returncode}"))
    return trials


def case_concurrent_set(base, work, trials: int = 2):
    """Two `estimate --set` on one shot at once: both values land (or one fails in one line)."""
    out = []
    for t in range(trials):
        folder = copy_shot(base, work / f"concurrent_{t}")
        first, second = base["labels"]
        a = subprocess.Popen(command("estimate", folder, "--set", f"{first}.density=512", "-q"),
                             stderr=subprocess.PIPE, text=True)
        b = subprocess.Popen(command("estimate", folder, "--set", f"{second}.density=713", "-q"),
                             stderr=subprocess.PIPE, text=True)
        results = [(p.wait(), p.stderr.read()) for p in (a, b)]
        edits = (folder / "edits.usda").read_text()
        landed = [v for v in ("512", "713") if f"density = {v}" in edits]
        failed_clean = all(rc == 0 or one_error_line(err) for rc, err in results)
        ok = failed_clean and all(rc != 0 or v in landed for (rc, _), v in zip(results, ("512", "713")))
        out.append((ok, f"exits {[r[0] for r in results]}, in edits.usda: {landed}"))
    return out


NAN_EDITS = """#usda 1.0
(
    timeCodesPerSecond = {fps}
    framesPerSecond = {fps}
)

over "World"
{{
    over "Objects"
    {{
        over "{prim}"
        {{
            {line}
        }}
    }}
{extra}}}
"""


def case_non_finite(base, work):
    """A NaN translate (validate, simulate, render), a NaN velocity and a gravity of 1e30 (validate): one
    line naming prim and attribute, exit 2, nothing replaced."""
    from pxr import Usd

    stage = Usd.Stage.Open(str(base["dir"] / "shot.usda"))
    fps = stage.GetTimeCodesPerSecond()
    prim = next(p.GetName() for p in stage.GetPrimAtPath("/World/Objects").GetChildren())
    scene = next((p for p in stage.Traverse() if p.GetTypeName() == "PhysicsScene"), None)
    cases = [("double3 xformOp:translate = (nan, 0, 0)", "", "xformOp:translate", ("validate", "simulate", "render")),
             ("vector3f physics:velocity = (nan, 0, 0)", "", "physics:velocity", ("validate",))]
    if scene is not None:
        rel = str(scene.GetPath()).split("/")[1:]
        gravity = "".join(f'{"    " * i}over "{n}"\n{"    " * i}{{\n' for i, n in enumerate(rel[1:], 1))
        gravity += "    " * len(rel) + "float physics:gravityMagnitude = 1e30\n"
        gravity += "".join(f'{"    " * i}}}\n' for i in range(len(rel) - 1, 0, -1))
        cases.append(("", gravity, "physics:gravityMagnitude", ("validate", "simulate")))
    trials = []
    for i, (line, extra, attr, commands) in enumerate(cases):
        folder = copy_shot(base, work / f"nan_{i}")
        (folder / "edits.usda").write_text(NAN_EDITS.format(fps=fps, prim=prim, line=line, extra=extra))
        before = snapshot(folder)
        for c in commands:
            proc = cli(c, folder / "shot.usda")
            ok = proc.returncode == 2 and one_error_line(proc.stderr, attr) and snapshot(folder) == before
            trials.append((ok, f"{attr} → {c}: exit {proc.returncode}"))
    return trials


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def case_preview_origin(base, work):
    """A page on another origin (or a rebound DNS name) cannot open the preview's websocket; its own page can."""
    import asyncio

    import viser
    import websockets

    folder = copy_shot(base, work / "preview")
    before = snapshot(folder)
    port = _free_port()
    proc = subprocess.Popen(command("preview", folder / "shot.usda", "--port", port, "--duration", 300, "--no-open"),
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        for line in proc.stderr:
            if line.startswith("preview: http"):
                break

        async def attempt(origin):
            try:
                async with websockets.connect(f"ws://127.0.0.1:{port}/", origin=origin, open_timeout=20,
                                              subprotocols=[f"viser-v{viser.__version__}"]):
                    return "accepted"
            except websockets.exceptions.InvalidStatus as exc:
                return f"refused {exc.response.status_code}"

        evil = asyncio.run(attempt("http://evil.example"))
        own = asyncio.run(attempt(f"http://127.0.0.1:{port}"))
        import http.client

        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
        conn.request("GET", "/", headers={"Host": f"evil.example:{port}"})  # a DNS name rebound to 127.0.0.1
        rebound = f"refused {conn.getresponse().status}"
        conn.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)
    same = snapshot(folder) == before
    trials = [(evil == "refused 403", f"Origin evil.example: {evil}"),
              (rebound == "refused 403", f"rebound DNS name: {rebound}"),
              (own == "accepted" and same, f"its own page: {own}; files {'unchanged' if same else 'CHANGED'}")]
    # with --record (and --play, since the page otherwise waits paused on the photo): Ctrl-C in a preview
    # started in a script's background (SIGINT inherited ignored) and a farm's SIGTERM both stop it, take saved
    take = folder / "sim.usdc"
    for signum, how in ((signal.SIGINT, "SIGINT inherited ignored, then Ctrl-C"), (signal.SIGTERM, "SIGTERM")):
        # a take of a shot at rest can be byte for byte the last one: a new file (renamed in) is what shows
        old_take = (take.stat().st_ino, take.stat().st_mtime_ns)
        ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if signum == signal.SIGINT else None
        proc = subprocess.Popen(command("preview", folder / "shot.usda", "--port", _free_port(), "--duration", 300,
                                        "--no-open", "--record", "--play"), stderr=subprocess.PIPE,
                                stdout=subprocess.DEVNULL, text=True, preexec_fn=ignore)
        err = []
        for line in proc.stderr:
            err.append(line)
            if line.startswith("preview: http"):
                time.sleep(2)
                proc.send_signal(signum)
                break
        try:
            err.append(proc.communicate(timeout=120)[1])
        except subprocess.TimeoutExpired:
            proc.kill()
            err.append(proc.communicate()[1])
        saved = "take written" in "".join(err) and (take.stat().st_ino, take.stat().st_mtime_ns) != old_take
        trials.append((proc.returncode == 0 and saved,
                       f"--record, {how}: exit {proc.returncode}, take {'saved' if saved else 'NOT saved'}"))
    return trials


def case_studio_origin(base, work):
    """A page on another origin, a rebound DNS name or a broken client cannot make the studio build, render or
    hand out the photo, and loses none of the artist's files (studio.json, studio.sh, the shot)."""
    import http.client
    import json

    import cv2

    from ..studio import session

    folder = copy_shot(base, work / "studio")
    state = session.empty_state(base["photo"], folder)
    ys, xs = (cv2.imread(str(base["masks"][0].rsplit(":", 1)[0]), cv2.IMREAD_GRAYSCALE) > 0).nonzero()
    box = [int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1]
    state["objects"] = [{"label": base["labels"][0], "box": box, "clicks": []}]
    session.write_state(state)  # the artist's set-up, which a rebuild would overwrite
    before = snapshot(folder)
    port = _free_port()
    proc = subprocess.Popen(command("studio", base["photo"], "-o", folder, "--port", port, "--duration", 300,
                                    "--no-open"), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    own, body = f"127.0.0.1:{port}", json.dumps(dict(state, camera="orbit-left")).encode()

    def ask(method, path, data=None, **headers):
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
        try:
            conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
            for k, v in {"Host": own, **headers}.items():
                conn.putheader(k.replace("_", "-"), v)
            conn.endheaders(data)  # Content-Length only as given: the trials lie about it
            r = conn.getresponse()
            error = json.loads(r.read() or b"{}").get("error", "") if r.status >= 400 else ""
            return f"{r.status}" + (" one line" if error and "\n" not in error else "")
        except (OSError, http.client.HTTPException, ValueError) as exc:
            return f"no answer ({type(exc).__name__})"
        finally:
            conn.close()

    err = []
    try:
        for line in proc.stderr:
            err.append(line)
            if line.startswith("studio: http"):
                break
        n, js = str(len(body)), "application/json"
        evil, rebound = "http://evil.example", f"evil.example:{port}"
        tried = [("403 one line", "text/plain POST /api/build from evil.example",
                  ask("POST", "/api/build", body, Content_Type="text/plain", Content_Length=n, Origin=evil)),
                 ("403 one line", "form POST /api/render from another local port",
                  ask("POST", "/api/render", body, Content_Type="application/x-www-form-urlencoded",
                      Content_Length=n, Origin=f"http://127.0.0.1:{port + 7}")),
                 ("403 one line", "GET /api/info by a rebound DNS name", ask("GET", "/api/info", Host=rebound)),
                 ("403 one line", "GET /photo.png by a rebound DNS name", ask("GET", "/photo.png", Host=rebound)),
                 ("400 one line", "POST with Content-Length -1",
                  ask("POST", "/api/build", body, Content_Type=js, Content_Length="-1")),
                 ("400 one line", "POST with Content-Length abc",
                  ask("POST", "/api/build", body, Content_Type=js, Content_Length="abc")),
                 ("400 one line", 'POST {"force": 123}',
                  ask("POST", "/api/build", b'{"force": 123}', Content_Type=js, Content_Length="14")),
                 ("200", "its own page's GET /api/info", ask("GET", "/api/info"))]
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            err.append(proc.communicate(timeout=120)[1])
        except subprocess.TimeoutExpired:
            proc.kill()
            err.append(proc.communicate()[1])
    trials = [(got == want, f"{what}: {got}") for want, what, got in tried]
    same, said = snapshot(folder) == before, "".join(err)
    trials.append((same and proc.returncode == 0 and "Traceback" not in said,
                   f"studio files {'unchanged' if same else 'CHANGED'}, exit {proc.returncode}"
                   + (", a traceback on stderr" if "Traceback" in said else "")))
    return trials


def case_secrets(base, work):
    """The API key is not sent after a redirect to another host; user:secret@ is never printed."""
    seen = []

    class Record(http.server.BaseHTTPRequestHandler):
        def do_POST(self):
            seen.append(self.headers.get("Authorization"))
            self.send_response(500)
            self.end_headers()

        do_GET = do_POST

        def log_message(self, *a):
            pass

    class Redirect(Record):
        def do_POST(self):
            self.send_response(302)
            self.send_header("Location", f"http://localhost:{other.server_port}/v1/chat/completions")
            self.end_headers()

    other = http.server.HTTPServer(("127.0.0.1", 0), Record)
    named = http.server.HTTPServer(("127.0.0.1", 0), Redirect)
    for s in (other, named):
        threading.Thread(target=s.serve_forever, daemon=True).start()
    folder = copy_shot(base, work / "secrets")
    try:
        proc = cli("estimate", folder, "--estimator", "vlm", "--vlm-url", f"http://127.0.0.1:{named.server_port}/v1",
                   "--vlm-model", "m", "--vlm-api-key", "sk-very-secret", "--vlm-timeout", 5)
    finally:
        for s in (other, named):
            s.shutdown()
    trials = [(not any(seen) and proc.returncode != 0 and "sk-very-secret" not in proc.stderr
               and one_error_line(proc.stderr, "another host"),
               f"redirect to another host: key sent there {sum(1 for s in seen if s)} time(s), exit {proc.returncode}")]
    proc = cli("estimate", folder, "--estimator", "vlm", "--vlm-url", "http://user:s3cr3t@127.0.0.1:9/v1",
               "--vlm-model", "m", "--vlm-timeout", 1)
    env = dict(os.environ, PHYSOMNI_VLM_URL="http://user:s3cr3t@127.0.0.1:9/v1")
    plugins = subprocess.run(command("plugins"), capture_output=True, text=True, env=env)
    trials.append(("s3cr3t" not in proc.stderr + plugins.stdout + plugins.stderr and one_error_line(proc.stderr),
                   f"user:secret@ in the URL: printed {'yes' if 's3cr3t' in proc.stderr + plugins.stdout else 'no'}"))
    return trials


def case_full_disk(base, work, commands=("estimate", "simulate")):
    """On a full disk `estimate --set` and `simulate` end in one line naming the file, exit 1, nothing
    replaced. Needs a small tmpfs (root); skipped (not counted) elsewhere."""
    mount = work / "full"
    mount.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)],
                                           capture_output=True).returncode:
        return []
    try:
        folder = mount / "shot"
        shutil.copytree(base["dir"], folder, ignore=shutil.ignore_patterns("video.mp4"))
        free = shutil.disk_usage(mount).free
        (mount / "filler").write_bytes(b"\0" * max(0, free - 12 * 1024))
        before = snapshot(folder)
        trials = []
        runs = {"estimate": ("estimate", folder / "shot.usda", "--set", f"{base['labels'][0]}.density=300"),
                "simulate": ("simulate", folder / "shot.usda", "--seconds", "0.2"),
                "render": ("render", folder / "shot.usda")}
        for args in (runs[c] for c in commands):
            proc = cli(*args, "-q")
            ok = (proc.returncode == 1 and one_error_line(proc.stderr, "no space left") and snapshot(folder) == before
                  and len(proc.stderr.strip().splitlines()) == 1)  # -q: nothing but that line, no library noise
            trials.append((ok, f"{args[0]}: exit {proc.returncode}, {proc.stderr.strip().splitlines()[-1:]}"))
        return trials
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def case_immutable_file(base, work):
    """An immutable sim.usdc is refused before a frame is simulated, naming sim.usdc (root with chattr only)."""
    folder = copy_shot(base, work / "immutable")
    target = folder / "sim.usdc"
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(target)],
                                                         capture_output=True).returncode:
        return []
    try:
        before = snapshot(folder)
        t0 = time.perf_counter()
        proc = cli("simulate", folder / "shot.usda")
        seconds = time.perf_counter() - t0
        frames = sum(ln.startswith("simulate: frame") for ln in proc.stderr.splitlines())
        ok = (proc.returncode == 2 and one_error_line(proc.stderr, str(target), "immutable")
              and snapshot(folder) == before and frames == 0)
        return [(ok, f"exit {proc.returncode} after {seconds:.1f} s and {frames} simulated frames: "
                     f"{proc.stderr.strip().splitlines()[-1:]}")]
    finally:
        subprocess.run(["chattr", "-i", str(target)], check=False)


def case_full_disk_render(base, work):
    """`render` on a full disk: as :func:`case_full_disk`; ffmpeg's own error lines still reach stderr."""
    return case_full_disk(base, work, ("render",))


CASES = {"terminated re-run": case_terminated_rerun, "terminated new folder": case_terminated_new_folder,
         "killed leftovers": case_killed_leftovers, "photo bomb": case_photo_bomb,
         "concurrent --set": case_concurrent_set, "non-finite values": case_non_finite,
         "preview origin": case_preview_origin, "secrets": case_secrets, "full disk": case_full_disk,
         "studio origin": case_studio_origin,
         "full disk render": case_full_disk_render,
         "immutable file": case_immutable_file, "planted journal": case_planted_journal,
         "symlinked lock": case_symlinked_lock, "symlinked layer": case_symlinked_layer,
         "uncomposable layers": case_uncomposable, "huge label": case_huge_label,
         "preview keep": case_preview_keep}


def base_shot(work: pathlib.Path, example: pathlib.Path | None = None, echo=print) -> dict:
    """A tiny finished shot to break: the motorcycle example at 240 px, 0.5 s at 20 fps."""
    from .pipeline import _resized_example

    example = example or pathlib.Path(__file__).resolve().parents[2] / "examples" / "motorcycle"
    ex = _resized_example(example, 240, work)
    base = {"photo": ex["photo"], "masks": ex["masks"], "dir": work / "base", "labels": ("motorcycle", "bench"),
            "run": ["--seconds", "0.5", "--fps", "20"]}
    echo(f"bench faults: building the shot to break ({example.name}, 240 px)")
    proc = cli(*run_args(base, base["dir"]))
    if proc.returncode:
        from ..errors import PhysOmniError

        raise PhysOmniError(f"bench faults: the base shot did not build: {proc.stderr.strip().splitlines()[-1:]}")
    return base


def bench_faults(only=(), echo=print) -> dict:
    """Run every case (or those named in ``only``) and print the matrix: case, tried, clean. An unknown case
    is refused (InputError) before any work."""
    import tempfile

    from ..errors import InputError

    unknown = [c for c in only if c not in CASES]
    if unknown:
        raise InputError(f"--only {unknown[0]!r}: not a case; one of {', '.join(CASES)}")

    rows = {}
    with tempfile.TemporaryDirectory(prefix="physomni-faults-") as tmp:
        work = pathlib.Path(tmp)
        base = base_shot(work, echo=echo)
        for name, case in CASES.items():
            if only and name not in only:
                continue
            scratch = work / name.replace(" ", "_")
            scratch.mkdir()
            t0 = time.perf_counter()
            trials = case(base, scratch)
            rows[name] = {"tried": len(trials), "clean": sum(ok for ok, _ in trials),
                          "seconds": round(time.perf_counter() - t0, 1), "trials": [d for _, d in trials]}
            echo(f"{name:<24} tried {len(trials):>2}  clean {rows[name]['clean']:>2}  ({rows[name]['seconds']} s)")
            for ok, detail in trials:
                echo(f"    {'ok ' if ok else 'NOT'} {detail}")
    return rows
