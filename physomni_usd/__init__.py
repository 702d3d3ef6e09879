"""physomni-usd: one photograph to a physically simulated, layered USD shot.

Importing the package registers the PhysOmni USD schema with OpenUSD. Nothing
heavy (warp, Newton, torch) is imported here; each stage imports what it needs
when it runs.

The public API is one function per stage, paths in and the stage's section of
``report.json`` out: :func:`build`, :func:`estimate`, :func:`simulate`,
:func:`render`, and :func:`run` for the three that ``physomni-usd run`` chains
(build, simulate, render), with its defaults. Each imports its stage only when
called. Bad input raises :class:`physomni_usd.errors.InputError` with one line
naming the option or file; nothing the user made is overwritten then.
:func:`physomni_usd.failure.failure_of` turns any exception into the line and
exit code the CLI prints.
"""

from ._version import __version__
from .usd.schema import register_schema

register_schema()

# The stages' own modules are named apart from these functions (building.py, rendering/): importing a
# submodule binds it on the package under its name, which would otherwise replace the function.


def build(photo, out_dir, masks=(), boxes=(), settings=None, **options):
    """Build a shot from ``photo`` (a path) into ``out_dir``: plate, textures, ``scene.usda``, ``physics.usda``
    and an empty ``edits.usda``. ``masks`` are ``PATH[:LABEL]`` specs, ``boxes`` ``X0,Y0,X1,Y1[:LABEL]`` in
    pixels (as ``--mask`` and ``--box`` take them); ``settings`` a
    :class:`physomni_usd.settings.BuildSettings` (defaults when None); ``options`` as
    :func:`physomni_usd.building.build_shot` takes them (pushes, forces, fixed, meshes_dir, sizes, backends, echo).
    Returns the build result; its ``shot`` is the path of ``shot.usda``."""
    from .building import build_shot
    from .settings import BuildSettings

    return build_shot(photo, out_dir, masks, boxes, settings or BuildSettings(), **options)


def estimate(shot, estimator: str = "rules", vlm=None, sets=(), forces=(), echo=lambda m: None) -> dict:
    """Estimate the materials of ``shot`` (``shot.usda`` or its folder) with ``estimator`` (``rules`` or a
    VLM), then apply ``sets`` (``NAME.KEY=VALUE``, written to ``edits.usda``) and ``forces``
    (``KIND:key=value,...``). Rewrites ``physics.usda``; returns the report's ``estimate`` section."""
    from .materials.estimate import estimate_shot

    return estimate_shot(shot, estimator, vlm, sets, forces, echo=echo)


def simulate(shot, settings=None, progress=None, echo=lambda m: None) -> dict:
    """Simulate the composed stage of ``shot`` and write ``sim.usdc`` beside it; ``settings`` a
    :class:`physomni_usd.settings.SimulateSettings` (seconds, fps, substeps; defaults when None: the shot's own
    length, at its frame rate). Returns the report's ``simulate`` section. A rigid-only shot imports no torch."""
    from .physics.simulate import simulate_shot
    from .settings import SimulateSettings

    return simulate_shot(shot, settings or SimulateSettings(), progress=progress, echo=echo)


def render(shot, output=None, settings=None, progress=None, **options) -> dict:
    """Render every frame of ``shot`` to ``output`` (default ``video.mp4`` beside it); ``settings`` a
    :class:`physomni_usd.settings.RenderSettings` (defaults when None); ``options``: ``passes``,
    ``passes_dir``, ``camera`` (a move of :data:`physomni_usd.rendering.moves.MOVES`), ``camera_amount`` and
    ``still`` (render a shot never simulated: one frame; refused without it).
    Returns the report's ``render`` section."""
    from .rendering.video import render_shot
    from .settings import RenderSettings

    return render_shot(shot, output, settings or RenderSettings(), progress=progress, **options)


#: The stages of :func:`run`, in order; ``check`` is the checking of every option before any work.
RUN_STAGES = ("check", "build", "simulate", "render")


def run(photo, out_dir, masks=(), boxes=(), settings=None, simulate_settings=None, render_settings=None, *,
        camera=None, camera_amount=1.0, progress=None, on_stage=None, echo=lambda m: None, **options) -> dict:
    """Build, simulate and render a shot in one go, as ``physomni-usd run`` does: ``out_dir`` gets
    ``shot.usda``, ``video.mp4`` and ``report.json`` (with a ``run`` section, its total seconds).

    ``photo``, ``masks``, ``boxes``, ``settings`` and ``options`` as :func:`build` takes them;
    ``simulate_settings`` a :class:`physomni_usd.settings.SimulateSettings` (when None, its defaults); a take
    whose ``seconds`` are not given is :data:`~physomni_usd.settings.DEFAULT_SECONDS` long, ended once nothing
    has moved for :data:`~physomni_usd.settings.REST_SECONDS` (unless its ``rest_seconds`` says otherwise);
    ``render_settings`` a
    :class:`physomni_usd.settings.RenderSettings`; ``camera`` and ``camera_amount`` as :func:`render` takes
    them. Every option is checked, and the video's path found writable, before any work.
    ``progress(stage, done, total)`` follows simulate and render frame by frame; ``on_stage(stage, result)``
    is called as each of :data:`RUN_STAGES` starts (``result`` None) and ends (its section; the
    :class:`physomni_usd.building.BuildResult` for ``build``). A failure before the build is written (bad input,
    a refused scene) is raised as it is, and nothing this call wrote is left
    (``physomni_usd._files.all_or_nothing``). A failure after it (simulate or render) keeps the built shot,
    so that it can be looked at, edited and simulated again: ``report.json``'s ``run`` section says which
    stage failed and why, and a :class:`physomni_usd.errors.PhysOmniError` saying the same is raised (with
    the stage's exit code). An interruption (Ctrl-C, a terminating signal) still puts every file back.

    Returns ``{"build": BuildResult, "simulate": section, "render": section, "total_seconds": float}``.
    """
    import pathlib
    import time

    from ._files import all_or_nothing, check_writable
    from .errors import PhysOmniError
    from .failure import failure_of
    from .rendering.video import check_camera_move
    from .report import update_report
    from .building import check_build_inputs
    from .settings import REST_SECONDS, BuildSettings, RenderSettings, SimulateSettings

    def stage(name, result=None):
        if on_stage is not None:
            on_stage(name, result)

    def follow(name):
        return None if progress is None else (lambda done, total: progress(name, done, total))

    with all_or_nothing():
        stage("check")
        settings = settings or BuildSettings()
        simulate_settings = simulate_settings or SimulateSettings()
        if simulate_settings.seconds is None and simulate_settings.rest_seconds is None:
            # seconds asked for are simulated to the end; the default length ends once all is still
            simulate_settings = simulate_settings.model_copy(update={"rest_seconds": REST_SECONDS})
        render_settings = render_settings or RenderSettings()
        check_build_inputs(photo, masks, boxes, settings)
        simulate_settings.for_shot(None, simulate_settings.fps or settings.fps)  # the step cap, on the new shot
        check_camera_move(camera, camera_amount)
        check_writable([pathlib.Path(out_dir) / "video.mp4"])
        stage("check", {})
        t0 = time.perf_counter()
        stage("build")
        built = build(photo, out_dir, masks, boxes, settings, echo=echo, **options)
        stage("build", built)
        current = "simulate"
        try:
            stage("simulate")
            simulated = simulate(built.shot, simulate_settings, progress=follow("simulate"), echo=echo)
            stage("simulate", simulated)
            current = "render"
            stage("render")
            rendered = render(built.shot, None, render_settings, progress=follow("render"), camera=camera,
                              camera_amount=camera_amount)
            stage("render", rendered)
        except Exception as exc:  # noqa: BLE001 — an interruption is no failure of the shot: it unwinds all
            # the shot built is the user's best handle on why the later stage failed (validate, preview, edits)
            found = failure_of(exc, current)
            update_report(built.folder, run={"failed": {"stage": current, "message": found.message,
                                                        "exit_code": found.exit_code,
                                                        "seconds": round(time.perf_counter() - t0, 3)}})
            failed = PhysOmniError(f"{current} failed: {found.message} (the built shot and report.json are kept "
                                   f"in {built.folder})", exit_code=found.exit_code)
            failed.__cause__ = exc
        else:
            failed = None
            total = round(time.perf_counter() - t0, 3)
            update_report(built.folder, run={"total_seconds": total})
    if failed is not None:  # raised after the block, which keeps what build wrote
        raise failed
    return {"build": built, "simulate": simulated, "render": rendered, "total_seconds": total}


__all__ = ["__version__", "register_schema", "build", "estimate", "simulate", "render", "run", "RUN_STAGES"]
