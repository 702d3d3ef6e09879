"""The set-up page's web server: Python's own ``http.server`` serving one page (``page.html``) and a small
JSON API over :mod:`physomni_usd.studio.session`; after "Build" the live preview (``physomni_usd.preview``)
runs on the next port, shown inside the page.

Threads: the HTTP server answers each request on a thread of its own; a lock makes the page's work
(masks, build, render) one thing at a time. The preview runs its loop on a thread the studio starts and
stops (a rebuild or "Render" ends it). A take the artist saves there ("Save take", written to ``sim.usdc``)
is what Render then renders, unsimulated, until a Build or a change of the pushes drops it.

Who may ask: any web page the artist has open can send requests to 127.0.0.1, so every request passes the
preview's :class:`~physomni_usd.preview.security.Guard` before anything reads its body or answers it (its
Origin the studio's own, its Host a loopback name, or the per-run token where the studio listens beyond
loopback), and a page of another site is refused by the browser's own ``Sec-Fetch-Site``. What changes the
shot is a POST of JSON only (a form or a ``text/plain`` fetch, the requests a page may send anywhere without
asking, never is), with a body read only as far as its Content-Length and never past ``MAX_BODY``. Every
refusal and every bad request is one line of JSON, and happens before the preview is stopped or a file is
touched.
"""

from __future__ import annotations

import base64
import contextlib
import http.server
import json
import math
import pathlib
import re
import sys
import threading
import time
import urllib.parse
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..errors import InputError, PhysOmniError
from ..preview import security
from ..preview.limits import STUDIO
from . import session

PAGE = pathlib.Path(__file__).with_name("page.html")
#: Largest request body the page sends (a state with its objects and clicks), bytes.
MAX_BODY = 1 << 20
#: Frames per second of what the page builds (build's --fps default), until a shot says its own.
BUILD_FPS = 30.0
#: Seconds a connection may stay silent mid-request (a body shorter than its Content-Length, a client that
#: stalls) before its thread gives up on it, so that idle sockets cannot hold threads for ever.
READ_TIMEOUT = 30
#: What a page of another site may still do: open the studio itself (a link, a typed address).
NAVIGATION = ("GET", "navigate")


@dataclass
class Options:
    host: str = "127.0.0.1"
    port: int = STUDIO["port"].default
    preview_port: int | None = None  # None: the port after ``port``
    open_browser: bool | None = None  # None: where one is available
    duration: float | None = None  # wall seconds, then quit (scripts, tests)
    render_size: int = 960  # longest side of the page's video, pixels
    echo: object = field(default=lambda m: print(m, file=sys.stderr, flush=True))


class Studio:
    """One photo, one shot folder, one page."""

    def __init__(self, photo, output, options: Options = Options(), segmenter: str = "grabcut"):
        from ..swappable import registry
        from ..perceive.masks import read_photo
        from ..preview.app import check_port

        STUDIO.check(port=options.port, duration=options.duration)
        self.options = options
        #: what the page's long work said, line by line, for the page to show while it runs (/api/progress)
        self.progress_lines: list[str] = []
        self.current = ""  # the frame being simulated or rendered now, every frame (the log gets each tenth)
        self.echo = self._echo
        out = pathlib.Path(output)
        if out.exists() and not out.is_dir():
            raise InputError(f"-o {out}: exists and is not a folder")
        self.photo = read_photo(photo)
        self.segmenter = registry.load("segmenter", segmenter)
        self.preview_port = options.preview_port or options.port + 1
        check_port(options.host, options.port, f"--port {options.port}")
        # the live preview serves on the next port: a busy one is named as such, the fix still --port
        check_port(options.host, self.preview_port,
                   f"--port {options.port} (its live preview's port, {self.preview_port})")
        saved = out / session.STATE_FILE
        self.state = session.empty_state(photo, out, segmenter)
        if saved.is_file():  # the page opens where the artist left it
            with contextlib.suppress(ValueError, KeyError, OSError):
                old = session.read_state(saved)
                self.state.update({k: old[k] for k in ("objects", "pushes", "force", "camera", "seconds")
                                   if k in old})
        self.lock = threading.Lock()
        self.guard = security.Guard(options.host, "studio")
        self.refusals_said: set[str] = set()
        self.preview_query = ""  # the running preview's ?token=… (empty on loopback)
        self.preview = None
        self.preview_thread = None
        self.preview_result: dict = {}
        #: the take the artist saved in the preview, which Render renders instead of simulating:
        #: {"frames", "seconds", "pushes": push_key of the shot it was kept on}; a Build drops it
        self.take: dict | None = None
        self._kept_from = None  # the preview's summary self.take was made from
        self.httpd = None

    # --- the page's work --------------------------------------------------------------------------
    def _echo(self, message: str) -> None:
        self.progress_lines.append(message)
        self.options.echo(message)

    def progress(self, since: int) -> dict:
        """The lines said from the ``since``-th on (the page asks again with ``next``)."""
        return {"lines": self.progress_lines[since:], "next": len(self.progress_lines), "current": self.current}

    def _length(self, state: dict) -> dict:
        """The video's length as the page shows it and Render makes it: seconds, frame rate and frames."""
        from pxr import Sdf

        shot = pathlib.Path(state["output"]) / "shot.usda"
        root = Sdf.Layer.FindOrOpen(str(shot)) if shot.is_file() else None
        if root is not None:
            root.Reload()  # a render or a rebuild changed it on disk
        fps = root.timeCodesPerSecond if root is not None and root.HasTimeCodesPerSecond() else BUILD_FPS
        take = self._kept()
        if take is not None and take["pushes"] == session.push_key(state.get("pushes")):
            return {"seconds": take["seconds"], "fps": fps, "frames": take["frames"]}
        seconds = session.render_seconds(state)
        return {"seconds": seconds, "fps": fps, "frames": int(round(seconds * fps)) + 1}

    def _kept(self) -> dict | None:
        """The kept take, a take saved in the running preview since the last look included."""
        preview = self.preview
        kept = getattr(preview, "kept", None)
        if kept is not None and kept is not self._kept_from:
            self._kept_from = kept
            # the preview runs the shot built from self.state: its pushes are the take's
            self.take = {"frames": kept["frames"], "seconds": kept["seconds"],
                         "pushes": session.push_key(self.state.get("pushes"))}
        return self.take

    def take_info(self) -> dict:
        """For the page (/api/take): the kept take, or null."""
        return {"take": self._kept()}

    def info(self) -> dict:
        from ..rendering.moves import MOVES

        h, w = self.photo.shape[:2]
        return {"state": self.state, "width": w, "height": h, "moves": list(MOVES),
                "forces": session.FORCE_PRESETS, "segmenter": type(self.segmenter).name,
                "preview": self._preview_url() if self.preview is not None else None,
                "length": self._length(self.state), "progress": len(self.progress_lines), "take": self._kept()}

    def mask(self, body: dict) -> dict:
        obj, index = body["object"], int(body.get("index", 0))
        with self.lock:
            found = session.object_mask(self.photo, obj, index, self.segmenter)
        rgba = np.zeros((*found["mask"].shape, 4), np.uint8)
        rgba[found["mask"]] = (255, 90, 20, 150)
        ok, png = cv2.imencode(".png", cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGRA))
        return {"png": "data:image/png;base64," + base64.b64encode(png.tobytes()).decode(),
                "pixels": found["pixels"], "warning": found["warning"], "spec": found["spec"]}

    def _take_state(self, body: dict) -> dict:
        state = dict(self.state)
        for key in ("objects", "pushes", "force", "camera", "seconds"):
            if key in body:
                state[key] = body[key]
        state["seconds"] = session.check_seconds(state.get("seconds"))
        if state.get("force"):
            from ..fields import parse_force_options

            parse_force_options([state["force"]])
        from ..rendering.moves import MOVES

        if state.get("camera") and state["camera"] not in MOVES:
            raise InputError(f"camera move {state['camera']!r}: one of {', '.join(MOVES)}")
        return state

    def build(self, body: dict) -> dict:
        with self.lock:
            state = self._take_state(body)
            self._stop_preview(record=False)
            dropped = None
            if self._kept() is not None:  # build writes an empty sim.usdc: the take is gone with it
                dropped = f"the kept take ({self.take['frames']} frames) was dropped: a Build makes a new shot"
                self.echo(f"studio: {dropped}")
                self.take = None
            # the build's settle steps the scene: on a first use it is the build that compiles the kernels
            from .._warp import compiled_seconds

            first_use = self._say_compiling()
            before = compiled_seconds()
            result = session.build(state, echo=self.echo)
            self.state = state
            self._start_preview(result.shot, first_use, before)
        return {"preview": self._preview_url(), "objects": result.objects, "dropped": dropped, "take": None,
                "command": session.command_text(state), "length": self._length(state)}

    def render(self, body: dict) -> dict:
        with self.lock:
            state = self._take_state(body)
            # what the preview stepped is not the video (studio.sh could not make it), unless the artist kept it
            self._stop_preview(record=False)
            take, dropped = self._kept(), None
            if take is not None and take["pushes"] != session.push_key(state.get("pushes")):
                dropped = "the pushes changed since it was kept"
            elif take is not None:
                dropped = session.take_on_disk(state, take)
            if dropped is not None:
                dropped = f"the kept take ({take['frames']} frames) was dropped: {dropped}"
                self.echo(f"studio: {dropped}")
                self.take = take = None
            length = self._length(state)
            if take is not None:
                self.echo(f"studio: rendering the take kept in the preview ({length['frames']} frames, "
                          f"{length['seconds']:.2f} s), not simulating")
            else:
                self.echo(f"studio: rendering {length['seconds']:g} s ({length['frames']} frames at "
                          f"{length['fps']:g} fps)")
            logged = {}

            def progress(stage, done, total):  # a line a frame would flood the page's log: each tenth
                self.current = f"{stage}: frame {done}/{total}"
                if done == total or done - logged.get(stage, 0) >= max(1, total // 10):
                    logged[stage] = done
                    self.echo(f"{stage}: frame {done}/{total}")

            try:
                section = session.render(state, self.options.render_size, echo=self.echo, progress=progress,
                                         take=take)
            finally:
                self.current = ""
            self.state = state
        return {"video": f"/video.mp4?t={time.time():.0f}", "frames": section["frames"], "take": take,
                "dropped": dropped, "command": session.command_text(state, take), "length": self._length(state)}

    # --- the preview ------------------------------------------------------------------------------
    def _preview_url(self, host: str | None = None) -> str:
        """The preview's address for a page that reached the studio at ``host`` (its Host header, which the
        guard has passed): the same name on the preview's port, with the preview's own token where it has one
        (beyond loopback, the address the studio was bound to, such as 0.0.0.0, is not one a browser elsewhere
        can use)."""
        try:
            name = urllib.parse.urlsplit(f"//{host}").hostname if host else None
        except ValueError:
            name = None
        name = name or self.options.host
        shown = f"[{name}]" if ":" in name else name
        return f"http://{shown}:{self.preview_port}/" + (f"?{self.preview_query}" if self.preview_query else "")

    def _say_compiling(self):
        """The kernels' first-use marker (``physics.prepare.kernels_first_use``), said on the page when the
        kernels are about to compile; None when they are compiled already."""
        from ..physics.prepare import kernels_first_use

        first_use = kernels_first_use()
        if first_use is not None:
            self.echo("studio: compiling physics kernels, once per machine (a minute or two) ...")
        return first_use

    def _start_preview(self, shot, first_use, before) -> None:
        """The preview of ``shot``; ``first_use`` and ``before`` as :meth:`_say_compiling` and
        ``compiled_seconds`` gave them before the build, which may have compiled the kernels itself."""
        from .._warp import compiled_seconds
        from ..preview.app import Options as PreviewOptions, Preview

        # paused on frame 0, the photo, as `physomni-usd preview` opens: Play (or a drag) starts it
        self.preview = Preview(shot, PreviewOptions(host=self.options.host, port=self.preview_port,
                                                    open_browser=False, play=False,
                                                    # its rate every few seconds is for the terminal, not
                                                    # the page's log of the Build and Render it runs between
                                                    echo=self.options.echo))
        if first_use is not None:
            # one frame stepped and undone: the kernels compile now, while the page says so, and Play
            # later starts at once
            engine = self.preview.engine
            engine.step()
            engine.reset()
            engine.sync()  # the loop has not started: the reset is applied here
            first_use.touch()
            after = compiled_seconds()
            self.echo("studio: physics kernels compiled" + (f" in {after - before:.0f} s" if None not in
                                                            (before, after) else "") + "; later builds start at once")
        self.preview_query = urllib.parse.urlsplit(self.preview.start()).query
        self.preview_result = {}

        def loop():
            self.preview_result = self.preview.run()

        self.preview_thread = threading.Thread(target=loop, name="preview", daemon=True)
        self.preview_thread.start()

    def _stop_preview(self, record: bool) -> dict | None:
        """End the preview's loop (its take written to sim.usdc first when ``record``); the take's summary."""
        if self.preview is None:
            return None
        self.preview.options.record = record
        self.preview.options.duration = 0.0  # the loop checks it every frame
        self.preview_thread.join(120)
        self._kept()  # a take saved in its last moments is kept too
        self.preview = self.preview_thread = None
        return self.preview_result.get("take")

    # --- serving ----------------------------------------------------------------------------------
    def _say_refusal(self, why: str) -> None:
        """One line on stderr the first time a reason is seen (a page that keeps trying does not flood it)."""
        if why not in self.refusals_said and len(self.refusals_said) < 20:
            self.refusals_said.add(why)
            self.echo(f"studio: refused a request: {why}")

    def start(self) -> str:
        studio = self

        class Handler(http.server.BaseHTTPRequestHandler):
            timeout = READ_TIMEOUT  # the socket's: a stalled client frees its thread

            def log_message(self, *args):  # the page's requests are not news
                pass

            def _send(self, code: int, body: bytes, kind: str, *headers: tuple[str, str]) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                # no other page may frame the studio and steer a click onto Build or Render
                self.send_header("X-Frame-Options", "DENY")
                self.send_header("Content-Security-Policy", "frame-ancestors 'none'")
                self.send_header("X-Content-Type-Options", "nosniff")
                # the page load that brought the token: its later requests send it as a cookie (no path
                # yet where http.server answers a request line it could not read)
                cookie = studio.guard.set_cookie(getattr(self, "path", "")) if code < 400 else None
                if cookie is not None:
                    self.send_header("Set-Cookie", cookie)
                for name, value in headers:
                    self.send_header(name, value)
                self.end_headers()
                if self.command != "HEAD":
                    self.wfile.write(body)

            def _json(self, code: int, data, *headers) -> None:
                self._send(code, json.dumps(data, default=float).encode(), "application/json", *headers)

            def _fail(self, code: int, message: str, *headers) -> None:
                """A refusal or a bad request: one line, and the connection closed, since a body it did not
                read must not be taken for the next request."""
                self.close_connection = True
                self._json(code, {"error": message}, *headers)

            def send_error(self, code, message=None, explain=None):
                # http.server's own answers (a garbled request line, too many headers) as one line too
                self._fail(code, message or http.HTTPStatus(code).phrase)

            def parse_request(self):
                """Every request, whatever its method, passes the guard before its body is read or anything
                is answered."""
                if not super().parse_request():
                    return False
                why = studio.guard.refusal(self.headers, self.path)
                site, mode = self.headers.get("Sec-Fetch-Site"), self.headers.get("Sec-Fetch-Mode")
                if why is None and site in ("cross-site", "same-site") and (self.command, mode) != NAVIGATION:
                    # the browser's word for a page of another site (another port of this machine included)
                    why = f"a request from another site's page (Sec-Fetch-Site: {site})"
                if why is not None:
                    studio._say_refusal(why)
                    self._fail(403, f"refused: {why}")
                    return False
                if self.command not in ("GET", "POST"):
                    self._fail(405, f"{self.command} is not served here: the studio answers GET and POST",
                               ("Allow", "GET, POST"))
                    return False
                return True

            def do_GET(self):
                path = self.path.split("?", 1)[0]
                if path == "/":
                    self._send(200, PAGE.read_bytes(), "text/html; charset=utf-8")
                elif path == "/photo.png":
                    ok, png = cv2.imencode(".png", cv2.cvtColor(studio.photo, cv2.COLOR_RGB2BGR))
                    self._send(200, png.tobytes(), "image/png")
                elif path == "/api/info":
                    self._json(200, self._for_page(studio.info()))
                elif path == "/api/take":
                    self._json(200, studio.take_info())
                elif path == "/api/progress":
                    query = self.path.split("?", 1)[1] if "?" in self.path else ""
                    since = next((v for k, _, v in (q.partition("=") for q in query.split("&")) if k == "since"), "0")
                    self._json(200, studio.progress(int(since) if since.isdigit() else 0))
                elif path == "/video.mp4":
                    video = pathlib.Path(studio.state["output"]) / "video.mp4"
                    if video.is_file():
                        self._send(200, video.read_bytes(), "video/mp4")
                    else:
                        self._json(404, {"error": "no video yet: press Render"})
                else:
                    self._json(404, {"error": f"no page {path}"})

            def _for_page(self, data: dict) -> dict:
                if data.get("preview"):  # the preview's address as this page can reach it
                    data["preview"] = studio._preview_url(self.headers.get("Host"))
                return data

            def _body(self) -> dict | None:
                """The request's JSON object, or None once a one-line refusal has been sent. Nothing is read
                before the headers say JSON of a length within ``MAX_BODY``, and never more than that."""
                kind = (self.headers.get("Content-Type") or "").split(";", 1)[0].strip().lower()
                if kind != "application/json":
                    self._fail(400, f"the request must be JSON (Content-Type: application/json), not "
                                    f"{kind or 'without a Content-Type'}")
                    return None
                if self.headers.get("Transfer-Encoding") is not None:
                    self._fail(400, "a body sent in chunks is not read: send it with its Content-Length")
                    return None
                lengths = self.headers.get_all("Content-Length") or []
                if len(lengths) != 1 or not re.fullmatch(r"[0-9]{1,18}", lengths[0].strip()):
                    self._fail(400, "the request needs one Content-Length in bytes, not "
                                    + (", ".join(map(repr, lengths)) or "none"))
                    return None
                size = int(lengths[0])
                if size > MAX_BODY:
                    self._fail(413, f"request too large: {size} bytes, at most {MAX_BODY}")
                    return None
                try:
                    data = self.rfile.read(size)
                except OSError:  # the client stalled past READ_TIMEOUT or went away
                    data = b""
                if len(data) < size:
                    self._fail(400, f"the request's body ended after {len(data)} of its {size} bytes")
                    return None
                try:
                    body = json.loads(data or b"{}", parse_constant=_not_a_number, parse_float=_finite)
                except (ValueError, RecursionError):  # RecursionError: arrays nested thousands deep
                    self._fail(400, "the request is not JSON")
                    return None
                if not isinstance(body, dict):
                    self._fail(400, f"the request is JSON but not an object (a {type(body).__name__})")
                    return None
                return body

            def do_POST(self):
                work = {"/api/mask": studio.mask, "/api/build": studio.build, "/api/render": studio.render}
                action = work.get(self.path)
                if action is None:
                    self._fail(404, f"no action {self.path}")
                    return
                body = self._body()
                if body is None:
                    return
                try:
                    _check_request(self.path, body)
                    self._json(200, self._for_page(action(body)))
                except PhysOmniError as exc:  # bad input from the page: its message, as the CLI says it
                    self._json(400, {"error": _one_line(str(exc))})
                except (KeyError, TypeError, ValueError) as exc:
                    self._json(400, {"error": _one_line(f"malformed request: {type(exc).__name__}: {exc}")})
                except Exception as exc:  # a bug: the page says so, the server stays up
                    studio.echo(f"studio: internal error: {type(exc).__name__}: {exc}")
                    self._json(500, {"error": _one_line(f"internal error: {type(exc).__name__}: {exc}")})

        class Server(http.server.ThreadingHTTPServer):
            daemon_threads = True

            def handle_error(self, request, client_address):
                exc = sys.exc_info()[1]
                if not isinstance(exc, OSError):  # a client that went away is not news; anything else, one line
                    studio.echo(f"studio: internal error answering a request: {type(exc).__name__}: {exc}")

        o = self.options
        self.httpd = Server((o.host, o.port), Handler)
        threading.Thread(target=self.httpd.serve_forever, name="studio", daemon=True).start()
        url = self.guard.url(o.port)
        self.echo(f"studio: {url}")
        from ..preview.app import browser_available

        if o.open_browser or (o.open_browser is None and browser_available()):
            import webbrowser

            webbrowser.open(url)
        return url

    def wait(self) -> None:
        """Serve until the duration ends or Ctrl-C; then stop the preview and the server."""
        start = time.monotonic()
        try:
            while self.options.duration is None or time.monotonic() - start < self.options.duration:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass
        finally:
            with self.lock:
                self._stop_preview(record=False)
            if self.httpd is not None:
                self.httpd.shutdown()
                self.httpd.server_close()


def _not_a_number(word: str):
    raise ValueError(f"{word} is not a number JSON has")


def _finite(text: str) -> float:
    v = float(text)
    if not math.isfinite(v):  # 1e999 reads as inf
        raise ValueError(f"{text} is beyond a float")
    return v


def _one_line(text: str) -> str:
    return re.sub(r"\s*\n\s*", " ", text).strip()


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)  # finite: _not_a_number, _finite


def _check_object(obj, where: str) -> None:
    if not isinstance(obj, dict):
        raise InputError(f"{where}: an object is {{\"label\": …, \"box\": [x0, y0, x1, y1], \"clicks\": […]}}, "
                         f"not {json.dumps(obj)[:60]}")
    box = obj.get("box")
    if not (isinstance(box, list) and len(box) == 4 and all(map(_number, box))):
        raise InputError(f"{where}.box: four numbers [x0, y0, x1, y1], not {json.dumps(box)[:60]}")
    if not isinstance(obj.get("label") or "", str):
        raise InputError(f"{where}.label: a text, not {json.dumps(obj['label'])[:60]}")
    clicks = obj.get("clicks", [])
    if not (isinstance(clicks, list) and all(isinstance(c, list) and len(c) == 3 and _number(c[0])
                                             and _number(c[1]) and isinstance(c[2], bool) for c in clicks)):
        raise InputError(f"{where}.clicks: a list of [x, y, true|false], not {json.dumps(clicks)[:60]}")


def _check_request(path: str, body: dict) -> None:
    """The kinds of the values a request brings, checked before anything runs, so that a number where a text
    belongs is a 400 naming the value rather than an error deep in a build (``{"force": 123}`` was a 500)."""
    if path == "/api/mask":
        _check_object(body.get("object"), "object")
        if not isinstance(body.get("index", 0), int) or isinstance(body.get("index"), bool):
            raise InputError(f"index: a whole number, not {json.dumps(body['index'])[:60]}")
        return
    objects = body.get("objects", [])
    if not isinstance(objects, list):
        raise InputError(f"objects: a list, not {json.dumps(objects)[:60]}")
    for i, obj in enumerate(objects):
        _check_object(obj, f"objects[{i}]")
    pushes = body.get("pushes", [])
    if not isinstance(pushes, list):
        raise InputError(f"pushes: a list, not {json.dumps(pushes)[:60]}")
    for i, push in enumerate(pushes):
        v = push.get("velocity") if isinstance(push, dict) else None
        if not (isinstance(push, dict) and isinstance(push.get("object"), int) and not isinstance(push["object"], bool)
                and isinstance(v, list) and len(v) == 3 and all(map(_number, v))):
            raise InputError(f"pushes[{i}]: {{\"object\": its number, \"velocity\": [vx, vy, vz]}}, "
                             f"not {json.dumps(push)[:60]}")
    for key, what in (("force", "a KIND:key=value,... text"), ("camera", "a camera move's name")):
        if body.get(key) is not None and not isinstance(body[key], str):
            raise InputError(f"{key}: {what} or null, not {json.dumps(body[key])[:60]}")


#: What ``preview`` takes for a photo (and sets up on this page first) rather than a shot.
PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")


def preview_or_set_up(path, options, out_dir=None) -> dict | None:
    """``preview``'s entry: the live preview of the shot at ``path`` (``options``: the preview's
    :class:`~physomni_usd.preview.app.Options`) until it stops, returning its result (``frames``: frames
    stepped); a photo (:data:`PHOTO_SUFFIXES`) is set up first on this page, built into ``out_dir``
    (InputError without one), and None is returned when the page stops."""
    path = pathlib.Path(path)
    if path.suffix.lower() in PHOTO_SUFFIXES:
        if out_dir is None:
            raise InputError(f"{path} is a photo, not a shot: name the folder to build it into with -o, e.g. "
                             f"physomni-usd preview {path} -o shot/ (the same as physomni-usd studio)")
        page = Studio(path, out_dir, Options(host=options.host, port=options.port, duration=options.duration,
                                             open_browser=options.open_browser))
        page.start()
        page.wait()
        return None
    from ..preview.app import Preview

    session = Preview(path, options)
    session.start()
    return session.run()
