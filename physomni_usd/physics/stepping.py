"""The one place that builds Newton's solvers and steps a scene through a frame: substeps, when
contacts are searched (``StepPlan.collide_interval``), MPM steps interleaved with the rigid substeps,
force fields applied, pushes given. ``simulate``, ``bench physics`` and the tests all step through
:class:`Stepper`, so that what is measured is what the simulator runs."""

from __future__ import annotations

import time
from functools import cached_property, lru_cache

import numpy as np

from ..fields import FIELD_KIND
from .controls import give_velocities
from .mpm import add_particle_forces, step_particles
from .snapshots import restore, snapshot
from .stability import PARTICLE_CONTACT_GAP, StepPlan, body_energy, particle_energy


def xpbd_solver(model, iterations: int):
    """The simulator's XPBD solver for ``model``."""
    from .._warp import newton_solver

    # Newton leaves restitution off by default; the materials author it, so it must act
    return newton_solver("SolverXPBD")(model, iterations=iterations, enable_restitution=True)


def contact_pipeline(model):
    """The simulator's contact search for ``model`` and the contacts it fills."""
    from .._warp import load_newton

    newton = load_newton()

    # sticky contact matching keeps a resting hull's contact points from frame to frame;
    # without it XPBD lets flat-based hulls creep by millimetres per second
    pipeline = newton.CollisionPipeline(model, contact_matching="sticky", soft_contact_gap=PARTICLE_CONTACT_GAP)
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

    def __init__(self, model, solver=None, *, pipeline=None, contacts=None, fields=None, mpm=None, pushes=(), air=None,
                 damping=None):
        self.model, self.solver = model, solver
        self.state, self.state_next = model.state(), model.state()
        self.control = model.control()
        self.pipeline, self.contacts = pipeline, contacts
        self.fields, self.mpm = fields, mpm
        self.air = air  # cloths' air resistance (cloth.AirDrag), or None
        self.damping = damping  # soft bodies' deformation damping (cloth.ShapeDamping), or None
        self.pending = sorted(pushes, key=lambda p: p.at)
        self._work = None  # (1,) float64 on the device: the fields' work (J) since it was last read
        #: forces added every rigid substep after the fields', outside their work: callables
        #: ``(model, state, t, dt)`` adding to ``state.body_f`` / ``particle_f`` (the preview's hand)
        self.extra_forces = []
        #: whether the fields' work is summed for the guard (kernels a substep, a read-back a frame);
        #: off where no guard reads it, so that a frame can be captured as one graph
        self.count_work = True
        #: the bound on the speed start overlaps separate at (``depenetration.Depenetration``), or None
        self.depenetration = None
        #: the particles that bound may hold (cloth: an elastic solid's own oscillation must not be
        #: clipped), or None for every particle
        self.separating_particles = None

    def checkpoint(self, into=None):
        """Copies of the state (the MPM scene's included) and the pending pushes, for :meth:`restore`;
        ``into``, an earlier checkpoint no longer needed, is written over rather than new arrays allocated."""
        import warp as wp

        old = into[0] if into is not None else []
        snaps = [snapshot(self.state, old[0] if old else None)]
        if self.mpm:
            force = old[2][""] if len(old) > 2 else None
            if force is None or force.shape != self.mpm.body_force.shape:
                force = wp.clone(self.mpm.body_force)
            else:
                wp.copy(force, self.mpm.body_force)
            snaps += [snapshot(self.mpm.state, old[1] if len(old) > 1 else None), {"": force}]
        return snaps, list(self.pending)

    def restore(self, saved) -> None:
        """Put a :meth:`checkpoint` back, into the same arrays."""
        snaps, pending = saved
        self.pending = list(pending)
        restore(self.state, snaps[0])
        if self.mpm:
            restore(self.mpm.state, snaps[1])
            self.mpm.body_force.assign(snaps[2][""])

    def energy(self) -> tuple[float, float]:
        """Kinetic + gravitational energy (J) of everything stepped, and the top speed (m/s)."""
        e_b, v_b = body_energy(self.model, self.state)
        e_p, v_p = particle_energy(self.model, self.state)
        e_m, v_m = particle_energy(self.mpm.model, self.mpm.state) if self.mpm else (0.0, 0.0)
        return e_b + e_p + e_m, max(v_b, v_p, v_m)

    def frame(self, plan: StepPlan, t0: float, step0: int, add_work=None, speed: float | None = None,
              after_mpm_step=None, read_work: bool = True, capturing: bool = False) -> None:
        """One frame from time ``t0`` (substep counter ``step0``), the fastest body moving at ``speed`` m/s
        at its start (None: read from the state); the work pushes and fields do goes to ``add_work`` (J);
        ``after_mpm_step(t)`` is called after each MPM step. ``read_work`` False leaves the fields' work summed
        on the device (a frame being captured reads nothing back; :meth:`take_work` reads it after); ``capturing``
        says the frame is being recorded as a graph, whose caller writes the frame's time to the device."""
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
            self.solver.rigid_contact_restitution_iterations = plan.restitution_passes(speed)
        by_substep = self._passes_by_substep(plan, speed)
        groups = plan.mpm_steps or 1
        per = plan.substeps // groups
        dt = plan.dt
        step = step0
        fields = self.fields
        bound = self.depenetration if self.depenetration is not None and self.depenetration.active(t0) else None
        if bound is not None and not capturing:
            bound.set_time(t0)
        for _ in range(groups):
            for _ in range(per):
                t = t0 + (step - step0) * dt
                if self.pending and self.pending[0].at <= t + 1e-9:
                    self._give_velocities(t, add_work)
                if self.solver is not None:
                    self.state.clear_forces()
                    held = None
                    if fields:
                        fields.apply(self.model, self.state, t, step, dt)
                        held = self._work_before(self.model, self.state, dt) if self.count_work else None
                    for force in self.extra_forces:
                        force(self.model, self.state, t, dt)
                    if self.air is not None:
                        self.air.apply(self.model, self.state)
                    if self.mpm:
                        add_particle_forces(self.mpm, self.state)
                    if self.pipeline is not None and (step - step0) % collide_every == 0:
                        self.pipeline.collide(self.state, self.contacts)
                    if by_substep:
                        self._step_by_impact(plan, dt)
                    else:
                        self._solver_step(dt)
                    self.state, self.state_next = self.state_next, self.state
                    if self.damping is not None:
                        self.damping.apply(self.model, self.state, dt)
                    if bound is not None:
                        bound.apply(self.model, self.state, (step - step0 + 1) * dt)
                    if held is not None:
                        self._work_after(held, self.state, dt)
                step += 1
            if self.mpm:
                t = t0 + (step - step0) * dt
                self.mpm.state.clear_forces()
                held = None
                if fields:
                    fields.apply(self.mpm.model, self.mpm.state, t, step, plan.mpm_dt)
                    held = self._work_before(self.mpm.model, self.mpm.state, plan.mpm_dt) if self.count_work else None
                step_particles(self.mpm, self.model, self.state, plan.mpm_dt)
                if held is not None:
                    self._work_after(held, self.mpm.state, plan.mpm_dt)
                if after_mpm_step is not None:
                    after_mpm_step(t)
        if fields and self.count_work and read_work:
            add_work(self._read_work())

    def _passes_by_substep(self, plan: StepPlan, speed: float) -> bool:
        """Whether this frame chooses its restitution passes substep by substep (``impacts``): a frame that may
        hold an impact, stepped by XPBD with restitution on against a contact buffer, on a device whose captured
        frames can branch (every CPU; CUDA with conditional graph nodes)."""
        import warp as wp

        if not (plan.restitution and self.contacts is not None and self.pipeline is not None
                and hasattr(self.solver, "rigid_contact_restitution_iterations") and self.model.body_count
                and plan.restitution_passes(speed) != plan.restitution_passes(0.0)):
            return False
        device = self.model.device
        return device.is_cpu or wp.is_conditional_graph_supported()

    def _step_by_impact(self, plan: StepPlan, dt: float) -> None:
        """One XPBD substep with the full restitution passes where a contact about to touch closes or parts
        faster than ``IMPACT_SPEED`` (``impacts.impact_kernel``), the default passes elsewhere; decided on the
        device, so a captured frame replays the choice."""
        import warp as wp

        from .impacts import impact_kernel
        from .stability import IMPACT_SPEED

        c, m = self.contacts, self.model
        flag = self.__dict__.get("_impact_flag")
        if flag is None:
            flag = self._impact_flag = wp.zeros(1, dtype=wp.int32, device=m.device)
        flag.zero_()
        # within reach: a contact no further apart than the solver's own resting speed covers in the substep
        wp.launch(impact_kernel(), dim=c.rigid_contact_max,
                  inputs=[c.rigid_contact_count, c.rigid_contact_shape0, c.rigid_contact_shape1,
                          c.rigid_contact_point0, c.rigid_contact_point1, c.rigid_contact_normal,
                          c.rigid_contact_margin0, c.rigid_contact_margin1, m.shape_body, self.state.body_q,
                          self.state.body_qd, m.body_com, dt, (IMPACT_SPEED + plan.acceleration * dt) * dt,
                          IMPACT_SPEED],
                  outputs=[flag], device=m.device)
        full, rest = plan.restitution_passes(1e9), plan.restitution_passes(0.0)
        solver = self.solver

        def step(passes):
            solver.rigid_contact_restitution_iterations = passes
            self._solver_step(dt)

        wp.capture_if(flag, on_true=lambda: step(full), on_false=lambda: step(rest))

    def _solver_step(self, dt: float) -> None:
        """One substep of the solver; XPBD's restitution passes after one that changed nothing are skipped
        (``impacts.PassGate``: the same result) where the device can branch within a captured frame."""
        args = (self.state, self.state_next, self.control, self.contacts, dt)
        if self._pass_gate is None:
            self.solver.step(*args)
        else:
            self._pass_gate.step(self.solver, *args)

    @cached_property
    def _pass_gate(self):
        """The :class:`~.impacts.PassGate` for this solver, or None where it cannot act; made on first use."""
        return self._make_gate()

    def _make_gate(self):
        import warp as wp

        from .impacts import PassGate

        if not (self.contacts is not None and self.model.body_count
                and hasattr(self.solver, "rigid_contact_restitution_iterations")):
            return None
        if not (self.model.device.is_cpu or wp.is_conditional_graph_supported()):
            return None
        gate = PassGate(self.solver)
        return gate if gate.usable else None

    def take_work(self) -> float:
        """The fields' work (J) summed on the device since it was last read, and zero it."""
        return self._read_work()

    # --- the fields' work ------------------------------------------------------------------------
    # A field's force F (and torque τ about the centre of mass) is constant over a step, evaluated at
    # the sample points at the step's start; the kinetic energy it gives in the step is
    # F·(v₀ + v₁)/2·dt + τ·(ω₀ + ω₁)/2·dt, v₀ and v₁ the velocities before and after the step. Summed
    # per step on the device, so a field that starts mid-frame or one that spins a body is accounted.

    def _work_before(self, model, state, dt: float):
        """Add the first half of this step's field work; returns the field forces, kept for the second."""
        import warp as wp

        body_power, particle_power = _power_kernels()
        if self._work is None:
            self._work = wp.zeros(1, dtype=wp.float64, device=model.device)
        held = []
        if model.body_count and state.body_f is not None:
            f = self._held_copy(("body", id(model)), state.body_f)
            wp.launch(body_power, dim=model.body_count, inputs=[f, state.body_qd, 0.5 * dt], outputs=[self._work],
                      device=model.device)
            held.append(("body", f))
        if model.particle_count and state.particle_f is not None:
            f = self._held_copy(("particle", id(model)), state.particle_f)
            wp.launch(particle_power, dim=model.particle_count, inputs=[f, state.particle_qd, 0.5 * dt],
                      outputs=[self._work], device=model.device)
            held.append(("particle", f))
        return held

    def _held_copy(self, key, src):
        """``src`` copied into a buffer kept per ``key``: the same array every step, so that a captured
        frame allocates nothing and its replays read what they wrote."""
        import warp as wp

        held = self.__dict__.setdefault("_held", {})
        buf = held.get(key)
        if buf is None or buf.shape != src.shape:
            buf = held[key] = wp.empty_like(src)
        wp.copy(buf, src)
        return buf

    def _work_after(self, held, state, dt: float) -> None:
        import warp as wp

        body_power, particle_power = _power_kernels()
        for kind, f in held:
            kernel, v = (body_power, state.body_qd) if kind == "body" else (particle_power, state.particle_qd)
            wp.launch(kernel, dim=f.shape[0], inputs=[f, v, 0.5 * dt], outputs=[self._work], device=f.device)

    def _read_work(self) -> float:
        if self._work is None:
            return 0.0
        joules = float(self._work.numpy()[0])
        self._work.zero_()
        return joules

    def _give_velocities(self, t: float, add_work) -> None:
        """Give the pushes due at ``t``; the kinetic energy they add counts as work."""
        due = [p for p in self.pending if p.at <= t + 1e-9]
        self.pending = [p for p in self.pending if p.at > t + 1e-9]
        before = self.energy()[0]
        give_velocities(due, self.state, self.mpm.state if self.mpm else None)
        add_work(self.energy()[0] - before)


class FrameGraphs:
    """A :class:`Stepper`'s frames captured as warp graphs and replayed (one Python call a frame instead of
    a dozen kernel launches a substep), for rigid scenes stepped by XPBD; a frame the graph cannot
    reproduce runs launch by launch. A graph is keyed by everything the frame bakes in: substeps,
    iterations, restitution and its passes, contact-search cadence, which fields are on, and which of the two
    state buffers it starts from. A device or scene that cannot capture falls back for good (``error`` says why)."""

    def __init__(self, stepper: Stepper, enabled: bool = True):
        self.stepper = stepper
        self.graphs: dict = {}
        self.seen: set = set()  # keys met once: a schedule's first frame runs launch by launch
        self.enabled = enabled and self.supported(stepper)
        self.error: str | None = None
        self.captured_frames = 0  # frames replayed from a graph
        self.captures = 0  # graphs recorded

    @staticmethod
    def supported(stepper: Stepper) -> bool:
        """Rigid bodies only, stepped by XPBD: deformables and MPM (host-side schedules, read-backs) are not."""
        import newton

        m = stepper.model
        return (stepper.mpm is None and stepper.air is None and not m.particle_count and m.body_count > 0
                and isinstance(stepper.solver, newton.solvers.SolverXPBD))

    def key(self, plan: StepPlan, t0: float, speed: float):
        """What a captured frame from ``t0`` depends on, or None where it must run launch by launch (a
        push due in it, a noise field on, a field switching on or off within it)."""
        stepper = self.stepper
        if not self.enabled:
            return None
        frame = 1.0 / plan.fps
        if stepper.pending and stepper.pending[0].at < t0 + frame + 1e-9:
            return None
        fields = stepper.fields
        active = ()
        if fields:
            active = tuple(f.active(t0) for f in fields.fields)
            if active != tuple(f.active(t0 + frame) for f in fields.fields):
                return None
            if any(FIELD_KIND[f.kind].draws_each_step and on for f, on in zip(fields.fields, active)):
                return None
            fields._set_time(t0)  # the mask the graph reads, written outside the capture
        bound = stepper.depenetration is not None and stepper.depenetration.active(t0)
        if bound:
            stepper.depenetration.set_time(t0)  # likewise the time the overlap bound reads
        return (plan.substeps, plan.iterations, plan.restitution, plan.restitution_passes(speed),
                plan.collide_interval(speed), id(stepper.state), active, stepper.count_work, bound, id(fields))

    def frame(self, plan: StepPlan, t0: float, step0: int, add_work=None, speed: float = 0.0) -> bool:
        """One frame as :meth:`Stepper.frame` steps it; returns whether it was replayed from a graph."""
        import warp as wp

        stepper = self.stepper
        key = self.key(plan, t0, speed)
        if key is None:
            stepper.frame(plan, t0, step0, add_work, speed)
            return False
        graph = self.graphs.get(key)
        if graph is None and key not in self.seen:
            # its first frame loads the kernels and allocates the buffers the capture then reuses
            self.seen.add(key)
            stepper.frame(plan, t0, step0, add_work, speed)
            return False
        if graph is None:
            before = (stepper.state, stepper.state_next)
            device = stepper.model.device
            try:
                with wp.ScopedCapture(device=device) as capture:
                    stepper.frame(plan, t0, step0, add_work, speed, read_work=False, capturing=True)
            except Exception as exc:  # an operation warp cannot record: this scene steps launch by launch
                stepper.state, stepper.state_next = before
                self.enabled, self.error = False, f"{type(exc).__name__}: {exc}"
                self.graphs.clear()
                stepper.frame(plan, t0, step0, add_work, speed)
                return False
            # a CPU capture records without running; a replay ends in the buffers the recording ended in
            graph = self.graphs[key] = (capture.graph, stepper.state, stepper.state_next)
            stepper.state, stepper.state_next = before
            self.captures += 1
        wp.capture_launch(graph[0])
        stepper.state, stepper.state_next = graph[1], graph[2]
        if stepper.fields and stepper.count_work and add_work is not None:
            add_work(stepper.take_work())
        self.captured_frames += 1
        return True


@lru_cache(maxsize=1)
def _power_kernels():
    """Kernels adding ``scale``·(force · velocity) (bodies: + torque · angular velocity) to ``out[0]``."""
    import warp as wp

    @wp.kernel
    def body_power(f: wp.array(dtype=wp.spatial_vector), qd: wp.array(dtype=wp.spatial_vector), scale: float,
                   out: wp.array(dtype=wp.float64)):
        b = wp.tid()
        w = f[b]
        v = qd[b]
        p = wp.dot(wp.spatial_top(w), wp.spatial_top(v)) + wp.dot(wp.spatial_bottom(w), wp.spatial_bottom(v))
        wp.atomic_add(out, 0, wp.float64(scale * p))

    @wp.kernel
    def particle_power(f: wp.array(dtype=wp.vec3), v: wp.array(dtype=wp.vec3), scale: float,
                       out: wp.array(dtype=wp.float64)):
        i = wp.tid()
        wp.atomic_add(out, 0, wp.float64(scale * wp.dot(f[i], v[i])))

    return body_power, particle_power
