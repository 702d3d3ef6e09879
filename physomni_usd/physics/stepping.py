"""The one place that builds Newton's solvers and steps a scene through a frame: substeps, when
contacts are searched (``StepPlan.collide_interval``), MPM steps interleaved with the rigid substeps,
force fields applied, pushes given. ``simulate``, ``bench physics`` and the tests all step through
:class:`Stepper`, so that what is measured is what the simulator runs."""

from __future__ import annotations

import time

import numpy as np

from .controls import give_velocities
from .mpm import add_particle_forces, step_particles
from .stability import StepPlan, body_energy, particle_energy


def xpbd_solver(model, iterations: int):
    """The simulator's XPBD solver for ``model``."""
    import newton

    # Newton leaves restitution off by default; the materials author it, so it must act
    return newton.solvers.SolverXPBD(model, iterations=iterations, enable_restitution=True)


def contact_pipeline(model):
    """The simulator's contact search for ``model`` and the contacts it fills."""
    import newton

    # sticky contact matching keeps a resting hull's contact points from frame to frame;
    # without it XPBD lets flat-based hulls creep by millimetres per second
    pipeline = newton.CollisionPipeline(model, contact_matching="sticky")
    return pipeline, pipeline.contacts()


def _ignore(joules: float) -> None:
    pass


def run_frames(stepper: Stepper, plan: StepPlan, frames: int, after_frame=None, after_mpm_step=None) -> float:
    """Step ``frames`` frames from t = 0 without the guard (benchmarks, tests); ``after_frame(f)`` is called
    after frame ``f`` (1, 2, …). Returns the wall seconds spent stepping."""
    t0 = time.perf_counter()
    step = 0
    for f in range(frames):
        stepper.frame(plan, f / plan.fps, step, after_mpm_step=after_mpm_step)
        step += plan.substeps
        if after_frame is not None:
            after_frame(f + 1)
    return time.perf_counter() - t0


class Stepper:
    """Advances a Newton model (rigid bodies, cloth, soft bodies: ``solver``) and an optional MPM scene
    coupled to it, a frame at a time; ``state`` is always the current state."""

    def __init__(self, model, solver=None, *, pipeline=None, contacts=None, fields=None, mpm=None, pushes=()):
        self.model, self.solver = model, solver
        self.state, self.state_next = model.state(), model.state()
        self.control = model.control()
        self.pipeline, self.contacts = pipeline, contacts
        self.fields, self.mpm = fields, mpm
        self.pending = sorted(pushes, key=lambda p: p.at)

    def energy(self) -> tuple[float, float]:
        """Kinetic + gravitational energy (J) of everything stepped, and the top speed (m/s)."""
        e_b, v_b = body_energy(self.model, self.state)
        e_p, v_p = particle_energy(self.model, self.state)
        e_m, v_m = particle_energy(self.mpm.model, self.mpm.state) if self.mpm else (0.0, 0.0)
        return e_b + e_p + e_m, max(v_b, v_p, v_m)

    def frame(self, plan: StepPlan, t0: float, step0: int, add_work=None, speed: float | None = None,
              after_mpm_step=None) -> None:
        """One frame from time ``t0`` (substep counter ``step0``), the fastest body moving at ``speed`` m/s
        at its start (None: read from the state); the work pushes and fields do goes to ``add_work`` (J);
        ``after_mpm_step(t)`` is called after each MPM step."""
        add_work = add_work or _ignore
        if speed is None:
            speed = self.energy()[1] if plan.collide_every > 1 else 0.0
        for p in self.pending:  # a push due in this frame counts as the speed it gives
            if p.at < t0 + 1.0 / plan.fps and p.linear is not None:
                speed = max(speed, float(np.linalg.norm(p.linear)))
        collide_every = plan.collide_interval(speed)
        if self.solver is not None and plan.iterations:
            self.solver.iterations = plan.iterations
        if hasattr(self.solver, "enable_restitution"):
            self.solver.enable_restitution = plan.restitution
        groups = plan.mpm_steps or 1
        per = plan.substeps // groups
        dt = plan.dt
        step = step0
        fields = self.fields
        for _ in range(groups):
            for _ in range(per):
                t = t0 + (step - step0) * dt
                if self.pending and self.pending[0].at <= t + 1e-9:
                    self._give_velocities(t, add_work)
                if self.solver is not None:
                    self.state.clear_forces()
                    if fields is not None:
                        fields.apply(self.model, self.state, t, step)
                    if self.mpm:
                        add_particle_forces(self.mpm, self.state)
                    if self.pipeline is not None and (step - step0) % collide_every == 0:
                        self.pipeline.collide(self.state, self.contacts)
                    self.solver.step(self.state, self.state_next, self.control, self.contacts, dt)
                    self.state, self.state_next = self.state_next, self.state
                step += 1
            if self.mpm:
                t = t0 + (step - step0) * dt
                self.mpm.state.clear_forces()
                if fields is not None:
                    fields.apply(self.mpm.model, self.mpm.state, t, step)
                step_particles(self.mpm, self.model, self.state, plan.mpm_dt)
                if after_mpm_step is not None:
                    after_mpm_step(t)
        if fields:
            add_work(self._field_work(t0, step0, 1.0 / plan.fps))

    def _field_work(self, t: float, step: int, seconds: float) -> float:
        """Work (J, signed) the force fields did over the last frame, from the end-of-frame velocities."""
        work = 0.0
        m = self.model
        if m.body_count:
            q, qd = self.state.body_q.numpy(), self.state.body_qd.numpy()
            a = self.fields.acceleration(q[:, :3], qd[:, :3], t, step)
            work += float((m.body_mass.numpy() * np.einsum("ij,ij->i", a, qd[:, :3])).sum()) * seconds
        for model, state in ((m, self.state), (self.mpm.model, self.mpm.state) if self.mpm else (None, None)):
            if model is None or not model.particle_count:
                continue
            x, v = state.particle_q.numpy(), state.particle_qd.numpy()
            a = self.fields.acceleration(x, v, t, step)
            work += float((model.particle_mass.numpy() * np.einsum("ij,ij->i", a, v)).sum()) * seconds
        return work

    def _give_velocities(self, t: float, add_work) -> None:
        """Give the pushes due at ``t``; the kinetic energy they add counts as work."""
        due = [p for p in self.pending if p.at <= t + 1e-9]
        self.pending = [p for p in self.pending if p.at > t + 1e-9]
        before = self.energy()[0]
        give_velocities(due, self.state, self.mpm.state if self.mpm else None)
        add_work(self.energy()[0] - before)
