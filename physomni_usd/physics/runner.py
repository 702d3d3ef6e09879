"""A run under the stability guard: every frame checked for non-finite values, speeds and energy
beyond the work done; a failed frame is rolled back and redone at half the step."""

from __future__ import annotations

import time

import numpy as np

from ..errors import PhysOmniError
from .recording import Recorder
from .diagnose import FRAME_WALL_BUDGET_S, failure_line
from .stability import Guard, StepPlan
from .stepping import FrameGraphs

#: Whether frames of rigid XPBD scenes are captured as warp graphs and replayed (False: launch by launch).
CAPTURE = True

#: How often a diverging frame is rolled back and redone, each time with half the step.
MAX_RETRIES = 4


def run_guarded(models, plan: StepPlan, frames: int, progress=None, echo=lambda m: None) -> dict:
    """Step ``frames − 1`` frames of ``models`` (a :class:`~.assembly.ShotModels`) under the guard.
    Returns what the writer needs: the final plan, the recorded frames, timings and the guard's log."""
    wp = models.wp
    stepper = models.stepper
    graphs = FrameGraphs(stepper, enabled=CAPTURE)
    guard = Guard()
    rollbacks = []
    rec = Recorder(models, frames)
    with wp.ScopedDevice(models.device):
        energy, speed, finite = _energy(stepper)
        guard.check(energy, speed, finite)
        rec.record(0)
        max_speed = speed
        t1 = time.perf_counter()
        t, step, f = 0.0, 0, 1
        t_frame, frame_of_t = time.perf_counter(), 1
        while f < frames:
            if f != frame_of_t:
                t_frame, frame_of_t = time.perf_counter(), f
            saved = stepper.checkpoint()
            work = guard.work
            graphs.frame(plan, t, step, guard.add_work, speed)
            before = speed
            energy, speed, finite = _energy(stepper)
            why = guard.check(energy, speed, finite)
            if why is not None:
                if len(rollbacks) >= MAX_RETRIES:
                    raise PhysOmniError(failure_line(models.stage, f"simulation diverged at frame {f}: {why}, "
                                                     f"even at {plan.substeps} substeps per frame"))
                if time.perf_counter() - t_frame > FRAME_WALL_BUDGET_S:
                    raise PhysOmniError(failure_line(models.stage, f"simulation stuck at frame {f}: {why}, "
                                                     f"{FRAME_WALL_BUDGET_S:g} s spent on it"))
                stepper.restore(saved)
                guard.work = work
                speed = before
                plan = plan.refined()
                rollbacks.append({"frame": f, "why": why, "substeps": plan.substeps, "mpm_steps": plan.mpm_steps})
                echo(f"simulate: frame {f}: {why}; going back to frame {f - 1} with {plan.substeps} "
                     "substeps per frame")
                continue
            step += plan.substeps
            t = f / plan.fps
            max_speed = max(max_speed, speed)
            rec.record(f)
            if progress:
                progress(f, frames - 1)
            f += 1
        t_step = time.perf_counter() - t1
    return {"plan": plan, "body_q": rec.body_q, "surfaces": rec.surfaces, "mpm_points": rec.mpm_points,
            "t_step": t_step, "capture": {"enabled": graphs.enabled, "frames_replayed": graphs.captured_frames,
                                          "graphs": graphs.captures, "error": graphs.error},
            "max_speed": round(max_speed, 4), "notes": sorted(set(models.notes)),
            "guard": {"energy_initial_j": guard.initial, "energy_final_j": guard.last_energy,
                      "work_j": guard.work, "tolerance": guard.tolerance, "rollbacks": rollbacks}}


def _energy(stepper) -> tuple[float, float, bool]:
    energy, speed = stepper.energy()
    return energy, speed, all(np.isfinite(a.numpy()).all() for a in _arrays(stepper))


def _arrays(stepper):
    s = stepper.state
    out = [a for a in (s.body_q, s.body_qd, s.particle_q, s.particle_qd) if a is not None and a.shape[0]]
    if stepper.mpm:
        out += [stepper.mpm.state.particle_q, stepper.mpm.state.particle_qd]
    return out

