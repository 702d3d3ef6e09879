"""The set-up page's web server: Python's own ``http.server`` serving one page (``page.html``) and a small
JSON API over :mod:`physomni_usd.studio.session`; after "Build" the live preview (``physomni_usd.preview``)
runs on the next port, shown inside the page.

Threads: the HTTP server answers each request on a thread of its own; a lock makes the page's work
(masks, build, render) one thing at a time. The preview runs its loop on a thread the studio starts and
stops (a rebuild or "Render" ends it; its take is written first).
"""

from __future__ import annotations

import base64
import contextlib
import http.server
import json
import pathlib
import sys
import threading
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..errors import InputError, PhysOmniError
from . import session

PAGE = pathlib.Path(__file__).with_name("page.html")
#: Largest request body the page sends (a state with its objects and clicks), bytes.
MAX_BODY = 1 << 20


@dataclass
class Options:
    host: str = "127.0.0.1"
    port: int = 8070
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

        self.options = options
        self.echo = options.echo
        out = pathlib.Path(output)
        if out.exists() and not out.is_dir():
            raise InputError(f"-o {out}: exists and is not a folder")
        self.photo = read_photo(photo)
        self.segmenter = registry.load("segmenter", segmenter)
        self.preview_port = options.preview_port or options.port + 1
        check_port(options.host, options.port)
        check_port(options.host, self.preview_port)
        saved = out / session.STATE_FILE
        self.state = session.empty_state(photo, out, segmenter)
        if saved.is_file():  # the page opens where the artist left it
            with contextlib.suppress(ValueError, KeyError, OSError):
                old = session.read_state(saved)
                self.state.update({k: old[k] for k in ("objects", "pushes", "force", "camera") if k in old})
        self.lock = threading.Lock()
        self.preview = None
        self.preview_thread = None
        self.preview_result: dict = {}
        self.httpd = None

    # --- the page's work --------------------------------------------------------------------------
    def info(self) -> dict:
        from ..rendering.moves import MOVES

        h, w = self.photo.shape[:2]
        return {"state": self.state, "width": w, "height": h, "moves": list(MOVES),
                "forces": session.FORCE_PRESETS, "segmenter": type(self.segmenter).name,
                "preview": self._preview_url() if self.preview is not None else None}

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
        for key in ("objects", "pushes", "force", "camera"):
            if key in body:
                state[key] = body[key]
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
            result = session.build(state, echo=self.echo)
            self.state = state
            self._start_preview(result.shot)
        return {"preview": self._preview_url(), "objects": result.objects,
                "command": session.command_text(state)}

    def render(self, body: dict) -> dict:
        with self.lock:
            state = self._take_state(body)
            take = self._stop_preview(record=True)
            simulated = bool(take) and take.get("frames", 0) >= 2
            self.echo("studio: rendering " + ("the preview's take" if simulated else
                                             f"{session.RENDER_SECONDS:g} simulated seconds"))
            section = session.render(state, simulated, self.options.render_size, echo=self.echo)
            self.state = state
        return {"video": f"/video.mp4?t={time.time():.0f}", "frames": section["frames"],
                "command": session.command_text(state)}

    # --- the preview ------------------------------------------------------------------------------
    def _preview_url(self) -> str:
        return f"http://{self.options.host}:{self.preview_port}"

    def _start_preview(self, shot) -> None:
        from ..preview.app import Options as PreviewOptions, Preview

        self.preview = Preview(shot, PreviewOptions(host=self.options.host, port=self.preview_port,
                                                    open_browser=False, echo=self.echo))
        self.preview.start()
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
        self.preview = self.preview_thread = None
        return self.preview_result.get("take")

    # --- serving ----------------------------------------------------------------------------------
    def start(self) -> str:
        studio = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):  # the page's requests are not news
                pass

            def _send(self, code: int, body: bytes, kind: str) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def _json(self, code: int, data) -> None:
                self._send(code, json.dumps(data, default=float).encode(), "application/json")

            def do_GET(self):
                path = self.path.split("?", 1)[0]
                if path == "/":
                    self._send(200, PAGE.read_bytes(), "text/html; charset=utf-8")
                elif path == "/photo.png":
                    ok, png = cv2.imencode(".png", cv2.cvtColor(studio.photo, cv2.COLOR_RGB2BGR))
                    self._send(200, png.tobytes(), "image/png")
                elif path == "/api/info":
                    self._json(200, studio.info())
                elif path == "/video.mp4":
                    video = pathlib.Path(studio.state["output"]) / "video.mp4"
                    if video.is_file():
                        self._send(200, video.read_bytes(), "video/mp4")
                    else:
                        self._json(404, {"error": "no video yet: press Render"})
                else:
                    self._json(404, {"error": f"no page {path}"})

            def do_POST(self):
                size = int(self.headers.get("Content-Length") or 0)
                if size > MAX_BODY:
                    self._json(413, {"error": "request too large"})
                    return
                try:
                    body = json.loads(self.rfile.read(size) or b"{}")
                except ValueError:
                    self._json(400, {"error": "the request is not JSON"})
                    return
                work = {"/api/mask": studio.mask, "/api/build": studio.build, "/api/render": studio.render}
                action = work.get(self.path)
                if action is None:
                    self._json(404, {"error": f"no action {self.path}"})
                    return
                try:
                    self._json(200, action(body))
                except PhysOmniError as exc:  # bad input from the page: its message, as the CLI says it
                    self._json(400, {"error": str(exc)})
                except (KeyError, TypeError, ValueError) as exc:
                    self._json(400, {"error": f"malformed request: {type(exc).__name__}: {exc}"})
                except Exception as exc:  # a bug: the page says so, the server stays up
                    studio.echo(f"studio: internal error: {type(exc).__name__}: {exc}")
                    self._json(500, {"error": f"internal error: {type(exc).__name__}: {exc}"})

        o = self.options
        self.httpd = http.server.ThreadingHTTPServer((o.host, o.port), Handler)
        self.httpd.daemon_threads = True
        threading.Thread(target=self.httpd.serve_forever, name="studio", daemon=True).start()
        url = f"http://{o.host}:{o.port}"
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
