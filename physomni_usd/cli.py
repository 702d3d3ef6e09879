"""The ``physomni-usd`` command: one subcommand per stage (build, estimate, simulate, render), ``run``
for the three of them, and ``preview``, ``validate``, ``batch``, ``bench``, ``plugins``, ``rerender``.

The stage commands and ``run`` parse their options, call the public API (:mod:`physomni_usd`) and show
what it did; the others call the module that owns them. In every command an exception becomes one
``error:`` line and an exit code (:func:`physomni_usd.failure.failure_of`): 0 success, 1 a stage failed
or validation found errors, 2 bad input or usage, 3 an internal error (a bug: please report it), 130
interrupted.
"""

from __future__ import annotations

import os
import pathlib
import sys
import time
from contextlib import contextmanager
from functools import lru_cache

import click

from ._files import all_or_nothing
from .failure import failure_of
from .settings import MAX_PARTICLES, MAX_SOLVER_STEPS, RenderSettings, SimulateSettings

PUSH_HELP = ("Give an object this velocity in m/s (each component at most 1000 in size) at T seconds "
             "(default 0, T ≥ 0); world axes: Z up, +Y away from the camera, +X to the image's right. A label "
             "shared by several objects pushes them all (and says which); a prim name (toy_1) pushes one. "
             "Repeatable.")

EPILOG_BUILD = """
\b
Examples:
  physomni-usd build photo.png -o shot/ --mask cup.png:cup --mask saucer.png
  physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --fov 60
  physomni-usd build photo.png -o shot/ --box 120,40,380,300:cup:-130,60   (a click off the cup)
  physomni-usd build photo.png -o shot/ --find "cup, saucer, spoon"        (needs physomni-sam3)
"""


def limits(model, field: str) -> str:
    """The valid range of a settings field as help text, e.g. ``0 < value ≤ 600``, from its declaration."""
    lo = hi = ""
    for m in model.model_fields[field].metadata:
        for attr, fmt in (("gt", "{} <"), ("ge", "{} ≤")):
            if getattr(m, attr, None) is not None:
                lo = fmt.format(f"{getattr(m, attr):g}") + " "
        for attr, fmt in (("lt", "< {}"), ("le", "≤ {}")):
            if getattr(m, attr, None) is not None:
                hi = " " + fmt.format(f"{getattr(m, attr):g}")
    finite = ", finite" if "float" in str(model.model_fields[field].annotation) else ""
    return f"{lo}value{hi}{finite}" if (lo or hi) else ""


def _range_help(text: str, model, field: str) -> str:
    return f"{text} Range: {limits(model, field)}."


def _fail(message: str, code: int) -> None:
    from .errors import redact

    click.echo(f"error: {redact(message)}", err=True)
    sys.exit(code)


@contextmanager
def _errors():
    """Turn our exceptions and pydantic's into one line and an exit code (:func:`failure.failure_of`)."""
    from .errors import Interrupted, received_signal

    try:
        yield
    except (Exception, KeyboardInterrupt) as exc:
        if received_signal() is not None and not isinstance(exc, Interrupted):
            # whatever broke after a signal whose exception was swallowed (a module left half-imported) is
            # the signal's doing: say that, not an internal error
            exc = Interrupted(received_signal())
        found = failure_of(exc)
        if found.internal and os.environ.get("PHYSOMNI_DEBUG"):
            raise
        _fail(found.message, found.exit_code)


#: Where stderr is no terminal (a log, CI), progress is a plain line at every tenth of the work, and at
#: least every this many seconds.
LOG_EVERY_S = 5.0


@contextmanager
def _progress(label: str, enabled: bool = True):
    """A click progress bar on stderr, or plain ``label: frame K/N`` lines where stderr is not a terminal;
    yields a callback ``(done, total)``."""
    state = {"bar": None, "done": 0, "logged": 0, "at": time.monotonic()}
    tty = sys.stderr.isatty()

    def log(done, total):
        now = time.monotonic()
        tenth = max(1, -(-total // 10))
        if done >= total or done // tenth > state["logged"] // tenth or now - state["at"] >= LOG_EVERY_S:
            click.echo(f"{label.strip()}: frame {done}/{total}", err=True)
            state["logged"], state["at"] = done, now

    def update(done, total):
        if not enabled:
            return
        if not tty:
            log(done, total)
            return
        if state["bar"] is None:
            state["bar"] = click.progressbar(length=total, label=label, file=sys.stderr, show_pos=True)
            state["bar"].__enter__()
        state["bar"].update(done - state["done"])
        state["done"] = done

    try:
        yield update
    finally:
        if state["bar"] is not None:
            state["bar"].__exit__(None, None, None)


@contextmanager
def _shot_lock(shot):
    """Hold the shot folder's lock from before the command reads the shot to after its last write, so that
    two commands on one shot (two `estimate --set`) run one after the other and no update is lost."""
    from ._files import folder_lock
    from .usd import layers

    with folder_lock(layers.shot_folder(shot)):
        yield


def _say(quiet: bool):
    return (lambda msg: None) if quiet else (lambda msg: click.echo(msg, err=True))


class _OneLineUsage(click.Group):
    """A subcommand's usage error (a missing -o, an unknown option, a bad choice) as one ``error:`` line and
    exit 2, as every other bad input is; click would print the command's usage and a hint around it."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:
            where = exc.ctx.command_path if exc.ctx is not None else ctx.command_path
            message = exc.format_message()
            _fail(f"{where}: {message[:-1] if message.endswith('.') else message}; see `{where} --help`", 2)


@click.group(cls=_OneLineUsage, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="physomni-usd")
def main():
    """Turn one photograph into a physically simulated, layered USD shot and a video.

    \b
    A shot folder holds one layer per stage under a root shot.usda:
      shot.usda = [edits.usda, render.usda, sim.usdc, physics.usda, scene.usda]
    (strongest first; render.usda holds a camera move, written by `render --camera`).
    edits.usda is yours: it is created empty, no command rewrites it (only
    `estimate --set` and the preview's "Keep settings" add your values to it),
    and what you author there (a heavier object, a push, a moved prop) counts
    in the next `simulate`.

    \b
    Quick start:
      physomni-usd run photo.png -o shot/ --mask cup.png:cup --push cup=0.5,0,0
      physomni-usd validate shot/shot.usda
    """
    _exit_without_collecting()
    previous = _stop_on_signals()
    if previous:  # an in-process caller (a test, a script) gets its own handlers back afterwards
        import signal

        click.get_current_context().call_on_close(lambda: [signal.signal(k, v) for k, v in previous.items()])


@lru_cache(maxsize=1)
def _exit_without_collecting() -> None:
    """Python's exit walks the whole heap with its cycle collector once per module it clears: seconds of CPU
    after the last line is printed, for the objects that warp's kernels and Newton leave. Nothing is left to
    reclaim from a process that is ending, so the heap is moved out of the collector's reach first; objects
    are still freed as their modules are cleared, and atexit handlers still run."""
    import atexit
    import gc

    atexit.register(gc.freeze)


def _stop_on_signals() -> dict:
    """SIGTERM and SIGHUP (what `timeout`, farm managers and Kubernetes send) unwind a command as Ctrl-C
    does, so its files are put back; SIGINT too where it was inherited ignored (a script's background
    job). A SIGHUP ignored on purpose (nohup) stays ignored; a second signal while unwinding is ignored.
    Returns the handlers it replaced."""
    import signal
    import threading

    from .errors import Interrupted, forget_signals, note_signal

    if threading.current_thread() is not threading.main_thread():
        return {}
    state = {"stopping": False}
    forget_signals()

    def stop(signum, frame):
        if state["stopping"]:
            return
        state["stopping"] = True
        # noted as well as raised: if a library swallows the exception, the commit (all_or_nothing) and the
        # command's end (_errors) still see the signal, so the files are put back and the exit is 128 + N
        if note_signal(signum):
            raise Interrupted(signum)

    previous = {}
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        old = signal.getsignal(sig)
        if sig == signal.SIGHUP and old is signal.SIG_IGN:
            continue
        previous[sig] = old if old is not None else signal.SIG_DFL
        signal.signal(sig, stop)
    return previous


def build_options(f):
    from .fields import KINDS
    from .settings import BuildSettings, CameraSettings

    opts = [
        click.option("--mask", "masks", multiple=True, metavar="PNG[:LABEL]",
                     help="Object mask at the photo's resolution; non-zero pixels are the object. "
                          "Repeat per object; LABEL defaults to the file's name."),
        click.option("--box", "boxes", multiple=True, metavar="X0,Y0,X1,Y1[:LABEL][:±X,Y...]",
                     help="Pixel box around an object; the segmenter (OpenCV GrabCut by default) cuts its mask. "
                          "Clicks after it correct the mask: +X,Y a pixel on the object, -X,Y one off it "
                          "(e.g. 120,40,380,300:cup:-130,60). `physomni-usd studio` writes these for you. "
                          f"Repeatable; at most {BuildSettings().max_objects} objects, --mask and --box together."),
        click.option("--find", default=None, metavar="PHRASES",
                     help="Find every instance of each phrase with a text-promptable finder, e.g. "
                          "'cup, saucer, spoon'; each is labelled by its phrase and numbered after the masks "
                          "and boxes (cup_2, cup_3). Needs a finder plugin (physomni-sam3)."),
        click.option("--finder", default=None, metavar="NAME",
                     help="The finder --find uses [default: sam3]. See `physomni-usd plugins`."),
        click.option("--meshes", "meshes_dir", type=click.Path(file_okay=False, path_type=pathlib.Path),
                     default=None, help="Folder with one mesh per object (OBJ, GLB, PLY) and poses.json "
                                        "(label → mesh, rotation_wxyz, translation, scale in OpenCV camera "
                                        "coordinates); replaces silhouette lifting."),
        click.option("--fov", type=float, default=None,
                     help="Vertical field of view of the photo in degrees [default: from the photo's vanishing "
                          f"points, else 50°]. Range: {limits(CameraSettings, 'fov_deg')}."),
        click.option("--pitch", type=float, default=None,
                     help="Downward camera tilt in degrees, 0 (level) to 90 (straight down) [default: estimated "
                          "from the photo: round outlines, vanishing points, horizon, where objects stand]. "
                          f"Range: {limits(CameraSettings, 'pitch_deg')}."),
        click.option("--camera-height", type=float, default=None,
                     help="Camera height above the ground in metres; sets the scene's scale [default: from the "
                          f"objects' typical sizes by label, else 1 m]. Range: {limits(CameraSettings, 'height_m')}."),
        click.option("--size", "sizes", multiple=True, metavar="LABEL=METRES",
                     help="An object's real longest dimension, e.g. 'coin=0.024'; fixes the scene's scale "
                          "(over --camera-height and the typical sizes). Repeatable."),
        click.option("--shape", type=click.Choice(["auto", "round", "extrude"]), default="auto", show_default=True,
                     help="How silhouettes become meshes: surface of revolution, extrusion, or by symmetry."),
        click.option("--fps", type=float, default=30.0, show_default=True,
                     help=_range_help("Frames per second of the shot.", BuildSettings, "fps")),
        click.option("--fix", "fixed", multiple=True, metavar="LABEL",
                     help="Keep this object where it is (it still collides); a label shared by several objects "
                          "fixes them all. Repeatable."),
        click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
                     help=f"A force field ({', '.join(KINDS)}), e.g. "
                          "'wind:direction=1,0,0,strength=30'. Accelerations in m/s²; times in seconds. Repeatable."),
        click.option("--max-pixels", type=int, default=BuildSettings().max_pixels, show_default=True,
                     help="Refuse a larger photo (width × height), judged from its header before decoding. "
                          f"Range: {limits(BuildSettings, 'max_pixels')}."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def backend_options(f):
    """--segmenter/--inpainter/--lifter/--depth/--estimator, passed on as one ``backends`` dict."""
    import functools

    kinds = {"segmenter": "How --box becomes a mask [default: grabcut; plugin: sam].",
             "inpainter": "What fills the objects' holes in the plate [default: builtin; plugin: lama].",
             "outpainter": "What extends the plate beyond the photo's frame for camera moves "
                           "[default: exemplar; built in: mirror].",
             "lifter": "How masks become meshes [default: silhouette; plugin: sam3d].",
             "depth": "A depth model whose ground plane sets the camera's pitch when --pitch is not given "
                      "[default: none; plugin: depth-anything].",
             "estimator": "Materials from rules or a model [default: rules; built in: vlm, which reads "
                          "PHYSOMNI_VLM_URL and PHYSOMNI_VLM_MODEL]."}

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        kwargs["backends"] = {k: kwargs.pop(k) for k in kinds}
        return f(*args, **kwargs)

    for kind, text in reversed(kinds.items()):
        wrapper = click.option(f"--{kind}", kind, default=None, metavar="NAME",
                               help=text + " See `physomni-usd plugins`.")(wrapper)
    return wrapper


def _build_settings(fov, pitch, camera_height, shape, fps, max_pixels=None, photo=None, objects=0):
    """The build's settings; with ``photo``, also refuse (before any work) a photo over ``max_pixels``
    and more than ``max_objects`` masks and boxes."""
    from .errors import InputError
    from .settings import BuildSettings, CameraSettings, LiftSettings

    extra = {} if max_pixels is None else {"max_pixels": max_pixels}
    settings = BuildSettings(camera=CameraSettings(fov_deg=fov, pitch_deg=pitch, height_m=camera_height),
                             lift=LiftSettings(shape=shape), fps=fps, **extra)
    if objects > settings.max_objects:
        raise InputError(f"--mask/--box: {objects} objects; a shot has at most {settings.max_objects}")
    if photo is not None:
        from .perceive.masks import check_photo_size

        check_photo_size(photo, settings.max_pixels)
    return settings


@main.command(epilog=EPILOG_BUILD)
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder to write (created if missing).")
@build_options
@backend_options
@click.option("--push", "pushes", multiple=True, metavar="LABEL=VX,VY,VZ[@T]",
              help=PUSH_HELP)
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def build(photo, out_dir, masks, boxes, fov, pitch, camera_height, sizes, shape, fps, meshes_dir, fixed, forces, pushes,
          quiet, backends, max_pixels, find=None, finder=None):
    """Photo → scene.usda, physics.usda and the root shot.usda (perceive, align, estimate)."""
    with _errors():
        import physomni_usd

        settings = _build_settings(fov, pitch, camera_height, shape, fps, max_pixels, photo, len(masks) + len(boxes))
        result = physomni_usd.build(photo, out_dir, masks, boxes, settings, pushes=pushes, echo=_say(quiet),
                                    forces=forces, fixed=fixed, meshes_dir=meshes_dir, sizes=sizes, backends=backends,
                                    find=find, finder=finder)
        if not quiet:
            total = sum(result.seconds.values())
            click.echo(f"wrote {result.shot} ({len(result.objects)} objects, {total:.2f} s)", err=True)


def _simulate(shot, seconds, fps, substeps, quiet, particle_spacing=None, mpm_steps=None):
    import physomni_usd
    from .settings import SimulateSettings
    from .usd import layers

    if seconds is None:  # the shot's own length; 3 s for a shot never simulated
        root = layers.shot_file(shot)
        seconds = (layers.shot_seconds(root) if root.is_file() else None) or DEFAULT_SECONDS

    settings = SimulateSettings(seconds=seconds, fps=fps, substeps=substeps, particle_spacing=particle_spacing,
                                mpm_steps=mpm_steps)
    if substeps is not None:  # refused before any work, not after an hour of it
        from .errors import InputError

        root = layers.shot_file(shot)
        rate = fps or (layers.check_layer(root).timeCodesPerSecond if root.is_file() else 30.0)
        steps = round(seconds * rate) * substeps
        if steps > MAX_SOLVER_STEPS:
            raise InputError(f"--substeps {substeps}: {seconds:g} s at {rate:g} fps is {steps:,} solver steps; at "
                             f"most {MAX_SOLVER_STEPS:,} (fewer --seconds, --fps or --substeps)")
    with _progress("simulate", not quiet) as bar:
        section = physomni_usd.simulate(shot, settings, progress=bar, echo=_say(quiet))
    _said("simulate", section, quiet)
    return section


#: What `preview` takes for a photo (and hands to the set-up page) rather than a shot.
PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")

def _said(stage: str, section, quiet: bool) -> None:
    """The one line a stage ends with."""
    if quiet:
        return
    if stage == "simulate":
        click.echo(f"simulate: {section['frames']} frames, {section['bodies']} rigid bodies, "
                   f"{len(section['moving_prims'])} moving, dt {section['dt'] * 1000:.2f} ms, "
                   f"{section['total_seconds']:.2f} s", err=True)
    elif stage == "render":
        click.echo(f"render: {section['video']} ({section['frames']} frames, "
                   f"{section['frames_per_second']:.1f} frames/s)", err=True)


#: Simulated seconds of `run` (:func:`physomni_usd.run`'s default), and of `simulate` on a shot that has no
#: length yet.
DEFAULT_SECONDS = SimulateSettings.model_fields["seconds"].default


def _camera_moves():
    from .rendering.moves import MOVES

    return MOVES


def _render(shot, output, quiet, max_size=1920, passes=None, passes_dir=None, camera=None, camera_amount=1.0):
    from .rendering.passes import parse_passes
    import physomni_usd
    from .settings import RenderSettings

    names = parse_passes(passes)
    if passes_dir is not None and not names:
        from .errors import InputError

        raise InputError("--passes-dir needs --passes (e.g. --passes depth,normal,flow,mask)")
    from .validate import check_shot_values

    check_shot_values(shot)
    with _progress("render  ", not quiet) as bar:
        section = physomni_usd.render(shot, output, RenderSettings(max_size=max_size), progress=bar, passes=names,
                                      passes_dir=passes_dir, camera=camera, camera_amount=camera_amount)
    _said("render", section, quiet)
    return section


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--seconds", type=float, default=None,
              help="Simulated seconds [default: the shot's own length, its last frame over its frame rate; "
                   f"{DEFAULT_SECONDS:g} for a shot never simulated]. Range: "
                   f"{limits(SimulateSettings, 'seconds')}.")
@click.option("--fps", type=float, default=None,
              help=f"Frames per second [default: the shot's]. Range: {limits(SimulateSettings, 'fps')}.")
@click.option("--substeps", type=int, default=None,
              help="Solver steps per frame [default: chosen from the shot's materials and speeds]. "
                   f"Range: {limits(SimulateSettings, 'substeps')}; at most {MAX_SOLVER_STEPS:,} steps in all "
                   "(frames × substeps).")
@click.option("--particle-spacing", type=float, default=None, metavar="METRES",
              help="MPM particle spacing [default: 2 particles per cm³ of the MPM objects, each counted as at "
                   f"least 1,000, at most 15,000 particles]. Range: {limits(SimulateSettings, 'particle_spacing')}, and at most "
                   f"{MAX_PARTICLES:,} particles in all.")
@click.option("--mpm-steps", type=int, default=None,
              help="MPM steps per frame [default: what the bench found accurate for the shot's materials "
                   "(elastic 16, sand 4, liquid 2 at 30 fps), fewer where the CFL bound allows; fewer is a "
                   f"faster, less accurate preview]. Range: {limits(SimulateSettings, 'mpm_steps')}.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def simulate(shot, seconds, fps, substeps, particle_spacing, mpm_steps, quiet):
    """Simulate the composed shot (edits.usda included) and write sim.usdc.

    Each object goes to its material's solver: rigid bodies, cloth (pbd_cloth) and soft bodies
    (pbd_elastic) on XPBD, sand, snow, liquids and elastic solids (mpm_*) on Newton's implicit MPM,
    coupled both ways. Steps come from the materials; a frame whose energy or speed runs away is
    redone at half the step. Newton's contacts use one friction coefficient, dynamic_friction: a
    static_friction unlike it does not act (said for values you set; report.json lists all).

    \b
    Example: make the box heavier and throw it, then simulate again:
      # in shot/edits.usda
      over "World" {
          over "Objects" {
              over "box_0" {
                  float physics:density = 2000
                  vector3f physics:velocity = (0, 2, 1)
              }
          }
      }
      physomni-usd simulate shot/shot.usda --seconds 4

    \b
    Turn the box to sand and simulate with coarser particles:
      physomni-usd estimate shot/shot.usda --set box.material=mpm_sand
      physomni-usd simulate shot/shot.usda --particle-spacing 0.03

    \b
    A quick preview of an elastic shot (4 MPM steps a frame instead of 16):
      physomni-usd simulate shot/shot.usda --mpm-steps 4
    """
    with _errors(), all_or_nothing(), _shot_lock(shot):
        _simulate(shot, seconds, fps, substeps, quiet, particle_spacing, mpm_steps)


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("-o", "--output", type=click.Path(path_type=pathlib.Path), default=None,
              help="Video file (.mp4) [default: video.mp4 beside the shot].")
@click.option("--max-size", type=int, default=1920, show_default=True,
              help=_range_help("Longest side of the video in pixels; larger photos are rendered smaller. H.264 "
                               "needs even sides: an odd width or height loses its last column or row. A "
                               "frame's cost grows with its pixels: about 0.19 CPU seconds a frame at 741×500 "
                               "and 1.2 at 1920×1295 on a 2-core CPU (bench scale). The default is a full-HD "
                               "video's width: a 12 MP photo's own 4000 px would cost 4× as much a frame.",
                               RenderSettings, "max_size"))
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
@click.option("--passes", default=None, metavar="NAME,NAME,...",
              help="Also write control passes, exact from the stage: depth (channel Z, metres along the optical "
                   "axis), normal (N.X N.Y N.Z, world space), flow (motion.X motion.Y, pixels to the next frame, "
                   "+y down), mask (objectId, 0 = environment); or all. One float32 OpenEXR per frame, "
                   "passes.####.exr, plus passes.json (ids → prim paths) and a preview MP4 per pass.")
@click.option("--passes-dir", type=click.Path(path_type=pathlib.Path), default=None,
              help="Folder for the passes [default: passes/ beside the shot].")
@click.option("--camera", type=click.Choice(list(_camera_moves())), default=None, metavar="MOVE",
              help="Write this camera move to the shot's render.usda, then render it: "
                   + ", ".join(_camera_moves()) + ". Defaults over the whole shot: orbits left/right 15°, "
                   "up/down 10° about the objects' centre; truck 15 % and dolly 25 % of the distance to the "
                   "objects; crane-down 30 % of the camera's height. static removes a move. "
                   "[default: the camera the shot has]")
@click.option("--camera-amount", type=float, default=1.0, show_default=True,
              help="Size of the move as a multiple of its default. Range: 0 < value ≤ 4.")
@click.option("--still", is_flag=True,
              help="Render a shot that was never simulated: one frame, the photo's moment [default: refuse it].")
def render(shot, output, max_size, quiet, passes, passes_dir, camera, camera_amount, still):
    """Render the composed shot over its background plate into an H.264 MP4.

    A camera move is written as time samples on /World/Camera in render.usda, below edits.usda: Blender or
    usdview play the same move, and keys an artist sets on the camera in edits.usda win over it.

    \b
    Examples:
      physomni-usd render shot/shot.usda
      physomni-usd render shot/shot.usda --camera orbit-left -o shot/orbit.mp4
      physomni-usd render shot/shot.usda --camera dolly-in --camera-amount 0.5
      physomni-usd render shot/shot.usda --passes depth,normal,flow,mask --passes-dir shot/passes
    """
    with _errors():
        if not still:
            _check_simulated(shot)
        _render(shot, output, quiet, max_size, passes, passes_dir, camera, camera_amount)


def _check_simulated(shot) -> None:
    """Refuse (exit 2) a shot never simulated: its video would be one frame of the photo, silently."""
    from .errors import InputError
    from .usd import layers

    root = layers.shot_file(shot)
    if root.is_file() and layers.shot_seconds(root) is None:
        raise InputError(f"{root} was never simulated, so its video would be one still frame: run "
                         f"`physomni-usd simulate {root}` first, or pass --still for that one frame")


@main.command()
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder to write (created if missing).")
@build_options
@backend_options
@click.option("--seconds", type=float, default=None,
              help=_range_help(f"Simulated seconds [default: {DEFAULT_SECONDS:g}, ended once nothing has moved "
                               "for a second].", SimulateSettings, "seconds"))
@click.option("--push", "pushes", multiple=True, metavar="LABEL=VX,VY,VZ[@T]",
              help=PUSH_HELP)
@click.option("--particle-spacing", type=float, default=None, metavar="METRES",
              help="MPM particle spacing [default: chosen from the objects' sizes]. "
                   f"Range: {limits(SimulateSettings, 'particle_spacing')}, and at most {MAX_PARTICLES:,} "
                   "particles in all.")
@click.option("--mpm-steps", type=int, default=None,
              help="MPM steps per frame [default: chosen from the materials; see simulate --help]. "
                   f"Range: {limits(SimulateSettings, 'mpm_steps')}.")
@click.option("--camera", type=click.Choice(list(_camera_moves())), default=None, metavar="MOVE",
              help="A camera move for the video (see render --help) [default: the photo's camera, still].")
@click.option("--camera-amount", type=float, default=1.0, show_default=True,
              help="Size of the move as a multiple of its default. Range: 0 < value ≤ 4.")
@click.option("--max-size", type=int, default=1920, show_default=True,
              help=_range_help("Longest side of the video in pixels, as render --max-size takes it (a frame's "
                               "cost grows with its pixels: about 0.19 CPU seconds a frame at 741×500 and 1.2 at "
                               "1920×1295; larger photos are rendered smaller).",
                               RenderSettings, "max_size"))
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def run(photo, out_dir, masks, boxes, fov, pitch, camera_height, sizes, shape, fps, meshes_dir, fixed, forces, seconds,
        pushes, particle_spacing, mpm_steps, camera, camera_amount, quiet, backends, max_pixels, find=None, finder=None,
        max_size=1920):
    """build + simulate + render in one go; writes DIR/shot.usda, DIR/video.mp4, DIR/report.json.

    \b
    Example:
      physomni-usd run examples/motorcycle/photo.png -o out/ \\
          --mask examples/motorcycle/motorcycle.png --push motorcycle=1.4,0,0
    """
    with _errors():
        import physomni_usd

        params = dict(photo=photo, out_dir=out_dir, masks=masks, boxes=boxes, fov=fov, pitch=pitch,
                      camera_height=camera_height, sizes=sizes, shape=shape, fps=fps, meshes_dir=meshes_dir,
                      fixed=fixed, forces=forces, seconds=seconds, pushes=pushes, particle_spacing=particle_spacing,
                      mpm_steps=mpm_steps, camera=camera, camera_amount=camera_amount, backends=backends,
                      max_pixels=max_pixels, find=find, finder=finder, max_size=max_size)
        with _run_display(quiet) as display:
            done = physomni_usd.run(**_run_call(params), echo=_say(quiet), **display)
        if not quiet:
            result = done["build"]
            click.echo(f"done in {done['total_seconds']:.1f} s: {result.shot}, {done['render']['video']}, "
                       f"{result.folder / 'report.json'}", err=True)


def _run_call(params: dict) -> dict:
    """``run``'s option values (as its parser makes them, or with ``backends`` already gathered) → the
    keyword arguments of :func:`physomni_usd.run`; refuses absurd values before any work."""
    from .backends.steps import BUILD_KINDS
    from .settings import REST_SECONDS, RenderSettings, SimulateSettings

    p = dict(params)
    backends = p.pop("backends", None) or {kind: p.pop(kind, None) for kind in BUILD_KINDS}
    given = p["seconds"] is not None  # seconds asked for are simulated to the end
    simulate = SimulateSettings(seconds=p["seconds"] if given else DEFAULT_SECONDS, rest_seconds=None if given
                                else REST_SECONDS, particle_spacing=p["particle_spacing"], mpm_steps=p["mpm_steps"])
    return dict(photo=p["photo"], out_dir=p["out_dir"], masks=p["masks"], boxes=p["boxes"],
                settings=_build_settings(p["fov"], p["pitch"], p["camera_height"], p["shape"], p["fps"],
                                         p.get("max_pixels"), p["photo"], len(p["masks"]) + len(p["boxes"])),
                simulate_settings=simulate, render_settings=RenderSettings(max_size=p.get("max_size", 1920)),
                camera=p["camera"], camera_amount=p["camera_amount"],
                pushes=p["pushes"], forces=p["forces"], fixed=p["fixed"], meshes_dir=p["meshes_dir"],
                sizes=p["sizes"], backends=backends, find=p.get("find"), finder=p.get("finder"))


def _run_arguments(args: list[str]) -> dict:
    """One shot line of ``batch`` → the keyword arguments of :func:`physomni_usd.run` (raises like ``run``)."""
    return _run_call(_run_parser(list(args)))


@contextmanager
def _run_display(quiet: bool):
    """``progress`` and ``on_stage`` for :func:`physomni_usd.run`: one bar (or log lines) per stage, and the
    line each stage ends with, as the commands ``simulate`` and ``render`` print them."""
    from contextlib import ExitStack

    bars = ExitStack()
    current = {}

    def progress(stage, done, total):
        if stage not in current:
            current[stage] = bars.enter_context(_progress("render  " if stage == "render" else stage, not quiet))
        current[stage](done, total)

    def on_stage(stage, result):
        if result is not None and stage in ("simulate", "render"):
            bars.close()  # the bar ends before its stage's line
            _said(stage, result, quiet)

    with bars:
        yield {"progress": progress, "on_stage": on_stage}


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--estimator", default="rules", show_default=True, metavar="NAME",
              help="rules: label keywords (built in). vlm: ask an OpenAI-compatible vision-language model. "
                   "Plugins add more (see `physomni-usd plugins`).")
@click.option("--vlm-url", envvar="PHYSOMNI_VLM_URL", default=None,
              help="API root of the VLM server, e.g. http://localhost:8000/v1 [env: PHYSOMNI_VLM_URL].")
@click.option("--vlm-model", envvar="PHYSOMNI_VLM_MODEL", default=None,
              help="Model name on that server [env: PHYSOMNI_VLM_MODEL].")
@click.option("--vlm-api-key", envvar="PHYSOMNI_VLM_API_KEY", default=None,
              help="Bearer token, if the server wants one [env: PHYSOMNI_VLM_API_KEY].")
@click.option("--vlm-timeout", type=click.FloatRange(1, 3600), default=120.0, show_default=True,
              help="Seconds to wait for one answer.")
@click.option("--set", "sets", multiple=True, metavar="NAME.KEY=VALUE",
              help="Your value for an object's material (KEY 'material') or parameter (density, friction, "
                   "youngs_modulus, poissons_ratio, …; each within its catalog range, which a refused value's "
                   "message states); written to edits.usda. NAME: a prim name (one object) or a label (every "
                   "object with it). Repeatable.")
@click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
              help="Add a force field of yours (kept across later estimates). Repeatable.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def estimate(shot, estimator, vlm_url, vlm_model, vlm_api_key, vlm_timeout, sets, forces, quiet):
    """Estimate physical materials (and force fields) and write physics.usda; --set goes to edits.usda.

    The estimate is made from the photo that `build` keeps in the shot (inputs/photo.png). On a shot
    without one (assembled by a script) nothing is estimated: --set alone is applied and physics.usda kept.

    \b
    Examples:
      physomni-usd estimate shot/shot.usda --set cup.material=mpm_elastic --set cup.youngs_modulus=2e4
      physomni-usd estimate shot/shot.usda --estimator vlm --vlm-url http://localhost:8000/v1 \\
          --vlm-model Qwen2.5-VL-72B-Instruct
    """
    with _errors(), all_or_nothing(), _shot_lock(shot):
        import physomni_usd

        vlm = None
        if estimator == "vlm":
            from .materials.vlm import VLMSettings

            vlm = VLMSettings.resolve(vlm_url, vlm_model, vlm_api_key, timeout_s=vlm_timeout)
        section = physomni_usd.estimate(shot, estimator, vlm, sets, forces, echo=_say(quiet))
        if not quiet:
            for name, obj in section["objects"].items():
                params = ", ".join(f"{k}={v['value']:g}" if isinstance(v["value"], float) else f"{k}={v['value']}"
                                   for k, v in obj["params"].items())
                click.echo(f"{name}: {obj['material']} ({obj['source']}) {params}", err=True)


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to serve the page on.")
@click.option("--port", type=click.IntRange(1, 65535), default=8080, show_default=True, help="Port of the page.")
@click.option("--duration", type=click.FloatRange(0, 86400, min_open=True), default=None, metavar="SECONDS",
              help="Quit after this many seconds (for scripts) [default: run until Ctrl-C].")
@click.option("--record", is_flag=True, help="On exit, write the take since the last reset to sim.usdc.")
@click.option("--open/--no-open", "open_browser", default=None,
              help="Open the page in a web browser [default: where one is available].")
@click.option("-o", "--output", "out_dir", default=None, type=click.Path(path_type=pathlib.Path),
              help="Given a photo instead of a shot: the folder the set-up page (`studio`) builds the shot into.")
@click.option("--play", is_flag=True,
              help="Start the simulation at once [default: the page opens paused on frame 0, the photo, "
                   "until Play or a drag on an object].")
def preview(shot, host, port, duration, record, open_browser, out_dir, play):
    """Simulate the composed shot live in the browser: push objects with the mouse, change fields,
    materials and gravity from the panel, keep the take (sim.usdc) or the settings (edits.usda).

    \b
    In the page: a left-drag that starts on an object pulls it toward the cursor (a spring-damper);
    a drag on empty space orbits the view and "Photo view" brings back the photo's camera. "Save take"
    writes the motion since the last reset to sim.usdc as `simulate` would; "Keep settings" adds the
    changed parameters to edits.usda, keeping everything already there. Nothing is written unless asked.
    The rate (frames a second) is printed on stderr every few seconds and shown on the page.

    \b
    Examples:
      physomni-usd preview shot/shot.usda
      physomni-usd preview shot/shot.usda --port 8090 --duration 20 --record
      physomni-usd preview photo.png -o shot/     (a photo: the set-up page, as `studio`)

    \b
    Limits: rigid bodies are pulled by the mouse; cloth, soft bodies and MPM materials move live but
    are not grabbed. A take keeps at most 3600 frames.
    """
    with _errors():
        if shot.suffix.lower() in PHOTO_SUFFIXES:  # a photo: set the shot up first, on the studio's page
            from .errors import InputError
            from .studio import Options as StudioOptions, Studio

            if out_dir is None:
                raise InputError(f"{shot} is a photo, not a shot: name the folder to build it into with -o, e.g. "
                                 f"physomni-usd preview {shot} -o shot/ (the same as physomni-usd studio)")
            page = Studio(shot, out_dir, StudioOptions(host=host, port=port, duration=duration,
                                                       open_browser=open_browser))
            page.start()
            page.wait()
            return
        from .preview.app import Options, Preview

        options = Options(host=host, port=port, duration=duration, record=record, open_browser=open_browser,
                          play=play)
        session = Preview(shot, options)
        session.start()
        result = session.run()
        click.echo(f"preview: stopped after {result['frames']} frames", err=True)


@main.command()
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder the page builds into (created at the first Build).")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to serve the page on. On any but a loopback address the printed URL carries a "
                   "per-run token, without which every request is refused.")
@click.option("--port", type=click.IntRange(1, 65534), default=8070, show_default=True,
              help="Port of the page; the live preview takes the next one.")
@click.option("--segmenter", default="grabcut", show_default=True, metavar="NAME",
              help="What cuts the masks as you pick (see `physomni-usd plugins`; sam takes clicks natively).")
@click.option("--duration", type=click.FloatRange(0, 86400, min_open=True), default=None, metavar="SECONDS",
              help="Quit after this many seconds (for scripts) [default: run until Ctrl-C].")
@click.option("--open/--no-open", "open_browser", default=None,
              help="Open the page in a web browser [default: where one is available].")
def studio(photo, out_dir, host, port, segmenter, duration, open_browser):
    """Set up a shot in the browser: pick objects on the photo, push them, build, preview and render.

    \b
    In the page: drag a box around an object and type its label; its mask shows at once (GrabCut, or
    the segmenter chosen). "Click on object (+)" and "Click off object (−)" correct the selected mask;
    ↑ ↓ reorder and ✕ deletes. "Push arrow": drag from an object's mask (where masks overlap, the
    smallest object's); a quarter of the photo's width is 1 m/s, right is +X, up is +Y (away from the
    camera); each push shows on its object and in the list, where it is edited or removed alone.
    Choose a force field and a camera move from the lists. "Build" builds the shot and shows its live
    preview, paused on frame 0; "Render" simulates the video length the page shows (default: the
    shot's own, 3 s for a shot never simulated), writes video.mp4 and shows it. Each stage and frame
    shows in the page as it happens.

    \b
    Everything is written beside the shot: studio.json (what the page holds, and its command lines)
    and studio.sh (the same as `physomni-usd build ... --box X0,Y0,X1,Y1:LABEL:+X,Y:-X,Y ...`), so a
    TD can batch what was set up here. Opening the page again on the same folder resumes it.
    Only the page itself can drive the studio: a request from another site's page, or by another
    name than a loopback one (or, served beyond loopback with --host, without its token), is refused.

    \b
    Example:
      physomni-usd studio photo.png -o shot/
    """
    with _errors():
        from .studio import Options, Studio

        page = Studio(photo, out_dir, Options(host=host, port=port, duration=duration, open_browser=open_browser),
                      segmenter=segmenter)
        page.start()
        page.wait()
        click.echo("studio: stopped", err=True)


@main.command()
@click.argument("stage", type=click.Path(path_type=pathlib.Path))
@click.option("--warnings/--no-warnings", default=True, show_default=True, help="Also print warnings.")
def validate(stage, warnings):
    """Check a stage with every pxr.UsdValidation validator and our USD contract.

    Prints one finding per line; exits 1 if any is an error.
    """
    with _errors():
        from .validate import validate_stage

        findings = validate_stage(stage)
        errors = [f for f in findings if f.severity == "error"]
        for f in findings:
            if f.severity == "error" or warnings:
                click.echo(str(f))
        click.echo(f"{stage}: {len(errors)} error(s), {len(findings) - len(errors)} warning(s)", err=True)
        if errors:
            sys.exit(1)


EPILOG_BATCH = """
\b
SHOTS, one `physomni-usd run` argument list per line (paths relative to SHOTS):
  # shots.txt
  cup/photo.png -o out/cup --mask cup/cup.png:cup --push cup=0.5,0,0
  'bike shed/photo.png' -o out/bike --mask 'bike shed/bike.png' --seconds 2
or a YAML (.yaml, .yml) or JSON (.json) list of such lines or of mappings:
  - {photo: cup/photo.png, output: out/cup, mask: [cup/cup.png:cup], push: cup=0.5,0,0}

\b
Examples:
  physomni-usd batch shots.txt --summary out/summary.json
  physomni-usd batch shots.txt --address 10.0.0.5:6379 --gpus-per-shot 0.25
\b
A shot whose folder holds a finished run of the same inputs (photo, mask and
mesh bytes, options, version; a hash in report.json) is skipped unless --force.
Each attempt's output goes to DIR/batch.log. Exit codes: 0 every shot ok or
skipped, 1 some shot failed, 2 a bad shot list (the line is named). On a cluster
every node must see SHOTS' folder and the outputs at the same paths (shared
storage), or give --upload; every node needs physomni-usd installed.
"""


def _run_parser(args: list[str]) -> dict:
    """``run``'s own option parser on one shot's arguments (nothing runs)."""
    from .errors import InputError

    try:
        return run.make_context("run", args).params
    except click.ClickException as exc:
        raise InputError(exc.format_message()) from None


@main.command(epilog=EPILOG_BATCH)
@click.argument("shots", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("--address", envvar="RAY_ADDRESS", default=None, metavar="HOST:PORT",
              help="Ray cluster to run on [env: RAY_ADDRESS; default: start Ray on this machine with its CPUs].")
@click.option("--workers", type=click.IntRange(1), default=None,
              help="At most this many shots at once [default: as many as the CPUs (GPUs) allow].")
@click.option("--retries", type=click.IntRange(0, 20), default=2, show_default=True,
              help="Attempts after the first for a shot that crashed, was killed or whose stage failed "
                   "(never for bad input).")
@click.option("--force", is_flag=True, help="Run finished shots again.")
@click.option("--summary", "summary_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Write a JSON summary here (one entry per shot: output, status, seconds, attempts, node, "
                   "reason); updated as shots finish.")
@click.option("--cpus-per-shot", type=click.FloatRange(0, min_open=True), default=1.0, show_default=True,
              help="CPUs Ray reserves for each shot.")
@click.option("--gpus-per-shot", type=click.FloatRange(0), default=0.0, show_default=True,
              help="GPUs Ray reserves for each shot (0.25: four shots share one); Ray sets CUDA_VISIBLE_DEVICES "
                   "to the reserved ones. Give at least a fraction to run shots on GPUs.")
@click.option("--upload", is_flag=True,
              help="Send each shot's input files with its task and its output folder back, through Ray's "
                   "object store: for a cluster whose nodes do not share storage with this machine.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors and the final line.")
def batch(shots, address, workers, retries, force, summary_path, cpus_per_shot, gpus_per_shot, upload, quiet):
    """Run many shots (each a `physomni-usd run`) as Ray tasks; resumable, one failure never stops the rest."""
    with _errors():
        from .errors import InputError

        try:
            import ray  # noqa: F401
        except ImportError:
            raise InputError("batch needs Ray: pip install 'physomni-usd[batch]'") from None
        from .batch.progress import Progress
        from .batch.runner import Quiet, run_batch
        from .batch.shots import read_shot_list

        if summary_path is not None and not summary_path.parent.resolve().is_dir():
            raise InputError(f"--summary {summary_path}: folder {summary_path.parent} does not exist")
        shot_list = read_shot_list(shots, _run_parser)
        summary = run_batch(shot_list, address=address, workers=workers, retries=retries, force=force,
                            cpus_per_shot=cpus_per_shot, gpus_per_shot=gpus_per_shot,
                            progress=Quiet() if quiet else Progress(), summary_path=summary_path,
                            upload=run if upload else None, call=_run_arguments)
        click.echo(f"batch: {summary['ok']} ok, {summary['skipped']} skipped, {summary['failed']} failed "
                   f"in {summary['seconds']:.1f} s" + (f"; summary: {summary_path}" if summary_path else ""),
                   err=True)
        if summary["failed"]:
            sys.exit(1)


@main.group()
def bench():
    """Benchmarks: each prints a table and can write the same numbers as JSON."""


@bench.command("pipeline")
@click.option("--example", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("examples/motorcycle"), show_default=True,
              help="Example folder with example.json, a photo and its masks.")
@click.option("--size", type=click.IntRange(64, 8192), default=880, show_default=True,
              help="Longer side of the photo, pixels.")
@click.option("--repeats", type=click.IntRange(1, 50), default=3, show_default=True, help="Builds to time.")
@click.option("--seconds", type=float, default=2.0, show_default=True,
              help=_range_help("Simulated seconds in the run.", SimulateSettings, "seconds"))
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_pipeline_command(example, size, repeats, seconds, json_path):
    """Wall time of build and of a whole run on a bundled example (run twice for warm kernel caches)."""
    with _errors():
        from .bench.pipeline import bench_pipeline

        numbers = bench_pipeline(example, size=size, repeats=repeats, seconds=seconds, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("render")
@click.option("--example", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("examples/motorcycle"), show_default=True,
              help="Example folder with example.json, a photo and its masks.")
@click.option("--size", type=click.IntRange(64, 4096), default=880, show_default=True,
              help="Longer side of the photo and of the frames, pixels.")
@click.option("--seconds", type=click.FloatRange(0.1, 30), default=1.0, show_default=True,
              help="Simulated (and rendered) seconds.")
@click.option("--quick", is_flag=True, help="Render 0.3 s (10 frames) instead of --seconds.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_render_command(example, size, seconds, quick, json_path):
    """Frames per second of render on a bundled example: plain, and with every control pass (EXR + previews).

    \b
    Static camera (the photo's), the example's push simulated first. Example:
      physomni-usd bench render --quick --json out/render.json
    """
    with _errors():
        from .bench.render import bench_render

        numbers = bench_render(example, size=size, seconds=0.3 if quick else seconds, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("batch")
@click.option("--example", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("examples/motorcycle"), show_default=True,
              help="Example folder with example.json, a photo and its masks; every shot is this one.")
@click.option("--counts", default="1,2,4,8", show_default=True, metavar="N,N,...",
              help="Numbers of shots to time.")
@click.option("--size", type=click.IntRange(64, 4096), default=320, show_default=True,
              help="Longer side of the photo, pixels.")
@click.option("--seconds", type=click.FloatRange(0.1, 30), default=1.0, show_default=True,
              help="Simulated seconds per shot.")
@click.option("--fps", type=click.FloatRange(1, 120), default=30.0, show_default=True, help="Frames per second.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_batch_command(example, counts, size, seconds, fps, json_path):
    """Wall time and shots per hour of `batch` (local Ray) against `run` one after another.

    \b
    Needs the [batch] extra. N shots take about N small runs twice over, plus
    Ray's start-up once per N (minutes on a 2-core CPU).
    Example:
      physomni-usd bench batch --counts 1,2 --json out/batch.json
    """
    with _errors():
        from .errors import InputError

        try:
            import ray  # noqa: F401
        except ImportError:
            raise InputError("bench batch needs Ray: pip install 'physomni-usd[batch]'") from None
        try:
            numbers = [int(c) for c in counts.split(",")]
        except ValueError:
            raise InputError(f"--counts {counts!r}: expected whole numbers separated by commas") from None
        if not numbers or min(numbers) < 1 or max(numbers) > 64:
            raise InputError(f"--counts {counts!r}: each count must be 1 to 64")
        from .bench.batch import bench_batch

        result = bench_batch(example, numbers, size=size, seconds=seconds, fps=fps, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, result)


@bench.command("plate")
@click.option("--quick", is_flag=True, help="Two hole shapes per surface instead of five.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
def bench_plate_command(quick, json_path):
    """The background plate's fill on real photos of empty surfaces with object-shaped holes.

    \b
    Surfaces from scikit-image's bundled photos (brick, grass, gravel, a wooden table, a garage floor;
    needs the test extra: pip install 'physomni-usd[test]'); holes shaped like a cup, a saucer, a pencil,
    a bottle and a chair. For the exemplar (shift-map) fill that build uses and for OpenCV Telea: gradient
    ratio inside/around the hole (1 keeps the grain, a smear is far below 1), local colour difference
    (levels), SSIM inside the hole and seconds.

    \b
    Example:
      physomni-usd bench plate --quick --json out/plate.json
    """
    with _errors():
        try:
            import skimage  # noqa: F401
        except ImportError:
            _fail("bench plate: scikit-image is not installed (pip install 'physomni-usd[test]')", 2)
        from .bench.plate import bench_plate

        numbers = bench_plate(quick=quick, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("scale")
@click.option("--example", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("examples/motorcycle"), show_default=True,
              help="Example folder (with example.json) to scale.")
@click.option("--sizes", default="0.3,1,4,12,40", show_default=True, metavar="MP,MP,...",
              help="Megapixels of the photos; 0 is the example as it is.")
@click.option("--repeats", type=click.IntRange(1, 20), default=1, show_default=True,
              help="Rounds over the sizes, alternating (medians are reported).")
@click.option("--stages", default="build,simulate,render", show_default=True, help="Which stages to run.")
@click.option("--seconds", type=float, default=3.0, show_default=True, help="Simulated seconds.")
@click.option("--max-size", type=int, default=1920, show_default=True, help="render --max-size.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_scale_command(example, sizes, repeats, stages, seconds, max_size, json_path):
    """Each stage's wall time, CPU time and peak memory on one example scaled to each photo size, as ratios to
    the smallest; each stage a fresh process, the sizes alternating so that they share the load.

    \b
    Example:
      physomni-usd bench scale --sizes 0,12 --repeats 3 --json out/scale.json
    """
    with _errors():
        from .bench.scale import bench_scale
        from .errors import InputError

        folder = example
        if not (folder / "example.json").is_file():
            raise InputError(f"--example {example!r}: no example.json in {folder}")
        try:
            mps = tuple(float(x) for x in sizes.split(","))
        except ValueError:
            raise InputError(f"--sizes {sizes!r}: expected megapixels separated by commas") from None
        numbers = bench_scale(folder, mps, repeats, seconds, tuple(s.strip() for s in stages.split(",")),
                              max_size, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("look")
@click.option("--example", "examples", type=click.Path(file_okay=False, path_type=pathlib.Path), multiple=True,
              help="Example folder with example.json (repeatable) [default: every folder of examples/].")
@click.option("-o", "--output", "out_dir", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("out/look"), show_default=True, help="Folder for the sheets and look.json.")
@click.option("--size", type=click.IntRange(64, 4096), default=880, show_default=True,
              help="Longer side of the rendered frames, pixels.")
@click.option("--seconds", type=click.FloatRange(0.1, 30), default=None,
              help="Simulated seconds [default: each example's own].")
@click.option("--no-browser", is_flag=True, help="Leave out the preview's opening view (no Chromium needed).")
def bench_look_command(examples, out_dir, size, seconds, no_browser):
    """A contact sheet per bundled example and the figures of what is left where objects stood.

    \b
    Sheet: the photo, frames 0, middle and last, the last frame under --camera orbit-left, and the
    preview's opening view in headless Chromium. Figures, on the last frame without the moved objects'
    new contact shadows, for each revealed area against a ring around it: gradient ratio (target
    0.6-1.6), border gradient ratio (<= 1.3), colour difference against the ring's colour near each
    pixel of the area (<= 8 levels); in brackets, the frame as shown (gradient, border, and colour
    against the ring's plain mean); frame 0's PSNR against the photo; the opening view's SSIM.

    \b
    Example:
      physomni-usd bench look --example examples/desk -o out/look
    """
    with _errors():
        from .bench.look import bench_look

        chosen = list(examples) or sorted(p.parent for p in pathlib.Path("examples").glob("*/example.json"))
        if not chosen:
            _fail("bench look: no --example given and no examples/*/example.json here", 2)
        bench_look(chosen, out_dir, size=size, seconds=seconds, browser=not no_browser, echo=click.echo)


@bench.command("alignment")
@click.option("--quick", is_flag=True, help="Smaller images and fewer scenes (a few minutes on a CPU).")
@click.option("--only", type=click.Choice(["all", "ablation", "stacks"]), default="all", show_default=True,
              help="The paper's ablation tables, the stacked scenes, or both.")
@click.option("--stack", "stacks", multiple=True, metavar="NAME",
              help="Run only this stacked scene (cup_saucer_spoon, three_boxes, bowl_of_spheres, tray_of_parts); "
                   "repeatable [default: all four].")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
def bench_alignment_command(quick, only, stacks, json_path):
    """The paper's alignment ablations on synthetic scenes with known truth (scene and camera tables), and
    stacked scenes with truth (a cup on its saucer with a spoon, three boxes stacked, a bowl of balls, a
    tray of identical parts from straight above) built as a user's photo would be and simulated 2 s with
    nothing pushed: per object, mask IoU from the photo's view and orbited ±45°, position error over the
    camera distance, size error and rest drift, each against the holistic targets (STACK_LIMITS in
    physomni_usd/bench/alignment.py).

    \b
    Example:
      physomni-usd bench alignment --only stacks --stack cup_saucer_spoon --json out/stacks.json
    """
    with _errors():
        from .bench.alignment import bench_alignment, write_json
        from .bench.synthetic import STACKS
        from .errors import InputError

        unknown = sorted(set(stacks) - set(STACKS))
        if unknown:
            raise InputError(f"--stack {unknown[0]!r}: no such stacked scene (known: {', '.join(STACKS)})")
        numbers = bench_alignment(quick=quick, echo=click.echo, only=only, stacks=stacks or None)
        if json_path:
            write_json(numbers, json_path)


@bench.command("photos")
@click.option("--pitch", "pitches", type=click.FloatRange(0, 89.5), multiple=True,
              help="Camera pitch of a synthetic scene, degrees; repeatable [default: 5, 30, 60 and 85].")
@click.option("--seconds", type=click.FloatRange(0, 60), default=0.5, show_default=True,
              help="Simulated seconds of each run (0: build only).")
@click.option("--real", "real", multiple=True, metavar="NAME",
              help="Run only this real photo (desk, smarties, coffee, motorcycle, football, rubberwhale, fruits, "
                   "heap, parts); repeatable [default: all nine].")
@click.option("--only", type=click.Choice(["all", "synthetic", "real"]), default="all", show_default=True,
              help="Which half of the bench to run.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
def bench_photos_command(pitches, seconds, real, only, json_path):
    """Photos with known truth through the built-in path: camera, scale, lifting, frame 0 and a short run.

    \b
    Synthetic scenes (a box, a can, a plate and a bottle of typical sizes on a checkered floor) under a
    known camera at each pitch; prints pitch error, field-of-view error, position and height errors after
    the scale, size error, the scale's source, frame-0 SSIM, seconds and whether the run finished.
    Acceptance: pitch within 5°, field of view within 10 %, positions within 5 % of the camera distance,
    heights within 15 %.

    \b
    Real photos that packages ship (OpenCV's samples, scikit-image's data): a desk from above, sweets from
    steeply above, an espresso cup on its saucer, a motorcycle in a garage, a football on grass and a
    rubber whale on a cloth, a close-up pile of fruit, boxes and a bag heaped on a chair, and six identical
    parts on a lightbox from above, with a pitch and sizes measured by hand (physomni_usd/bench/real/photos.json
    says how). Prints the pitch error, each object's longest dimension over its real one, the scale's source,
    frame-0 SSIM, seconds, whether a --seconds run finished (nothing pushed) and how far its rigid objects
    moved. Acceptance: every object within a factor 1.5 of its real size.

    \b
    Example:
      physomni-usd bench photos --pitch 30 --pitch 85 --json out/photos.json
      physomni-usd bench photos --only real --real desk --seconds 2
    """
    with _errors():
        import json

        from .bench.photos import PITCHES, bench_photos
        from .bench.real_photos import bench_real_photos, load_truth
        from .errors import InputError

        truth = load_truth()
        unknown = sorted(set(real) - set(truth))
        if unknown:
            raise InputError(f"--real {unknown[0]!r}: no such photo (known: {', '.join(truth)})")
        wanted = [truth[n] for n in (real or truth)] if only in ("all", "real") else []
        if any(r["photo"].startswith("skimage:") for r in wanted):
            try:
                import skimage  # noqa: F401
            except ImportError:
                _fail("bench photos: scikit-image is not installed, and the coffee and motorcycle photos come "
                      "with it (pip install 'physomni-usd[test]', or --only synthetic)", 2)
        numbers = {}
        if only in ("all", "synthetic") and not real:
            numbers = bench_photos(pitches or PITCHES, seconds=seconds, echo=click.echo)
        if only in ("all", "real"):
            numbers["real"] = bench_real_photos(real or None, seconds=seconds, echo=click.echo)
        if json_path:
            from ._files import write_bytes

            write_bytes(json_path, (json.dumps(numbers, indent=2, default=float) + "\n").encode())


@bench.command("general")
@click.option("--n", "n", type=click.IntRange(1, 1000), default=10, show_default=True,
              help="How many scenes to generate and build.")
@click.option("--seed", type=click.IntRange(0, 10**9), default=None,
              help="Seed of the run (scene i is drawn from seed × 1000 + i) [default: a new one, printed].")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=pathlib.Path), default=None,
              help="Keep every scene (photo, masks, truth.json), its two shots, general.json and general.md here "
                   "[default: a temporary folder, removed at the end].")
@click.option("--seconds", type=click.FloatRange(0.1, 60), default=2.0, show_default=True,
              help="Simulated seconds with nothing pushed.")
@click.option("--only", type=click.Choice(["both", "masks", "boxes"]), default="both", show_default=True,
              help="Build each scene from its visible masks, from their bounding boxes, or both.")
@click.option("--materials", type=click.IntRange(0, 100), default=0, show_default=True,
              help="Per scene, this many objects (drawn from the scene's seed) switched in turn to mpm_elastic, "
                   "mpm_sand and pbd_cloth on the first build, each simulated 1 s: no stop, nothing non-finite "
                   "(minutes per object on a CPU).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_general_command(n, seed, out_dir, seconds, only, materials, json_path):
    """Scenes generated fresh, rendered with Blender's Cycles, each built as a user's photo would be.

    \b
    Every run draws new scenes (without --seed a new seed is drawn and printed): objects of many kinds
    (boxes, books, cups, bowls, bottles, fruit, coins and cards, toys, a plant in its pot) alone, stacked,
    piled, in a bowl, on a shelf or hung on a wall, on wood, cloth, paper, a printed board or tiles, under a
    camera at a pitch of 0-90° and a field of view of 25-80°, 320x240 px, 24 samples (5-30 s a render on
    2 cores). The truth: each object's visible mask (an object-id render) and whole outline, the camera,
    every mesh. Each scene is built with labels from its visible masks and from their bounding boxes.

    \b
    Invariants, per scene: build exits 0, simulate does not refuse, no start overlap over 2 mm, and with
    nothing pushed nothing moves over 1 cm or turns over 5° in --seconds. Truth, per object: IoU of the
    built mesh against the visible mask and the whole outline from the photo's view (>= 0.85) and against
    the truth from the camera orbited ±45° (>= 0.7), position error (after the one scale a photo cannot
    show) over the camera distance (<= 5 %), longest dimension within 1.5x; per scene pitch within 10°.
    With --materials K, K objects of each scene also simulate 1 s as each of mpm_elastic, mpm_sand and
    pbd_cloth without a stop or a non-finite value. Prints a row per scene and build, then the pass rates
    (Markdown).

    \b
    Needs Blender's Python module (bpy==5.0.1 pins numpy<2): install it in an environment of its own and
    set PHYSOMNI_BLENDER_PYTHON to that environment's python.

    \b
    Example:
      physomni-usd bench general --n 10 -o out/general
      physomni-usd bench general --n 3 --seed 4242 --only masks
    """
    with _errors():
        import json

        from .bench.general import MODES, NoBlender, bench_general, markdown

        try:
            numbers = bench_general(n, seed, out_dir, MODES if only == "both" else (only,), seconds,
                                    echo=click.echo, materials=materials)
        except NoBlender as exc:
            _fail(str(exc), 2)
        from ._files import write_bytes

        text = (json.dumps(numbers, indent=2, default=float) + "\n").encode()
        for path in [json_path] + ([out_dir / "general.json"] if out_dir else []):
            if path:
                write_bytes(path, text)
        if out_dir:
            write_bytes(out_dir / "general.md", markdown(numbers).encode())


@bench.command("physics")
@click.option("--quick", is_flag=True, help="Fewer settings, one repeat, a smaller matrix (a few minutes).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
@click.option("--plots", "plots_dir", type=click.Path(file_okay=False, path_type=pathlib.Path), default=None,
              help="Write error-against-time plots (PNG, needs matplotlib) to this folder.")
@click.option("--markdown", "md_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Write the tables as Markdown, dated and with the machine, to this file: a new file, or "
                   "one whose '<!-- bench physics: ... -->' and '<!-- /bench physics -->' lines mark the part "
                   "to replace (any other file is refused).")
def bench_physics_command(quick, json_path, plots_dir, md_path):
    """Error against run time of Newton's solvers, and the stiff and extreme matrix.

    \b
    Rigid cases (free fall, drag, incline, restitution, stack, rotation) on XPBD, MuJoCo (if
    installed), Featherstone and semi-implicit; cloth sag, an elastic bar, a dam break and a granular
    column on cloth and MPM; then the matrix (E from 1e3 to 1e9 Pa, densities, a 1:1000 stack,
    50 m/s at a 5 mm wall, a 1 mm cube, 1e4 N on 10 g) through `simulate` and its guard, a
    100,000-particle memory probe and the cost of ten objects at the simulator's defaults.

    \b
    Example:
      physomni-usd bench physics --quick --plots out/plots --json out/physics.json
    """
    with _errors():
        from .bench.markdown import check_markdown_target
        from .bench.physics import bench_physics, write_plots
        from .bench.plots import check_plots_possible

        if md_path:
            check_markdown_target(md_path)
        if plots_dir:
            check_plots_possible()
        numbers = bench_physics(quick=quick, echo=click.echo)
        if plots_dir:
            written = write_plots(numbers, plots_dir)
            click.echo(f"plots: {len(written)} written to {plots_dir}", err=True)
        from ._files import write_bytes, write_json

        if json_path:
            write_json(json_path, numbers)
        if md_path:
            from .bench.physics import markdown, splice_markdown

            text = markdown(numbers)
            if md_path.is_file():
                text = splice_markdown(md_path.read_text(), text)
            write_bytes(md_path, text.encode())


@bench.command("preview")
@click.option("--quick", is_flag=True, help="1 and 20 objects only, shorter runs (about two minutes).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_preview_command(quick, json_path):
    """Frames per second of the live preview, and the step against Genesis.

    \b
    Prints, in one run: the preview loop's rate (step, read back, publish; unpaced) for 1, 5, 10 and
    20 rigid boxes with a headless chromium attached where one is installed (/usr/bin/chromium and
    playwright), the same for 20 boxes without the graph capture; for ten boxes dropped and ten at rest,
    simulate's stepping, the whole simulate call (the first in a process, repeated ones, and a new shot
    in the same process, as each shot of a batch after its first) and the `physomni-usd simulate`
    command, each as a multiple of its stepping (target: the call within 3×), with the load average;
    and `bench peer`'s ten boxes at rest against Genesis when genesis-world is installed (pip install
    'physomni-usd[peer]'; target: ours ≥ 1.5× Genesis). Each measurement runs in a fresh interpreter.

    \b
    Example:
      physomni-usd bench preview --json out/preview.json
    """
    with _errors():
        from .bench.preview import bench_preview

        numbers = bench_preview(quick=quick, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("peer")
@click.option("--only", "only", multiple=True, type=click.Choice(["boxes_at_rest", "box_pile", "sand_column"]),
              help="Run only this case (repeatable).")
@click.option("--repeats", type=click.IntRange(1, 20), default=3, show_default=True,
              help="Timed runs of each engine per case, alternating.")
@click.option("--seconds", type=click.FloatRange(0.1, 20.0), default=2.0, show_default=True,
              help="Simulated seconds a run.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_peer_command(only, repeats, seconds, json_path):
    """The simulator against Genesis 1.4.5, in one process, case by case.

    \b
    Cases: ten boxes at rest on the ground; twenty boxes dropped in shifted layers so that they
    collide and topple; a 0.1 × 0.1 × 0.2 m sand column on both engines' MPM at the same particle
    spacing. Timed: ours is simulate_shot's stepping (the guarded loop with its checks and recording,
    what `simulate` runs, reported as seconds.step); Genesis's is scene.step() over the same frames at
    the same fps and substeps (for the sand: ours at its implicit MPM's steps a frame, Genesis's explicit
    MPM at the substep it suggests, 0.02 s per metre of particle spacing).
    Each engine's model build, kernel compiling and first run are left out alike. Prints, per case,
    Genesis's time over ours, min / median / max over the runs (> 1: ours is faster).

    \b
    Genesis pins its own pillow: install it in an environment of its own (pip install torch==2.13.0
    'physomni-usd[peer]'). Without it the command says so and exits 0 having run nothing. The first
    run compiles Genesis's kernels (minutes).

    \b
    Example:
      physomni-usd bench peer --only boxes_at_rest --json out/peer.json
    """
    with _errors():
        from .bench.peer import bench_peer

        numbers = bench_peer(only=only, repeats=repeats, seconds=seconds, echo=click.echo)
        if json_path and numbers.get("genesis"):
            from ._files import write_json

            write_json(json_path, numbers)


@bench.command("faults")
@click.option("--only", "only", multiple=True, metavar="CASE",
              help="Run only this case (repeatable); the cases are the rows the command prints.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the matrix to this JSON file.")
def bench_faults_command(only, json_path):
    """The reliability matrix: signals, kills, a photo bomb, two writers, NaNs, another origin, secrets, a
    full disk, each against a tiny shot through the CLI; one row per case with trials tried and clean.

    \b
    Example:
      physomni-usd bench faults --only "photo bomb"
    """
    with _errors():
        from .bench.faults import CASES, bench_faults
        from .errors import InputError

        unknown = [c for c in only if c not in CASES]
        if unknown:
            raise InputError(f"--only {unknown[0]!r}: not a case; one of {', '.join(CASES)}")
        rows = bench_faults(only=only, echo=click.echo)
        if json_path:
            from ._files import write_json

            write_json(json_path, rows)
        if any(r["clean"] < r["tried"] for r in rows.values()):
            sys.exit(1)


@main.command("plugins")
def plugins_command():
    """List every backend by kind: built in or from a plugin, its package and version, and its state.

    \b
    States: "ready" — it runs here as it is (modules installed, weights found);
    "needs setting up" — it runs once the variables or options named are given
    (the vlm estimator without a server); "not ready" — what to install or set.

    \b
    Plugins are packages that register under the entry-point group physomni_usd.backends; install one
    and point it at its weights, e.g.
      pip install -e plugins/physomni-lama && export PHYSOMNI_LAMA_WEIGHTS=/models/big-lama.pt
      physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --inpainter lama
    """
    with _errors():
        from .errors import redact
        from .swappable import registry

        entries = registry.entries()
        for kind in registry.KINDS:
            click.echo(f"{kind}:")
            found = [e for e in entries if e.kind == kind]
            if not found:
                hint = registry.SUGGESTED.get(kind)
                click.echo("  (none installed" + (f"; plugin: {hint})" if hint else ")"))
            for e in found:
                ready, note = registry.status(e)
                default = " (default)" if registry.DEFAULTS.get(kind) == e.name else ""
                origin = "built-in" if e.builtin else "plugin"
                # a backend that can run but waits for a setting (a server's address) is not "ready"
                state = "not ready" if not ready else ("needs setting up" if note.startswith("needs ") else "ready")
                note = note[len("needs "):] if state == "needs setting up" else note
                click.echo(redact(f"  {e.name}{default}: {origin}, {e.package} {e.version}, {state}"
                           + (f": {note}" if note else "")))


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--model", default=None, metavar="NAME",
              help="Re-renderer backend, e.g. wan-vace (plugin physomni-wan) [default: the one installed].")
@click.option("--strength", type=float, default=0.6, show_default=True,
              help="Share of the denoising run, in (0, 1]: low keeps the rendered frames, 1 starts from noise.")
@click.option("--steps", type=click.IntRange(1, 1000), default=20, show_default=True,
              help="Denoising steps actually run.")
@click.option("--prompt", default=None, help="Text prompt [default: made from the objects' labels].")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed of the noise.")
@click.option("--max-size", type=click.IntRange(16, 8192), default=832, show_default=True,
              help="Longest side of the frames given to the model, pixels.")
@click.option("-o", "--output", type=click.Path(path_type=pathlib.Path), default=None,
              help="Video file (.mp4) [default: rerender.mp4 beside the shot].")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def rerender(shot, model, strength, steps, prompt, seed, max_size, output, quiet):
    """Render the shot, then re-render its frames with a video model, the photo as reference.

    The renderer's control passes of each frame (depth, object ids, forward motion; see render --passes) go
    to the model with the frames; the objects' pixels are its masks. Needs a re-renderer plugin; without one
    this says which to install and exits 2.

    \b
    Example (Wan VACE; weights: a diffusers WanVACEPipeline folder):
      pip install -e plugins/physomni-wan && export PHYSOMNI_WAN_WEIGHTS=/models/Wan2.1-VACE-1.3B-diffusers
      physomni-usd rerender shot/shot.usda --model wan-vace --strength 0.5 --steps 20 -o shot/wan.mp4
    """
    with _errors():
        from .rerender import rerender_shot

        with _progress("render  ", not quiet) as bar:
            section = rerender_shot(shot, model, strength, steps, output, prompt, seed, max_size, progress=bar)
        if not quiet:
            click.echo(f"rerender: {section['video']} ({section['frames']} frames, "
                       f"{section['width']}×{section['height']}, {section['seconds']['model']:.1f} s in the model)",
                       err=True)


if __name__ == "__main__":  # pragma: no cover
    main()
