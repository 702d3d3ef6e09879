"""The ``physomni-usd`` command: one subcommand per stage, plus ``run`` and ``validate``.

Exit codes: 0 success, 1 a stage failed or validation found errors,
2 bad input or usage, 3 an internal error (a bug: please report it).
"""

from __future__ import annotations

import os
import pathlib
import sys
import time
from contextlib import contextmanager

import click
from pydantic import ValidationError

from .errors import PhysOmniError

EPILOG_BUILD = """
\b
Examples:
  physomni-usd build photo.png -o shot/ --mask cup.png:cup --mask saucer.png
  physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --fov 60
"""


def _fail(message: str, code: int) -> None:
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


@contextmanager
def _errors():
    """Turn our exceptions and pydantic's into one line and an exit code."""
    try:
        yield
    except PhysOmniError as exc:
        _fail(str(exc), exc.exit_code)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(x) for x in first.get("loc", ()))
        _fail(f"{where}: {first.get('msg')}", 2)
    except KeyboardInterrupt:
        _fail("interrupted; files already written are complete, the one in progress was not written", 130)
    except Exception as exc:  # a bug, not bad input
        if os.environ.get("PHYSOMNI_DEBUG"):
            raise
        _fail(f"internal error: {type(exc).__name__}: {exc} (set PHYSOMNI_DEBUG=1 for the traceback)", 3)


@contextmanager
def _progress(label: str, enabled: bool = True):
    """A click progress bar on stderr; yields a callback ``(done, total)``."""
    state = {"bar": None, "done": 0}

    def update(done, total):
        if not enabled:
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


def _say(quiet: bool):
    return (lambda msg: None) if quiet else (lambda msg: click.echo(msg, err=True))


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="physomni-usd")
def main():
    """Turn one photograph into a physically simulated, layered USD shot and a video.

    \b
    A shot folder holds one layer per stage under a root shot.usda:
      shot.usda = [edits.usda, sim.usdc, physics.usda, scene.usda]  (strongest first)
    edits.usda is yours: it is created empty, no command rewrites it (only
    `estimate --set` adds your values to it), and what you author there (a
    heavier object, a push, a moved prop) counts in the next `simulate`.

    \b
    Quick start:
      physomni-usd run photo.png -o shot/ --mask cup.png:cup --push cup=0.5,0,0
      physomni-usd validate shot/shot.usda
    """


def build_options(f):
    opts = [
        click.option("--mask", "masks", multiple=True, metavar="PNG[:LABEL]",
                     help="Object mask at the photo's resolution; non-zero pixels are the object. "
                          "Repeat per object; LABEL defaults to the file's name."),
        click.option("--box", "boxes", multiple=True, metavar="X0,Y0,X1,Y1[:LABEL]",
                     help="Pixel box around an object; OpenCV GrabCut cuts its mask. Repeatable."),
        click.option("--meshes", "meshes_dir", type=click.Path(file_okay=False, path_type=pathlib.Path),
                     default=None, help="Folder with one mesh per object (OBJ, GLB, PLY) and poses.json "
                                        "(label → mesh, rotation_wxyz, translation, scale in OpenCV camera "
                                        "coordinates); replaces silhouette lifting."),
        click.option("--fov", type=float, default=50.0, show_default=True,
                     help="Vertical field of view of the photo in degrees."),
        click.option("--pitch", type=float, default=None,
                     help="Downward camera tilt in degrees [default: smallest ≥ 10° that puts every "
                          "object's foot below the horizon]."),
        click.option("--camera-height", type=float, default=1.0, show_default=True,
                     help="Camera height above the ground in metres; sets the scene's scale."),
        click.option("--shape", type=click.Choice(["auto", "round", "extrude"]), default="auto", show_default=True,
                     help="How silhouettes become meshes: surface of revolution, extrusion, or by symmetry."),
        click.option("--fps", type=float, default=30.0, show_default=True, help="Frames per second of the shot."),
        click.option("--fix", "fixed", multiple=True, metavar="LABEL",
                     help="Keep this object where it is (it still collides). Repeatable."),
        click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
                     help="A force field (constant, wind, point, drag, vortex, turbulence, noise), e.g. "
                          "'wind:direction=1,0,0,strength=30'. Accelerations in m/s²; times in seconds. Repeatable."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def backend_options(f):
    """--segmenter/--inpainter/--lifter/--depth/--estimator, passed on as one ``backends`` dict."""
    import functools

    kinds = {"segmenter": "How --box becomes a mask [default: grabcut; plugin: sam].",
             "inpainter": "What fills the objects' holes in the plate [default: builtin; plugin: lama].",
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


def _build_settings(fov, pitch, camera_height, shape, fps):
    from .settings import BuildSettings, CameraSettings, LiftSettings

    return BuildSettings(camera=CameraSettings(fov_deg=fov, pitch_deg=pitch, height_m=camera_height),
                         lift=LiftSettings(shape=shape), fps=fps)


@main.command(epilog=EPILOG_BUILD)
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder to write (created if missing).")
@build_options
@backend_options
@click.option("--push", "pushes", multiple=True, metavar="LABEL=VX,VY,VZ[@T]",
              help="Give an object this velocity in m/s at T seconds (default 0); world axes: Z up, "
                   "+Y away from the camera, +X to the image's right. Repeatable.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def build(photo, out_dir, masks, boxes, fov, pitch, camera_height, shape, fps, meshes_dir, fixed, forces, pushes, quiet,
          backends):
    """Photo → scene.usda, physics.usda and the root shot.usda (perceive, align, estimate)."""
    with _errors():
        from .build import build_shot

        settings = _build_settings(fov, pitch, camera_height, shape, fps)
        result = build_shot(photo, out_dir, masks, boxes, settings, pushes, echo=_say(quiet), forces=forces, fixed=fixed,
                            meshes_dir=meshes_dir, backends=backends)
        if not quiet:
            total = sum(result.seconds.values())
            click.echo(f"wrote {result.shot} ({len(result.objects)} objects, {total:.2f} s)", err=True)


def _simulate(shot, seconds, fps, substeps, quiet, particle_spacing=None, mpm_steps=None):
    from .physics.simulate import simulate_shot
    from .settings import SimulateSettings

    settings = SimulateSettings(seconds=seconds, fps=fps, substeps=substeps, particle_spacing=particle_spacing,
                                mpm_steps=mpm_steps)
    with _progress("simulate", not quiet) as bar:
        section = simulate_shot(shot, settings, progress=bar, echo=_say(quiet))
    if not quiet:
        click.echo(f"simulate: {section['frames']} frames, {section['bodies']} rigid bodies, "
                   f"{len(section['moving_prims'])} moving, dt {section['dt'] * 1000:.2f} ms, "
                   f"{section['total_seconds']:.2f} s", err=True)
    return section


def _render(shot, output, quiet, max_size=1920):
    from .render.video import render_shot
    from .settings import RenderSettings

    with _progress("render  ", not quiet) as bar:
        section = render_shot(shot, output, RenderSettings(max_size=max_size), progress=bar)
    if not quiet:
        click.echo(f"render: {section['video']} ({section['frames']} frames, "
                   f"{section['frames_per_second']:.1f} frames/s)", err=True)
    return section


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--seconds", type=float, default=3.0, show_default=True, help="Simulated seconds.")
@click.option("--fps", type=float, default=None, help="Frames per second [default: the shot's].")
@click.option("--substeps", type=int, default=None,
              help="Solver steps per frame [default: chosen from the shot's materials and speeds].")
@click.option("--particle-spacing", type=float, default=None, metavar="METRES",
              help="MPM particle spacing [default: the smallest MPM object 10 particles across, at most "
                   "15,000 particles].")
@click.option("--mpm-steps", type=int, default=None,
              help="MPM steps per frame [default: what the bench found accurate for the shot's materials "
                   "(elastic 16, sand 4, liquid 2 at 30 fps), fewer where the CFL bound allows; fewer is a "
                   "faster, less accurate preview].")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def simulate(shot, seconds, fps, substeps, particle_spacing, mpm_steps, quiet):
    """Simulate the composed shot (edits.usda included) and write sim.usdc.

    Each object goes to its material's solver: rigid bodies, cloth (pbd_cloth) and soft bodies
    (pbd_elastic) on XPBD, sand, snow, liquids and elastic solids (mpm_*) on Newton's implicit MPM,
    coupled both ways. Steps come from the materials; a frame whose energy or speed runs away is
    redone at half the step.

    \b
    Example: make the box heavier and throw it, then simulate again:
      # in shot/edits.usda
      over "World" { over "Objects" { over "box_0" {
          float physics:density = 2000
          vector3f physics:velocity = (0, 2, 1)
      } } }
      physomni-usd simulate shot/shot.usda --seconds 4

    \b
    Turn the box to sand and simulate with coarser particles:
      physomni-usd estimate shot/shot.usda --set box.material=mpm_sand
      physomni-usd simulate shot/shot.usda --particle-spacing 0.03

    \b
    A quick preview of an elastic shot (4 MPM steps a frame instead of 16):
      physomni-usd simulate shot/shot.usda --mpm-steps 4
    """
    with _errors():
        _simulate(shot, seconds, fps, substeps, quiet, particle_spacing, mpm_steps)


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("-o", "--output", type=click.Path(path_type=pathlib.Path), default=None,
              help="Video file (.mp4) [default: video.mp4 beside the shot].")
@click.option("--max-size", type=int, default=1920, show_default=True,
              help="Longest side of the video in pixels; larger photos are rendered smaller.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def render(shot, output, max_size, quiet):
    """Render the composed shot over its background plate into an H.264 MP4."""
    with _errors():
        _render(shot, output, quiet, max_size)


@main.command()
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder to write (created if missing).")
@build_options
@backend_options
@click.option("--seconds", type=float, default=3.0, show_default=True, help="Simulated seconds.")
@click.option("--push", "pushes", multiple=True, metavar="LABEL=VX,VY,VZ[@T]",
              help="Give an object this velocity in m/s at T seconds (default 0); world axes: Z up, "
                   "+Y away from the camera, +X to the image's right. Repeatable.")
@click.option("--particle-spacing", type=float, default=None, metavar="METRES",
              help="MPM particle spacing [default: chosen from the objects' sizes].")
@click.option("--mpm-steps", type=int, default=None,
              help="MPM steps per frame [default: chosen from the materials; see simulate --help].")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def run(photo, out_dir, masks, boxes, fov, pitch, camera_height, shape, fps, meshes_dir, fixed, forces, seconds, pushes,
        particle_spacing, mpm_steps, quiet, backends):
    """build + simulate + render in one go; writes DIR/shot.usda, DIR/video.mp4, DIR/report.json.

    \b
    Example:
      physomni-usd run examples/motorcycle/photo.png -o out/ \\
          --mask examples/motorcycle/motorcycle.png --push motorcycle=0,0.8,0
    """
    with _errors():
        from .build import build_shot
        from .report import update_report
        from .settings import SimulateSettings

        # refuse absurd values before any work
        SimulateSettings(seconds=seconds, particle_spacing=particle_spacing, mpm_steps=mpm_steps)
        t0 = time.perf_counter()
        settings = _build_settings(fov, pitch, camera_height, shape, fps)
        result = build_shot(photo, out_dir, masks, boxes, settings, pushes, echo=_say(quiet), forces=forces, fixed=fixed,
                            meshes_dir=meshes_dir, backends=backends)
        _simulate(result.shot, seconds, None, None, quiet, particle_spacing, mpm_steps)
        section = _render(result.shot, None, quiet)
        total = round(time.perf_counter() - t0, 3)
        update_report(result.folder, run={"total_seconds": total})
        if not quiet:
            click.echo(f"done in {total:.1f} s: {result.shot}, {section['video']}, "
                       f"{result.folder / 'report.json'}", err=True)


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
                   "youngs_modulus, poissons_ratio, …); written to edits.usda. Repeatable.")
@click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
              help="Add a force field of yours (kept across later estimates). Repeatable.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def estimate(shot, estimator, vlm_url, vlm_model, vlm_api_key, vlm_timeout, sets, forces, quiet):
    """Estimate physical materials (and force fields) and write physics.usda; --set goes to edits.usda.

    \b
    Examples:
      physomni-usd estimate shot/shot.usda --set cup.material=mpm_elastic --set cup.youngs_modulus=2e4
      physomni-usd estimate shot/shot.usda --estimator vlm --vlm-url http://localhost:8000/v1 \\
          --vlm-model Qwen2.5-VL-72B-Instruct
    """
    with _errors():
        from .materials.estimate import estimate_shot

        vlm = None
        if estimator == "vlm":
            from .materials.vlm import VLMSettings

            vlm = VLMSettings.resolve(vlm_url, vlm_model, vlm_api_key, timeout_s=vlm_timeout)
        section = estimate_shot(shot, estimator, vlm, sets, forces, echo=_say(quiet))
        if not quiet:
            for name, obj in section["objects"].items():
                params = ", ".join(f"{k}={v['value']:g}" if isinstance(v["value"], float) else f"{k}={v['value']}"
                                   for k, v in obj["params"].items())
                click.echo(f"{name}: {obj['material']} ({obj['source']}) {params}", err=True)


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
@click.option("--seconds", type=float, default=2.0, show_default=True, help="Simulated seconds in the run.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the numbers to this JSON file.")
def bench_pipeline_command(example, size, repeats, seconds, json_path):
    """Wall time of build and of a whole run on a bundled example (run twice for warm kernel caches)."""
    with _errors():
        import json

        from .bench.pipeline import bench_pipeline

        numbers = bench_pipeline(example, size=size, repeats=repeats, seconds=seconds, echo=click.echo)
        if json_path:
            from ._files import write_bytes

            write_bytes(json_path, (json.dumps(numbers, indent=2) + "\n").encode())


@bench.command("alignment")
@click.option("--quick", is_flag=True, help="Smaller images and fewer scenes (a few minutes on a CPU).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
def bench_alignment_command(quick, json_path):
    """The paper's alignment ablations on synthetic scenes with known truth (scene and camera tables)."""
    with _errors():
        from .bench.alignment import bench_alignment, write_json

        numbers = bench_alignment(quick=quick, echo=click.echo)
        if json_path:
            write_json(numbers, json_path)


@bench.command("physics")
@click.option("--quick", is_flag=True, help="Fewer settings, one repeat, a smaller matrix (a few minutes).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Also write the rows to this JSON file.")
@click.option("--plots", "plots_dir", type=click.Path(file_okay=False, path_type=pathlib.Path), default=None,
              help="Write error-against-time plots (PNG, needs matplotlib) to this folder.")
@click.option("--markdown", "md_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Write the tables as Markdown, dated and with the machine, to this file.")
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
        import json

        from .bench.physics import bench_physics, write_plots

        numbers = bench_physics(quick=quick, echo=click.echo)
        if plots_dir:
            written = write_plots(numbers, plots_dir)
            click.echo(f"plots: {len(written)} written to {plots_dir}" if written else
                       "plots: matplotlib is not installed (pip install 'physomni-usd[bench]')", err=True)
        from ._files import write_bytes

        if json_path:
            write_bytes(json_path, (json.dumps(numbers, indent=2) + "\n").encode())
        if md_path:
            from .bench.physics import markdown, splice_markdown

            text = markdown(numbers)
            if md_path.is_file():
                text = splice_markdown(md_path.read_text(), text)
            write_bytes(md_path, text.encode())


@main.command("plugins")
def plugins_command():
    """List every backend by kind: built in or from a plugin, its package and version, and whether it is ready.

    \b
    Plugins are packages that register under the entry-point group physomni_usd.backends; install one
    and point it at its weights, e.g.
      pip install -e plugins/physomni-lama && export PHYSOMNI_LAMA_WEIGHTS=/models/big-lama.pt
      physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --inpainter lama
    """
    with _errors():
        from .backends import registry

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
                state = "ready" if ready else "not ready"
                click.echo(f"  {e.name}{default}: {origin}, {e.package} {e.version}, {state}"
                           + (f": {note}" if note else ""))


@main.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--model", required=True, metavar="NAME", help="Re-renderer backend, e.g. wan-vace (plugin physomni-wan).")
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

    The objects' pixels of each frame (from the renderer's ray hits) are the model's masks. Needs a
    re-renderer plugin; without one this says which to install and exits 2.

    \b
    Example (Wan VACE; weights: a diffusers WanVACEPipeline folder):
      pip install -e plugins/physomni-wan && export PHYSOMNI_WAN_WEIGHTS=/models/Wan2.1-VACE-1.3B-diffusers
      physomni-usd rerender shot/shot.usda --model wan-vace --strength 0.5 --steps 20 -o shot/wan.mp4
    """
    with _errors():
        from .backends.rerender import rerender_shot

        with _progress("render  ", not quiet) as bar:
            section = rerender_shot(shot, model, strength, steps, output, prompt, seed, max_size, progress=bar)
        if not quiet:
            click.echo(f"rerender: {section['video']} ({section['frames']} frames, "
                       f"{section['width']}×{section['height']}, {section['seconds']['model']:.1f} s in the model)",
                       err=True)


if __name__ == "__main__":  # pragma: no cover
    main()
