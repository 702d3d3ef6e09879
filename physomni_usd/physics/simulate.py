"""Simulation of a shot with Newton: the shot prepared (``physics.prepare``: each object routed to its
material's solver — rigid bodies, cloth and soft bodies on XPBD, MPM materials on the implicit MPM solver,
coupled two-way — and steps chosen from the materials), every frame checked by the stability guard,
recorded as one sample per video frame, written to ``sim.usdc`` and reported."""

from __future__ import annotations

import sys
import time

from .._warp import compiled_seconds
from ..report import prepare_writes, update_report
from ..settings import SimulateSettings
from ..usd import layers
from .prepare import prepare_simulation
from .recording import shot_checks, write_take
from .runner import run_guarded
from .stability import MAX_SUBSTEPS


def _compiled_line(before: float | None, after: float | None) -> str:
    """What the first run says once its kernels are in the cache: the compile's own time, not the run's."""
    if before is None or after is None:
        return "simulate: physics kernels compiled; later runs start at once"
    if after - before < 0.5:  # another process (or an earlier shot in this one) had compiled them
        return "simulate: physics kernels were already in warp's cache; later runs start at once"
    return f"simulate: physics kernels compiled in {after - before:.0f} s; later runs start at once"


def simulate_shot(shot, settings: SimulateSettings = SimulateSettings(), progress=None, echo=lambda m: None) -> dict:
    """Simulate the composed stage of ``shot`` and write ``sim.usdc`` beside it; returns the report section.
    Without ``settings.seconds``, the shot's own length (:meth:`SimulateSettings.for_shot`)."""
    t_start = time.perf_counter()
    folder = layers.shot_folder(shot)
    stage = layers.open_shot(shot, mute_sim=True)
    prepare_writes(folder, [layers.SIM, layers.SHOT], echo)  # refuse an unwritable folder before any work
    layers.warn_orphan_overs(stage, folder, echo)
    own_seconds = layers.shot_seconds(shot)
    prep = prepare_simulation(stage, settings, name=str(shot), own_seconds=own_seconds, echo=echo)
    cfg, objects, sim, plan, settings = prep.config, prep.objects, prep.models, prep.plan, prep.settings
    echo(f"simulate: solvers {', '.join(sim.solvers)}; {plan.substeps} substeps per frame"
         + (f", {plan.mpm_steps} MPM steps per frame ({sim.mpm.model.particle_count} particles, "
            f"spacing {sim.mpm.spacing * 1000:.1f} mm)" if sim.mpm else ""))
    if sim.supported:
        echo(f"simulate: {', '.join(sim.supported)} cannot stand on what the photo shows of "
             f"{'it' if len(sim.supported) == 1 else 'them'}: standing on {'its' if len(sim.supported) == 1 else 'their'} footprint")
    for o in objects:
        sheet = sim.cloth_sheets.get(o.path) if o.family == "cloth" else None
        if sheet is not None and sheet.softened_from_n_m:
            echo(f"simulate: {o.name}'s cloth springs softened from {sheet.softened_from_n_m:.3g} to "
                 f"{sheet.spring_n_m:.3g} N/m (its bending alike): at {sheet.softened_from_n_m:.3g} N/m its "
                 f"particles need {sheet.needs_substeps} substeps a frame; "
                 + (f"--substeps {settings.substeps} resolves only {sheet.spring_n_m:.3g} N/m (give more, or leave "
                    "--substeps out)" if settings.substeps else
                    f"a frame allows {MAX_SUBSTEPS} at {cfg.fps:g} fps (a higher --fps steps finer)"))
    run = run_guarded(sim, plan, settings.seconds, progress, echo, rest_seconds=settings.rest_seconds)
    take = run.take
    if run.rest is not None:
        # the take ends a still stretch after the last motion: the rest would be a photo held still
        echo(f"simulate: everything at rest from {run.rest['still_from_s']:.2f} s; the take ends at "
             f"{take.seconds:.2f} s of the {settings.seconds:g} s (--seconds simulates them all)")
    if prep.kernels_marker is not None:
        prep.kernels_marker.touch()
        echo(_compiled_line(prep.compiled_before, compiled_seconds()))

    t_write = time.perf_counter()
    plan, frames, seconds = take.plan, take.frames, take.seconds
    moved = write_take(folder, sim, take)
    written = layers.open_shot(folder)
    checks = shot_checks(written, frames)
    t_end = time.perf_counter()

    section = {
        "solver": cfg.solver, "solvers": list(sim.solvers), "device": sim.device, "fps": cfg.fps,
        "frames": frames, "substeps": plan.substeps, "dt": plan.dt, "iterations": plan.iterations,
        "steps": plan.as_dict(), "simulated_seconds": seconds, "asked_seconds": settings.seconds,
        "ended_at_rest": run.rest,
        "bodies": len(sim.path_body), "moving_prims": moved,
        "objects": {o.name: {"material": o.kind, "solver": o.family} for o in objects},
        "cloths": {o.name: _cloth_entry(sim, o) for o in objects if o.family == "cloth"},
        "soft_bodies": {o.name: {"particles": sim.ranges[o.path][1]} for o in objects if o.family == "soft"},
        "mpm": ({"particles": sim.mpm.model.particle_count, "spacing_m": sim.mpm.spacing,
                 "voxel_m": sim.mpm.solver.voxel_size,
                 "objects": {o.obj.name: o.count for o in sim.mpm.objects}} if sim.mpm else None),
        "guard": run.guard, "retries": len(run.guard["rollbacks"]), "newton_notes": run.notes,
        "force_fields": [f"{x.kind} {x.path}" for x in sim.fields.fields], "ignored_parameters": prep.ignored,
        "max_speed_m_s": run.max_speed, "captured_step": run.capture,
        "hidden_support": sim.supported, "colliders": sim.rounded.report(), **checks,
        "modules": {"torch": "torch" in sys.modules},
        "model_reused": sim.reused,
        "seconds": {"read": round(sim.t_built - t_start - sim.t_model, 4), "build_model": round(sim.t_model, 4),
                    "step": round(run.t_step, 4), "step_cpu": round(run.cpu_step, 4), "write": round(t_end - t_write, 4)},
        "total_seconds": round(t_end - t_start, 4),
        "seconds_per_simulated_second": round(run.t_step / max(seconds, 1e-9), 4),
    }
    update_report(folder, simulate=section)
    return section


def _cloth_entry(sim, o) -> dict:
    """report.json's entry for a cloth: its particles, its springs' stiffness as simulated, and what they were
    softened from where ``cloth.add_cloth`` softened them."""
    sheet = sim.cloth_sheets[o.path]
    entry = {"particles": sim.ranges[o.path][1]}
    if sheet.spring_n_m is not None:
        entry["spring_n_m"] = round(sheet.spring_n_m, 4)
    if sheet.softened_from_n_m:
        entry["softened_from_n_m"] = round(sheet.softened_from_n_m, 4)
    return entry
