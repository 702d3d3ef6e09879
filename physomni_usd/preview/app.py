"""The preview server: a viser page showing the shot from the photo's camera, a panel of controls,
mouse picking, and the loop that steps the simulation and publishes each frame's poses.

Threads: viser serves the page and runs the callbacks on its own threads; the loop (the caller's
thread) owns the simulation. Callbacks only queue what they want, the loop applies it between frames.
"""

from __future__ import annotations

import contextlib
import io
import os
import queue
import socket
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, PhysOmniError
from . import security
from .limits import PREVIEW
from .card import Mover, OpeningCard, moved_regions
from .engine import Engine, field_label
from .scene import (SHADOW_LIFT, GroundShadow, ShadowTrack, background_card, contact_decal, drawn_objects,
                    fitted_fov, mean_colour, opening_card, opening_frame, photo_view, shadow_blur_m, textured_glb)

#: Seconds between two ``preview: N fps`` lines on stderr (and updates of the page's rate).
REPORT_EVERY = 3.0
#: A pose change smaller than this (m, or quaternion component) is not sent again.
SEND_TOLERANCE = 1e-5
#: A page's camera within this distance (m) of the photo's, looking the same way, sees the opening view.
AT_PHOTO_M = 1e-3
#: The opening view's card stands this far (m) in front of the photo's camera, nearer than any object.
OPENING_DISTANCE = 0.05
#: Seconds between two changes of the card's holes sent to the pages (a page decodes each tile it is sent);
#: a hole opens at once, and leads a body by its motion over this time so that the body is never under the card.
CARD_EVERY = 0.2


@dataclass
class Options:
    host: str = "127.0.0.1"
    port: int = PREVIEW["port"].default
    duration: float | None = None  # wall seconds, then quit
    record: bool = False  # write the take on exit
    open_browser: bool | None = None  # None: where one is available
    paced: bool = True  # real time; False runs as fast as the CPU allows (bench)
    capture: bool = True  # replay each frame's launches as one graph where it can
    play: bool = True  # step from the start; the command opens paused on frame 0 unless --play
    report_every: float = REPORT_EVERY  # seconds between rate reports
    echo: object = field(default=lambda m: print(m, file=sys.stderr, flush=True))


def _set(apply, value, lo: float, hi: float) -> None:
    """Hand a control's value to ``apply`` clamped to the CLI's range; a non-number from a page is dropped."""
    v = security.clamp(value, lo, hi)
    if v is not None:
        apply(v)


def _within(value, lo: float, hi: float, old: float) -> float:
    v = security.clamp(value, lo, hi)
    return old if v is None else v


def check_port(host: str, port: int, option: str | None = None) -> None:
    """Refuse a port another program holds, before anything starts (viser would quietly take the next).
    ``option`` is what the user typed, or would type, to choose another (the studio's preview takes the
    port after its ``--port``). Who holds it is not known here: the line does not guess."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as s:
        if os.name == "posix":
            # connections a server closed itself linger in TIME_WAIT for a minute: without this a studio's
            # Build after a Render (which stopped its preview) was refused its own preview's port; a port
            # another program listens on is still refused (Windows' SO_REUSEADDR would take it over instead)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as exc:
            raise InputError(f"{option or f'--port {port}'}: cannot listen on {host}:{port} ({exc.strerror or exc}); another "
                             f"program holds it: choose another --port") from None


def browser_available() -> bool:
    """Whether a graphical web browser can be opened here (never on a machine without a display)."""
    import webbrowser

    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    try:
        webbrowser.get()
    except webbrowser.Error:
        return False
    return True


class Preview:
    """One shot on one page."""

    def __init__(self, shot, options: Options = Options()):
        PREVIEW.check(port=options.port, duration=options.duration)
        self.options = options
        self.echo = options.echo
        check_port(options.host, options.port)
        if options.open_browser and not browser_available():
            raise InputError("--open: no web browser is available here; leave out --open and open the "
                             "page's address in a browser yourself")
        self.engine = Engine(shot, capture=options.capture)
        if options.record:
            self.engine.check_writable()
        stage = self.engine.stage
        self.view, self.fx = photo_view(stage)
        self.plate = background_card(stage, self.view)
        self.drawn = drawn_objects(stage)
        self.opening, self.regions = opening_frame(stage, regions=True)
        self.card = OpeningCard(self.opening, self.view, self.fx)
        self.card_image = self.card.opaque  # what the opening card shows now (see _update_card)
        self.movers: dict = {}  # ("body", index) | ("surface", path) | ("particles", name) → Mover
        self._body_points: dict = {}  # body index → its mesh's points in the body's frame
        self.actions: queue.Queue = queue.Queue()
        self.playing = options.play
        self._cards: dict = {}  # client id → (its opening-view card's tiles, whether its camera is the photo's)
        self._card_sent = 0.0  # when the card's holes were last sent
        self._card_due = False  # things moved since the holes were last worked out, held back by CARD_EVERY
        self._last_q = None  # the bodies' poses at the last publish, for the holes' lead
        self.time_scale = 1.0
        self.status = ""
        self.saved = 0
        self.kept = None  # the last take saved (write_take's summary): the studio renders it instead of simulating
        self.seconds = {"step": 0.0, "publish": 0.0}  # wall time of the loop's two halves
        self.rate = 0.0
        self._sent: dict = {}
        self.server = None

    # --- page -------------------------------------------------------------------------------------
    def start(self) -> str:
        import viser

        o = self.options
        guard = security.Guard(o.host)
        with contextlib.redirect_stdout(io.StringIO()), security.guarded_server(guard):  # viser's banner
            self.server = viser.ViserServer(host=o.host, port=o.port, label="physomni-usd preview", verbose=False)
        url = guard.url(self.server.get_port())
        self._build_scene()
        self._build_panel()
        self.echo(f"preview: {url}")
        if o.open_browser or (o.open_browser is None and browser_available()):
            import webbrowser

            webbrowser.open(url)
        return url

    def _photo_camera(self, cam) -> None:
        v = self.view
        if hasattr(cam, "up_direction"):  # a connected page's camera: its canvas's aspect is known
            cam.up_direction = (0.0, 0.0, 1.0)
            cam.fov = fitted_fov(v, cam.aspect)
        else:  # what a page starts with
            cam.up = (0.0, 0.0, 1.0)
            cam.fov = v.fov
        cam.position = v.position
        cam.look_at = v.look_at
        cam.near = 0.01
        cam.far = 1000.0

    def _build_scene(self) -> None:
        s = self.server
        s.scene.configure_environment_map(hdri=None)
        s.scene.configure_default_lights(enabled=True, cast_shadow=False)
        s.scene.set_up_direction("+z")
        # nothing drawn is black: outside the photo's view the page is letterboxed
        s.scene.set_background_image(np.zeros((2, 2, 3), np.uint8), format="png")
        self._photo_camera(s.initial_camera)
        s.on_client_connect(self._connected)
        s.on_client_disconnect(lambda client: self._cards.pop(client.client_id, None))
        plate, centre, wxyz, w, h = self.plate
        s.scene.add_image("/plate", plate, w, h, format="jpeg", jpeg_quality=92, position=centre, wxyz=wxyz,
                          cast_shadow=False, receive_shadow=False)
        e = self.engine
        self.handles = {}
        self.ground = None  # the bodies' contact shadows (GroundShadow) and the image that shows them
        self.live_meshes = {}
        self.clouds = {}
        q, _ = e.body_state()
        families = {o.path: o for o in e.objects}
        tracks = {}
        for path, d in self.drawn.items():
            live = families.get(path)
            if live is None:
                continue
            if live.body is not None:
                b = live.body
                h = s.scene.add_glb(f"/objects/{d.name}", textured_glb(d), position=q[b, :3],
                                    wxyz=q[b, [6, 3, 4, 5]], cast_shadow=False, receive_shadow=False)
                if float(e.sim.model.body_inv_mass.numpy()[b]) > 0:
                    self._draggable(h, b)
                self.handles[b] = h
                self.movers[("body", b)] = Mover(_posed(d.points, q[b]), d.faces, path)
                self._body_points[b] = d.points
                tracks[b] = self._shadow_track(d, q[b])
            elif path in e.surfaces():
                world = e.world_surface(path, e.surfaces()[path])
                self.live_meshes[path] = s.scene.add_mesh_simple(
                    f"/objects/{d.name}", world.astype(np.float32), d.faces, color=mean_colour(d.texture),
                    side="double", cast_shadow=False, receive_shadow=False)
                self.movers[("surface", path)] = Mover(world.copy(), d.faces, path)
        tracks = {b: t for b, t in tracks.items() if t is not None}
        if tracks:
            self.ground = GroundShadow(tracks)
            self.ground_image = s.scene.add_image("/shadows", self.ground.rgba(q), self.ground.width,
                                                  self.ground.height, format="png", position=self.ground.centre,
                                                  wxyz=(1.0, 0.0, 0.0, 0.0), cast_shadow=False, receive_shadow=False)
        for name, pts in e.particles().items():
            mo = next(m for m in e.sim.mpm.objects if m.obj.name == name)
            colour = tuple(int(255 * c) for c in mo.colour)
            self.clouds[name] = s.scene.add_point_cloud(f"/particles/{name}", pts.astype(np.float32),
                                                        colors=colour, point_size=float(e.sim.mpm.spacing),
                                                        point_shape="circle")
            path = next((p for p, d in self.drawn.items() if d.name == name), None)
            self.movers[("particles", name)] = Mover(pts.copy(), None, path,
                                                     float(e.sim.mpm.spacing))

    def _shadow_track(self, d, pose) -> ShadowTrack | None:
        """The object's contact shadow, as ``render`` casts it, to follow the body: the plate has the photo's
        own shadows taken out, so without it every object would float once the opening view gives way. None for
        an object too far above the ground to darken it."""
        from ..settings import RenderSettings

        look = RenderSettings()
        foot = d.world_points().mean(axis=0) * np.array([1.0, 1.0, 0.0])
        decal = contact_decal(d, look.shadow_strength, look.shadow_falloff,
                              shadow_blur_m(self.view, self.fx, foot, look.shadow_blur))
        return ShadowTrack.of(d, decal, np.asarray(pose, float)) if decal.alpha.any() else None

    # --- the opening view ---------------------------------------------------------------------------
    def _connected(self, client) -> None:
        """A new page: its camera is the photo's, fitted to its canvas, and it shows the first frame as
        ``render`` draws it (the photo) on a card filling that view, clear only where something has moved."""
        self._photo_camera(client.camera)
        centre, wxyz, w, h = opening_card(self.view, self.fx, OPENING_DISTANCE)
        tiles = []
        for i, tile in enumerate(self.card.tiles()):
            at, tw, th = self.card.tile_place(tile, centre, w, h)
            tiles.append(client.scene.add_image(f"/opening/{i}", self.card_image[tile], tw, th, format="png",
                                                position=at, wxyz=wxyz, cast_shadow=False, receive_shadow=False,
                                                visible=True))
        self._cards[client.client_id] = [tiles, True]
        client.camera.on_update(lambda cam, cid=client.client_id: self._camera_moved(cid, cam))

    def _update_card(self, q: np.ndarray, surfaces: dict, particles: dict, now: bool = False) -> None:
        """Clear the opening card where something has moved since frame 0 (what it left, where it is and, for a
        body, where it will be in :data:`CARD_EVERY` s at its present speed; its shadow), opaque everywhere else:
        playing or paused, what has not moved is the photo itself. While the card has holes they are worked out
        and sent again at most every :data:`CARD_EVERY` s (the first opens at once), unless ``now``."""
        e = self.engine
        if not now and self.card_image is not self.card.opaque and \
                time.perf_counter() - self._card_sent < CARD_EVERY:
            self._card_due = True
            return
        self._card_due = False
        hole = np.zeros((self.card.height, self.card.width), np.uint8)
        bodies = []
        moved: set[str] = set()
        last, self._last_q = self._last_q, np.array(q, copy=True)
        for key, m in self.movers.items():
            kind, name = key
            if kind == "body":
                now = _posed(self._body_points[name], q[name])
                if last is not None and self.card.moved(now, m.start):
                    ahead = (q[name, :3] - last[name, :3]) * CARD_EVERY * e.fps
                    self.card.silhouette(hole, now + ahead, m)
            elif kind == "surface":
                now = e.world_surface(name, surfaces[name]) if name in surfaces else m.start
            else:
                now = particles.get(name, m.start)
            if not self.card.moved(now, m.start):
                continue
            if m.path is not None:
                moved.add(m.path)
            self.card.silhouette(hole, now, m)
            if kind == "body":
                bodies.append(name)
        # what the moved objects leave: each one's own pixels, and a shadow another shares once both have moved
        hole |= moved_regions(self.regions, moved, hole.shape)
        if bodies and self.ground is not None:
            self.card.shadow(hole, self.ground, self.ground.darkening(q, bodies), SHADOW_LIFT)
        image = self.card.rgba(hole)
        if image is self.card_image or np.array_equal(image[..., 3], self.card_image[..., 3]):
            return
        self._send_card(image)

    def card_now(self) -> np.ndarray:
        """(h, w, 4) uint8: the card for the scene as it is now (sent to the pages too)."""
        e = self.engine
        self._update_card(e.body_state()[0], e.surfaces() if self.live_meshes else {},
                          e.particles() if self.clouds else {}, now=True)
        return self.card_image

    def _send_card(self, image: np.ndarray) -> None:
        """Send the tiles of ``image`` that differ from what the pages show."""
        changed = [i for i, tile in enumerate(self.card.tiles())
                   if not np.array_equal(image[tile][..., 3], self.card_image[tile][..., 3])]
        tiles = self.card.tiles()
        for entry in list(self._cards.values()):
            for i in changed:
                entry[0][i].image = image[tiles[i]]
        self.card_image = image
        self._card_sent = time.perf_counter()

    def _camera_moved(self, client_id, cam) -> None:
        entry = self._cards.get(client_id)
        if entry is None:
            return
        v = self.view
        ahead = np.asarray(cam.look_at, float) - np.asarray(cam.position, float)
        entry[1] = bool(np.linalg.norm(np.asarray(cam.position, float) - v.position) < AT_PHOTO_M
                        and np.dot(ahead / max(np.linalg.norm(ahead), 1e-12), v.axes[2]) > 1 - 1e-6)
        if entry[1] and abs(cam.fov - fitted_fov(v, cam.aspect)) > 1e-4:
            cam.fov = fitted_fov(v, cam.aspect)  # the canvas changed shape: keep the photo letterboxed
        self._show_opening()

    def _show_opening(self) -> None:
        """The opening card on each page whose camera is the photo's (a camera moved away sees the meshes)."""
        for tiles, at_photo in list(self._cards.values()):
            for tile in tiles:
                if tile.visible != at_photo:
                    tile.visible = at_photo

    def _set_playing(self, playing: bool) -> None:
        self.playing = playing
        if getattr(self, "play_button", None) is not None:
            self.play_button.label = "Pause" if playing else "Play"
        self._show_opening()

    def _draggable(self, handle, body: int) -> None:
        engine = self.engine

        @handle.on_drag("left")
        async def _(event) -> None:
            if event.phase == "start":
                if not self.playing:  # a drag on an object starts the simulation, as Play does
                    self._set_playing(True)
                engine.grab(body, np.asarray(event.start_position, float))
                engine.pull_to(np.asarray(event.end_position, float))
            elif event.phase == "update":
                engine.pull_to(np.asarray(event.end_position, float))
            else:
                engine.release()

    def _build_panel(self) -> None:
        gui = self.server.gui
        e = self.engine
        gui.configure_theme(control_width="medium", show_logo=False, show_share_button=False)
        gui.main_panel.dock_right()  # beside the view, not over the photo
        self.rate_text = gui.add_markdown("**rate:** starting")
        with gui.add_folder("Playback"):
            play = gui.add_button("Pause" if self.playing else "Play", icon=None)
            self.play_button = play
            step = gui.add_button("Step")
            reset = gui.add_button("Reset to frame 0")
            scale = gui.add_slider("Time scale", 0.1, 2.0, 0.05, 1.0)
            photo = gui.add_button("Photo view")

            @play.on_click
            def _(_) -> None:
                self._set_playing(not self.playing)

            @step.on_click
            def _(_) -> None:
                self.actions.put("step")

            @reset.on_click
            def _(_) -> None:
                e.reset()

            @scale.on_update
            def _(_) -> None:
                self.time_scale = _within(scale.value, 0.1, 2.0, self.time_scale)

            @photo.on_click
            def _(event) -> None:
                self._photo_camera(event.client.camera)
                entry = self._cards.get(event.client.client_id)
                if entry is not None:
                    entry[1] = True
                self._show_opening()

        if e.field_list:
            with gui.add_folder("Force fields"):
                for i, f in enumerate(e.field_list):
                    self._field_controls(gui, i, f)
        with gui.add_folder("Scene"):
            g = gui.add_slider("Gravity (m/s²)", 0.0, 20.0, 0.01, round(e.gravity, 2))
            g.on_update(lambda _: _set(e.set_gravity, g.value, *security.gravity_range()))
        rigid = [o for o in e.objects if o.body is not None and "friction" in o.params]
        if rigid:
            with gui.add_folder("Objects", expand_by_default=False):
                for o in rigid:
                    self._object_controls(gui, o)
        with gui.add_folder("Keep"):
            save = gui.add_button("Save take")
            keep = gui.add_button("Keep settings")
            self.status_text = gui.add_markdown(" ")
            save.on_click(lambda _: self.actions.put("save"))
            keep.on_click(lambda _: self.actions.put("keep"))

    def _field_controls(self, gui, i: int, f) -> None:
        e = self.engine
        label = field_label(f)
        on = gui.add_checkbox(f"{label} on", bool(f.enabled))
        top = max(abs(f.strength) * 4.0, 1.0)
        lo = -top if f.strength < 0 or f.kind == "point" else 0.0
        strength = gui.add_slider(f"{label} strength", lo, top, top / 200.0, float(f.strength))
        on.on_update(lambda _: e.set_field(i, enabled=bool(on.value)))
        strength.on_update(lambda _: _set(lambda v: e.set_field(i, strength=v), strength.value,
                                          *security.field_strength_range()))

    def _object_controls(self, gui, o) -> None:
        e = self.engine
        d0 = o.params["density"]
        sliders = {
            "density": gui.add_slider(f"{o.name} density (kg/m³)", round(d0 / 10, 3), round(d0 * 10, 3),
                                      round(d0 / 100, 4), d0),
            "friction": gui.add_slider(f"{o.name} friction", 0.0, 2.0, 0.01, round(o.params["friction"], 3)),
            "restitution": gui.add_slider(f"{o.name} restitution", 0.0, 1.0, 0.01,
                                          round(o.params["restitution"], 3)),
        }
        for key, s in sliders.items():
            s.on_update(lambda _, key=key, s=s: _set(lambda v, key=key: e.set_param(o.name, key, v), s.value,
                                                     *security.param_range(key)))

    # --- loop -------------------------------------------------------------------------------------
    def publish(self) -> None:
        """Send this frame's poses (only those that changed) and deformable shapes in one batch."""
        e = self.engine
        q, _ = e.body_state()
        moved = False
        with self.server.atomic():
            for b, h in self.handles.items():
                pose = q[b]
                last = self._sent.get(b)
                if last is not None and np.abs(pose - last).max() < SEND_TOLERANCE:
                    continue
                h.position = pose[:3]
                h.wxyz = pose[[6, 3, 4, 5]]
                self._sent[b] = pose.copy()
                moved = True
            surfaces = e.surfaces() if self.live_meshes else {}
            for path, h in self.live_meshes.items():
                h.vertices = e.world_surface(path, surfaces[path]).astype(np.float32)
            particles = e.particles() if self.clouds else {}
            for name, pts in particles.items():
                self.clouds[name].points = pts.astype(np.float32)
            if moved and self.ground is not None:
                self.ground_image.image = self.ground.rgba(q)
            if moved or surfaces or particles or self._card_due:  # due: holes held back, things now at rest
                self._update_card(q, surfaces, particles)
        self._show_opening()

    def _handle(self, action: str) -> None:
        e = self.engine
        if action == "step":
            e.step()
            self.publish()
        elif action == "save":
            summary, line = save_take(e, self.saved + 1)
            if summary is not None:
                self.saved += 1
                self.kept = summary
            self._say(line)
        elif action == "keep":
            self._say(keep_settings(e)[1])

    def _say(self, message: str) -> None:
        self.status = message
        self.echo(f"preview: {message}")
        if self.server is not None:
            self.status_text.content = message

    def run(self) -> dict:
        """Step and publish until the duration ends or the user interrupts; returns what happened."""
        o, e = self.options, self.engine
        frame_dt = 1.0 / e.fps
        start = last_report = time.perf_counter()
        next_frame = start
        frames_since = 0
        rates = []
        interrupted = False
        try:
            while o.duration is None or time.perf_counter() - start < o.duration:
                while not self.actions.empty():
                    self._handle(self.actions.get())
                if self.playing:
                    t0 = time.perf_counter()
                    e.step()
                    t1 = time.perf_counter()
                    self.publish()
                    self.seconds["step"] += t1 - t0
                    self.seconds["publish"] += time.perf_counter() - t1
                    frames_since += 1
                elif e.sync():  # a reset or a change while paused shows at once
                    self.publish()
                now = time.perf_counter()
                if now - last_report >= o.report_every:
                    self.rate = frames_since / (now - last_report)
                    rates.append(self.rate)
                    self.echo(f"preview: {self.rate:.1f} fps")
                    self.rate_text.content = (f"**{self.rate:.1f} fps** · frame {e.frame} · "
                                              f"{e.plan.substeps} substeps a frame"
                                              + (" · captured" if e.captured_frames else ""))
                    frames_since, last_report = 0, now
                if o.paced or not self.playing:
                    next_frame += frame_dt / max(self.time_scale, 1e-3) if self.playing else frame_dt
                    delay = next_frame - time.perf_counter()
                    if delay > 0:
                        time.sleep(delay)
                    else:
                        next_frame = time.perf_counter()  # behind: run as fast as we can, do not catch up
        except KeyboardInterrupt:
            interrupted = True
        finally:
            # a take and settings asked for in the last moments are still kept
            while not self.actions.empty():
                self._handle(self.actions.get())
            result = {"frames": e.frame, "rates": rates, "interrupted": interrupted,
                      "wall_seconds": time.perf_counter() - start, "seconds": dict(self.seconds)}
            if o.record:
                result["take"] = e.write_take()
                self.echo(f"preview: take written to {result['take']['path']} ({result['take']['frames']} frames)")
            self.stop()
        return result

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None


def _refusal(exc: Exception) -> str | None:
    """The one line a refused or failed write says (a link, a planted lock, a layer that cannot be composed, a
    full disk), or None for a bug, which is raised."""
    from ..failure import failure_of

    found = failure_of(exc)
    return None if found.internal else found.message


def save_take(engine: Engine, number: int) -> tuple[dict | None, str]:
    """"Save take": the take so far to ``sim.usdc`` (and the shot's frame range), as ``simulate`` writes it;
    returns the take's summary (``Engine.write_take``'s; None where nothing was written) and the line to say. A refusal is that line, not an exception: the session
    and its take go on, and the user can put the folder right and press again."""
    try:
        r = engine.write_take()
    except (PhysOmniError, OSError) as exc:
        line = _refusal(exc)
        if line is None:
            raise
        return None, line
    return r, (f"take {number} saved: {r['frames']} frames ({r['seconds']:.2f} s), "
                  f"{len(r['moving_prims'])} moving prims → sim.usdc")


def keep_settings(engine: Engine) -> tuple[bool, str]:
    """"Keep settings": the settings changed in the session added to ``edits.usda`` as ``estimate --set`` adds
    its values (under the shot's lock, all or nothing, never through a link, every opinion already in the file
    kept); returns whether it was written and the line to say. A refusal is that line, as for :func:`save_take`."""
    from .._files import all_or_nothing, folder_lock
    from ..usd.overrides import add_overrides

    changes = engine.changed_settings()
    if not changes:
        return False, "no settings changed: edits.usda left as it was"
    try:
        # the lock from before edits.usda is read to after it is replaced: an `estimate --set` in another
        # terminal lands before or after this, never lost between the read and the write
        with all_or_nothing(), folder_lock(engine.folder):
            add_overrides(engine.folder, changes)
    except (PhysOmniError, OSError) as exc:
        line = _refusal(exc)
        if line is None:
            raise
        return False, line
    return True, f"kept {len(changes)} setting(s) in edits.usda"


def run_preview(shot, options: Options = Options()) -> dict:
    preview = Preview(shot, options)
    preview.start()
    return preview.run()


def _posed(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(N, 3) world points of a body's local ``points`` at ``pose`` (x, y, z, qx, qy, qz, qw)."""
    from scipy.spatial.transform import Rotation

    pose = np.asarray(pose, float)
    return np.asarray(points, float) @ Rotation.from_quat(pose[3:7]).as_matrix().T + pose[:3]
