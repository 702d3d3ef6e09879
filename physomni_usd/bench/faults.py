"""``bench faults``: the reliability matrix. Each case plays one hostile or unlucky thing a user or a farm
does to a finished shot (a signal mid-render, a kill, a photo bomb, two writers, a NaN, a page on another
origin, a redirect that would take the API key, a full disk) through the real CLI in a fresh interpreter,
and says per trial whether it ended clean: one line, the right exit code, nothing the user had changed.

The same case functions are the assertions of ``tests/test_faults.py``; a case takes a finished shot
(``base``: its folder and the photo and masks it was run from) and a scratch folder, and returns its
trials as ``(clean, what happened)``.
"""

from __future__ import annotations

import contextlib
import hashlib
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

CLI = "import sys\nfrom physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n"


def command(*args) -> list[str]:
    return [sys.executable, "-c", CLI, *map(str, args)]


def cli(*args, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(command(*args), capture_output=True, text=True, timeout=timeout)


def snapshot(folder: pathlib.Path) -> dict[str, str]:
    """Every file under ``folder`` (hidden ones too) → its content's SHA-256."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_error_line(stderr: str, *needles: str) -> bool:
    """Whether ``stderr`` ends in exactly one ``error:`` line holding every needle, and has no traceback."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("error:")]
    return (len(errors) == 1 and bool(lines) and lines[-1] == errors[0] and "Traceback" not in stderr
            and all(n in errors[0] for n in needles))


def copy_shot(base: dict, dest: pathlib.Path) -> pathlib.Path:
    shutil.copytree(base["dir"], dest)
    return dest


def run_args(base: dict, out: pathlib.Path) -> list:
    args = ["run", base["photo"], "-o", out]
    for m in base["masks"]:
        args += ["--mask", m]
    return args + list(base.get("run", ()))


def signal_when(args, marker: str, signum: int, timeout: float = 600) -> tuple[int, str]:
    """Start ``physomni-usd ARGS``, send ``signum`` once a stderr line starts with ``marker``; returns the
    exit code and stderr."""
    proc = subprocess.Popen(command(*args), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
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


# --- a shot folder from someone else: nothing outside it may change, edits.usda never -----------------

def decoy_beside(base, work) -> pathlib.Path:
    """Someone's files beside the shot (``work/decoy``), which no command on the shot may touch; one of them a
    valid layer, so that a link to it composes."""
    decoy = work / "decoy"
    (decoy / "sub").mkdir(parents=True)
    for name in ("victim.txt", "other.txt", "sub/deep.txt"):
        (decoy / name).write_text(f"{name}: someone else's\n")
    shutil.copy(base["dir"] / "sim.usdc", decoy / "layer.usdc")
    return decoy


def outside(work: pathlib.Path, folder: pathlib.Path) -> dict[str, str]:
    """Every entry under ``work`` except ``folder`` → its content's SHA-256 ("link → …" for a link, never
    followed; "folder" for one): what a command on the shot in ``folder`` must leave as it is."""
    out = {}
    for root, dirs, files in os.walk(work):
        root = pathlib.Path(root)
        dirs[:] = [d for d in dirs if root / d != folder]
        for name in dirs + files:
            p = root / name
            rel = str(p.relative_to(work))
            if p.is_symlink():
                out[rel] = f"link → {os.readlink(p)}"
            elif p.is_dir():
                out[rel] = "folder"
            else:
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def shot_commands(base, folder: pathlib.Path) -> dict[str, list]:
    """The commands that write into an existing shot, each as short as it can be."""
    masks = [a for m in base["masks"] for a in ("--mask", m)]
    return {"simulate": ["simulate", folder / "shot.usda", "--seconds", "0.3"],
            "render": ["render", folder / "shot.usda"],
            "estimate --set": ["estimate", folder / "shot.usda", "--set", f"{base['labels'][0]}.density=300"],
            "build -o": ["build", base["photo"], "-o", folder, *masks]}


def hostile_trials(base, work, name: str, plant, expect: dict[str, tuple[int, str]], commands=None):
    """For each command: a fresh copy of the shot beside :func:`decoy_beside`, ``plant(folder, decoy)`` done
    to it, the command run; clean when it exits as ``expect[command]`` says (code, and a needle its one
    ``error:`` line, or for exit 0 its warning, holds), nothing outside the folder changed and ``edits.usda``
    is byte for byte what it was (`estimate --set` adds its value to it when it succeeds)."""
    trials = []
    for cmd in commands or expect:
        # numbered, not named: a folder named after the trial ("sublayer_cycle") would put the very words that
        # the old code's message filter looked for into every path, and hide what the trial is to find
        where = work / f"trial{sum(1 for _ in work.iterdir()):02d}"
        where.mkdir()
        decoy = decoy_beside(base, where)
        folder = copy_shot(base, where / "shot")
        plant(folder, decoy)
        edits, before = (folder / "edits.usda").read_bytes(), outside(where, folder)
        proc = cli(*shot_commands(base, folder)[cmd])
        code, needle = expect[cmd]
        said = one_error_line(proc.stderr, needle) if code else needle in proc.stderr
        kept = outside(where, folder) == before
        now = (folder / "edits.usda").read_bytes() if (folder / "edits.usda").is_file() else None
        same_edits = now == edits or (cmd == "estimate --set" and proc.returncode == 0 and now is not None
                                      and b"300" in now)
        last = (proc.stderr.strip().splitlines() or [""])[-1][:160]
        trials.append((proc.returncode == code and said and kept and same_edits,
                       f"{name}, {cmd}: exit {proc.returncode}, outside {'unchanged' if kept else 'CHANGED'}, "
                       f"edits.usda {'as it was' if same_edits else 'CHANGED'}: {last}"))
    return trials


def _plant_journal(folder, decoy):
    (folder / "payload.txt").write_text("payload\n")
    (folder / ".physomni.lock").write_text(json.dumps(
        {"pid": 1, "saved": {str(decoy / "victim.txt"): None, "../decoy/other.txt": "payload.txt"},
         "temporary": ["../decoy/sub/deep.txt"]}))


def case_planted_journal(base, work):
    """A lock journal planted in the shot (a tarball's) naming an absolute path and a ../ path: it is set
    aside with one line, nothing is deleted or restored, the command runs."""
    said = (0, "is no journal of ours")
    trials = hostile_trials(base, work, "planted journal", _plant_journal,
                            dict.fromkeys(shot_commands(base, work), said))
    # an in-folder journal that would move one of the shot's files over another is no journal of ours either
    def swap(folder, decoy):
        (folder / ".physomni.lock").write_text(json.dumps({"pid": 1, "saved": {"shot.usda": "edits.usda"}}))

    return trials + hostile_trials(base, work, "journal moving edits.usda", swap, {"simulate": said})


def _link_lock(folder, decoy):
    (folder / ".physomni.lock").symlink_to(decoy / "victim.txt")


def case_symlinked_lock(base, work):
    """The lock file a link to a file outside: refused in one line naming it, exit 2; the target untouched."""
    return hostile_trials(base, work, "symlinked lock", _link_lock,
                          dict.fromkeys(shot_commands(base, work), (2, ".physomni.lock")))


def case_symlinked_layer(base, work):
    """sim.usdc a link to a valid layer outside: read through (render, estimate) but never written through
    (simulate, build: exit 2 naming it); textures/ a link to a folder outside: build refuses it."""
    def plant(folder, decoy):
        (folder / "sim.usdc").unlink()
        (folder / "sim.usdc").symlink_to(decoy / "layer.usdc")

    trials = hostile_trials(base, work, "symlinked sim.usdc", plant,
                            {"simulate": (2, "sim.usdc"), "render": (0, ""), "estimate --set": (0, ""),
                             "build -o": (2, "sim.usdc")})

    def textures(folder, decoy):
        shutil.copytree(folder / "textures", decoy / "textures")
        shutil.rmtree(folder / "textures")
        (folder / "textures").symlink_to(decoy / "textures")

    return trials + hostile_trials(base, work, "symlinked textures/", textures, {"build -o": (2, "textures")})


def _sublayer(folder, path: str) -> None:
    """Give the shot's edits.usda a sublayer (as a hand edit would)."""
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(str(folder / "edits.usda"))
    layer.subLayerPaths.append(path)
    layer.Save()


def case_uncomposable(base, work):
    """edits.usda sublayering itself (a cycle) or a missing file: exit 2 in every command, one line naming
    the layer; nothing replaced."""
    trials = hostile_trials(base, work, "sublayer cycle", lambda folder, decoy: _sublayer(folder, "./edits.usda"),
                            dict.fromkeys(shot_commands(base, work), (2, "edits.usda")))
    return trials + hostile_trials(base, work, "missing sublayer",
                                   lambda folder, decoy: _sublayer(folder, "./gone.usda"),
                                   dict.fromkeys(shot_commands(base, work), (2, "gone.usda")))


def _mask_box(base) -> str:
    """``X0,Y0,X1,Y1`` around the base shot's first mask: a box with an object in it, which GrabCut cuts."""
    import cv2
    import numpy as np

    mask = cv2.imread(base["masks"][0].rpartition(":")[0], cv2.IMREAD_GRAYSCALE)
    ys, xs = np.nonzero(mask)
    return f"{xs.min()},{ys.min()},{xs.max() + 1},{ys.max() + 1}"


def case_huge_label(base, work):
    """A 10,000-character label (build) or name (estimate --set): exit 2 naming the option, nothing written."""
    huge = "a" * 10000
    trials = []
    for option, args in (("--mask", lambda folder: ["build", base["photo"], "-o", folder, "--mask",
                                                    f"{base['masks'][0].rpartition(':')[0]}:{huge}"]),
                         ("--box", lambda folder: ["build", base["photo"], "-o", folder, "--box",
                                                   f"{_mask_box(base)}:{huge}"]),
                         ("--set", lambda folder: ["estimate", folder / "shot.usda", "--set", f"{huge}.density=300"])):
        where = work / f"label{option.strip('-')}"
        where.mkdir()
        decoy_beside(base, where)
        folder = copy_shot(base, where / "shot")
        before, everything = outside(where, folder), snapshot(folder)
        proc = cli(*args(folder))
        same = snapshot(folder) == everything and outside(where, folder) == before
        trials.append((proc.returncode == 2 and one_error_line(proc.stderr, option, "10,000") and same,
                       f"10,000-character {option}: exit {proc.returncode}, files {'unchanged' if same else 'CHANGED'}"))
    return trials


# --- the preview's Keep settings and Save take on such a folder, pressed in process -----------------------------

def _edits_link(folder, decoy):
    shutil.copy(folder / "edits.usda", decoy / "edits.usda")
    (folder / "edits.usda").unlink()
    (folder / "edits.usda").symlink_to(decoy / "edits.usda")


def _sim_link(folder, decoy):
    (folder / "sim.usdc").unlink()
    (folder / "sim.usdc").symlink_to(decoy / "layer.usdc")


def _cycle_on_disk(folder, decoy):
    """edits.usda sublayering itself, written by another program (an editor) while the preview runs."""
    text = (folder / "edits.usda").read_text()
    (folder / "edits.usda").write_text(text.replace("(", "(\n    subLayers = [@./edits.usda@]", 1))


def _noted(name: str):
    """An edit of the layer ``name`` by another program while the preview runs: a note in its metadata."""
    def edit(folder, decoy):
        text = (folder / name).read_text()
        note = '(\n    customLayerData = {\n        string handEdit = "kept"\n    }'
        (folder / name).write_text(text.replace("(", note, 1))

    return edit


def _damaged_edits(folder, decoy):
    with open(folder / "edits.usda", "a") as f:
        f.write("\nover this is no USD\n")


#: name → (what is done to the shot, whether while the preview runs rather than before it opens the shot, the
#: button: "keep" (Keep settings) or "save" (Save take), whether it writes, a needle of the line it says, and
#: what the written file must still hold: the edit made meanwhile).
KEEP_TRIALS = {
    "planted journal, Keep settings": (_plant_journal, False, "keep", True, "kept 1 setting", None),
    "planted journal, Save take": (_plant_journal, False, "save", True, "take 1 saved", None),
    "symlinked lock, Keep settings": (_link_lock, False, "keep", False, ".physomni.lock: it is a symbolic", None),
    "symlinked lock, Save take": (_link_lock, False, "save", False, ".physomni.lock: it is a symbolic", None),
    "symlinked edits.usda, Keep settings": (_edits_link, False, "keep", False, "edits.usda: it is a symbolic", None),
    "symlinked sim.usdc, Save take": (_sim_link, False, "save", False, "sim.usdc: it is a symbolic", None),
    "sublayer cycle written meanwhile, Keep settings": (_cycle_on_disk, True, "keep", False, "(a cycle)", None),
    "edits.usda damaged meanwhile, Keep settings": (_damaged_edits, True, "keep", False, "not a valid USD", None),
    "edits.usda edited meanwhile, Keep settings": (_noted("edits.usda"), True, "keep", True, "kept 1", "handEdit"),
    "shot.usda edited meanwhile, Save take": (_noted("shot.usda"), True, "save", True, "take 1 saved", "handEdit"),
}


@contextlib.contextmanager
def _stderr_lines(into: list):
    """What is written to file descriptor 2 inside the block (USD's own diagnostics included), as lines."""
    import tempfile

    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            into.extend(ln for ln in f.read().decode(errors="replace").splitlines() if ln.strip())


def keep_trial(base, work, name: str) -> tuple[bool, str]:
    """One of :data:`KEEP_TRIALS`: a fresh copy of the shot beside :func:`decoy_beside`, opened as the preview opens
    it, gravity changed and three frames stepped, the button's function called as the page's press runs it. Clean
    when it answers (never raises) with one line holding the needle, writes or not as the trial says, nothing
    outside the folder changed, and ``edits.usda`` is byte for byte what it was unless Keep settings wrote it
    (then it holds the kept value and whatever the trial put there meanwhile)."""
    from ..preview.app import keep_settings, save_take
    from ..preview.engine import Engine

    plant, meanwhile, button, writes, needle, still = KEEP_TRIALS[name]
    where = work / f"keep{sum(1 for _ in work.iterdir()):02d}"
    where.mkdir()
    decoy = decoy_beside(base, where)
    folder = copy_shot(base, where / "shot")
    if not meanwhile:
        plant(folder, decoy)
    engine = Engine(folder / "shot.usda", capture=False)
    engine.set_gravity(5.0)
    for _ in range(3):
        engine.step()
    if meanwhile:
        plant(folder, decoy)
    edits, before = (folder / "edits.usda").read_bytes(), outside(where, folder)
    written = folder / ("edits.usda" if button == "keep" else "sim.usdc")
    old = written.read_bytes()
    printed: list[str] = []
    try:
        with _stderr_lines(printed):
            if button == "keep":
                wrote, line = keep_settings(engine)
            else:
                summary, line = save_take(engine, 1)
                wrote = summary is not None
    except Exception as exc:  # the press ended the preview
        wrote, line = None, f"RAISED {type(exc).__name__}: {exc}"
    # besides the line on the page, at most the planted journal's one warning: none of USD's own diagnostics
    quiet = len(printed) <= 1 and all(ln.startswith("warning: ") for ln in printed)
    kept = outside(where, folder) == before
    now = written.read_bytes()
    if button == "keep" and wrote:  # refused where the trial says so: a write from the copy read before is wrong
        right = writes and b"gravityMagnitude = 5" in now and (still is None or still.encode() in now)
    else:
        right = (folder / "edits.usda").read_bytes() == edits and (wrote or now == old)
        if still is not None:
            right = right and still.encode() in (folder / "shot.usda").read_bytes()
    ok = wrote is writes and needle in line and "\n" not in line and quiet and kept and right
    return ok, (f"{name}: {'wrote' if wrote else 'refused' if wrote is False else 'ENDED THE PREVIEW'}, "
                f"{'' if quiet else f'{len(printed)} MORE LINES ON STDERR, '}outside "
                f"{'unchanged' if kept else 'CHANGED'}, {'shot.usda' if still and button == 'save' else 'edits.usda'} "
                f"{'as it should be' if right else 'WRONG'}: "
                f"{line[:160]}")


def case_preview_keep(base, work):
    """The preview's Keep settings and Save take on a shot folder from someone else, or one changed while the
    preview runs: refused in one line where they would write through a link, the session going on; nothing
    outside the folder changed; edits.usda as it was, or with the kept value added to what is on disk now."""
    return [keep_trial(base, work, name) for name in KEEP_TRIALS]


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
    """Run every case (or those named in ``only``) and print the matrix: case, tried, clean."""
    import tempfile

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
