"""Simulation of a shot with Newton: each object routed to its material's solver (rigid bodies, cloth
and soft bodies on XPBD, MPM materials on the implicit MPM solver, coupled two-way), steps chosen from
the materials, every frame checked by the stability guard, recorded as one sample per video frame."""

from __future__ import annotations

import sys
import time

from pxr import Usd, UsdPhysics

from .._warp import compiled_seconds
from ..errors import InputError
from ..report import prepare_writes, update_report
from ..settings import SimulateSettings
from ..usd import layers
from ..usd.author import OBJECTS
from .assembly import shot_models
from .checks import check_inputs
from .diagnose import refuse_broken_scene
from .objects import scene_objects
from .params import authored, describe, ignored_parameters
from .recording import shot_checks, write_take
from .runner import run_guarded
from .stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS, plan_steps

SUPPORTED_SOLVERS = ("xpbd",)


def scene_settings(stage: Usd.Stage, settings: SimulateSettings) -> dict:
    """Solver, substeps, iterations and fps: the command line's where given, else the stage's."""
    scene = next((p for p in stage.Traverse() if p.IsA(UsdPhysics.Scene)), None)

    def attr(name, default):
        a = scene.GetAttribute(name) if scene else None
        v = a.Get() if a and a.HasAuthoredValue() else None
        return default if v is None else v

    fps = settings.fps or stage.GetTimeCodesPerSecond() or 30.0
    out = {
        "solver": str(attr("physomni:solver", "xpbd")),
        "substeps": int(settings.substeps or attr("physomni:substeps", DEFAULT_SUBSTEPS)),
        "iterations": int(settings.iterations or attr("physomni:iterations", DEFAULT_ITERATIONS)),
        "fps": float(fps),
    }
    if out["solver"] not in SUPPORTED_SOLVERS:
        raise InputError(f"physomni:solver = {out['solver']!r} is not available; use one of {SUPPORTED_SOLVERS}")
    if not 1 <= out["substeps"] <= 1000 or not 1 <= out["iterations"] <= 100:
        raise InputError("physomni:substeps must be in [1, 1000] and physomni:iterations in [1, 100]")
    return out


def kernels_first_use():
    """The marker to write once this machine's warp kernel cache holds the simulator's kernels, or None
    when it already does (the marker names the versions of warp and Newton whose kernels it holds)."""
    import pathlib

    from .._warp import load_newton, load_warp

    wp, newton = load_warp(), load_newton()
    cache = pathlib.Path(wp.config.kernel_cache_dir or "")
    if not cache.is_dir():
        return None
    marker = cache / f"physomni-kernels-warp{wp.__version__}-newton{newton.__version__}"
    return None if marker.exists() else marker


def _compiled_line(before: float | None, after: float | None) -> str:
    """What the first run says once its kernels are in the cache: the compile's own time, not the run's."""
    if before is None or after is None:
        return "simulate: physics kernels compiled; later runs start at once"
    if after - before < 0.5:  # another process (or an earlier shot in this one) had compiled them
        return "simulate: physics kernels were already in warp's cache; later runs start at once"
    return f"simulate: physics kernels compiled in {after - before:.0f} s; later runs start at once"


#: The composed stage whose input checks last passed in this process: the checks are a function of the
#: composed stage alone, so the same stage simulated again (a bench, a batch's retries) is not checked again.
_CHECKED: dict = {}


def simulate_shot(shot, settings: SimulateSettings = SimulateSettings(), progress=None, echo=lambda m: None) -> dict:
    """Simulate the composed stage of ``shot`` and write ``sim.usdc`` beside it; returns the report section.
    Without ``settings.seconds``, the shot's own length (:meth:`SimulateSettings.for_shot`)."""
    t_start = time.perf_counter()
    folder = layers.shot_folder(shot)
    stage = layers.open_shot(shot, mute_sim=True)
    prepare_writes(folder, [layers.SIM, layers.SHOT], echo)  # refuse an unwritable folder before any work
    layers.warn_orphan_overs(stage, folder, echo)
    cfg = scene_settings(stage, settings)
    settings = settings.for_shot(layers.shot_seconds(shot), cfg["fps"])  # the shot's own length, the step cap
    digest = layers.content_digest(stage)
    checked = _CHECKED.get("digest") == digest
    if not checked:
        check_inputs(stage)
    objects = scene_objects(stage)
    if not objects:
        raise InputError(f"{shot}: no objects to simulate under {OBJECTS}")
    ignored = ignored_parameters(objects)
    for name, items in ignored.items():
        if authored(items):
            echo(f"simulate: {describe(name, authored(items))}")
    if not checked:
        refuse_broken_scene(stage)
        _CHECKED["digest"] = digest
    frames = int(round(settings.seconds * cfg["fps"])) + 1

    first_use = kernels_first_use()
    if first_use is not None:
        echo("simulate: compiling physics kernels, once per machine (a minute or two) ...")
    compiled_before = compiled_seconds()
    sim = shot_models(stage, objects, cfg, settings, digest)
    plan = plan_steps(objects, cfg["fps"], cfg["substeps"], base_iterations=cfg["iterations"], mpm=sim.mpm,
                      acceleration=sim.field_acceleration(settings.seconds), cloth_masses=sim.cloth_masses,
                      field_kinds=[f.kind for f in sim.fields.fields], particles=bool(sim.model.particle_count),
                      cloth_stiffness=sim.cloth_stiffness, soft_dt=sim.soft_dt, fixed_substeps=settings.substeps is not None,
                      mpm_steps=settings.mpm_steps)
    echo(f"simulate: solvers {', '.join(sim.solvers)}; {plan.substeps} substeps per frame"
         + (f", {plan.mpm_steps} MPM steps per frame ({sim.mpm.model.particle_count} particles, "
            f"spacing {sim.mpm.spacing * 1000:.1f} mm)" if sim.mpm else ""))
    if sim.supported:
        echo(f"simulate: {', '.join(sim.supported)} cannot stand on what the photo shows of "
             f"{'it' if len(sim.supported) == 1 else 'them'}: standing on {'its' if len(sim.supported) == 1 else 'their'} footprint")
    run = run_guarded(sim, plan, frames, progress, echo, rest_seconds=settings.rest_seconds)
    seconds = settings.seconds
    if run["rest"] is not None:
        # the take ends a still stretch after the last motion: the rest would be a photo held still
        frames = len(run["body_q"])
        seconds = run["rest"]["ended_s"]
        echo(f"simulate: everything at rest from {run['rest']['still_from_s']:.2f} s; the take ends at "
             f"{seconds:.2f} s of the {settings.seconds:g} s (--seconds simulates them all)")
    if first_use is not None:
        first_use.touch()
        echo(_compiled_line(compiled_before, compiled_seconds()))

    t_write = time.perf_counter()
    plan = run["plan"]
    moved = write_take(folder, sim, cfg, plan, run["body_q"], run["surfaces"], run["mpm_points"], seconds)
    checks = shot_checks(layers.open_shot(folder), frames)
    t_end = time.perf_counter()

    section = {
        "solver": cfg["solver"], "solvers": list(sim.solvers), "device": sim.device, "fps": cfg["fps"],
        "frames": frames, "substeps": plan.substeps, "dt": plan.dt, "iterations": plan.iterations,
        "steps": plan.as_dict(), "simulated_seconds": seconds, "asked_seconds": settings.seconds,
        "ended_at_rest": run["rest"],
        "bodies": len(sim.path_body), "moving_prims": moved,
        "objects": {o.name: {"material": o.kind, "solver": o.family} for o in objects},
        "cloths": {o.name: {"particles": sim.ranges[o.path][1]} for o in objects if o.family == "cloth"},
        "soft_bodies": {o.name: {"particles": sim.ranges[o.path][1]} for o in objects if o.family == "soft"},
        "mpm": ({"particles": sim.mpm.model.particle_count, "spacing_m": sim.mpm.spacing,
                 "voxel_m": sim.mpm.solver.voxel_size,
                 "objects": {o.obj.name: o.count for o in sim.mpm.objects}} if sim.mpm else None),
        "guard": run["guard"], "retries": len(run["guard"]["rollbacks"]), "newton_notes": run["notes"],
        "force_fields": [f"{x.kind} {x.path}" for x in sim.fields.fields], "ignored_parameters": ignored,
        "max_speed_m_s": run["max_speed"], "captured_step": run["capture"],
        "hidden_support": sim.supported, **checks,
        "modules": {"torch": "torch" in sys.modules},
        "model_reused": sim.reused,
        "seconds": {"read": round(sim.t_built - t_start - sim.t_model, 4), "build_model": round(sim.t_model, 4),
                    "step": round(run["t_step"], 4), "write": round(t_end - t_write, 4)},
        "total_seconds": round(t_end - t_start, 4),
        "seconds_per_simulated_second": round(run["t_step"] / max(seconds, 1e-9), 4),
    }
    update_report(folder, simulate=section)
    return section
