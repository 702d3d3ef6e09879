"""Stable steps from the materials, and the guard that watches every frame of a run.

Step rules (each gives a largest step; the simulator takes the smallest that applies):

- rigid bodies, tunnelling: no body may travel more than half the thinnest collider in one step,
  ``dt ≤ 0.5·thinnest / v``, ``v`` the fastest speed the scene can reach (initial velocities and pushes,
  plus free fall from the scene's height);
- rigid bodies, mass ratio: XPBD's Gauss–Seidel contacts converge more slowly as the heaviest and
  lightest bodies drift apart, so substeps grow with √(ratio / 100) beyond a ratio of 100;
- cloth: a spring of stiffness ``k`` between particles of mass ``m`` is resolved when
  ``dt ≤ 0.5·√(m / k)`` (the compliance XPBD uses is 1/k);
- soft bodies: the elastic wave √(k/ρ) may cross at most a fifth of a tetrahedral cell per step;
- MPM, CFL: a particle must not cross more than half a spacing per step, neither carried by the flow
  nor by an elastic wave: ``dt ≤ 0.5·h / max(v, √(M/ρ))``. Newton's implicit MPM stays stable beyond
  that bound, so its steps per frame are capped at ``MAX_MPM_STEPS`` and the report says when the cap
  bit.

The guard (:class:`Guard`) checks each frame for non-finite values, speeds beyond ``MAX_SPEED`` and
kinetic + potential energy above the initial energy plus the work done by pushes and force fields by
more than ``ENERGY_TOLERANCE``; the simulator then rolls back to the last good frame and halves the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..rotations import from_wxyz
from .checks import MAX_SPEED

GRAVITY = 9.81
MAX_SUBSTEPS = 1000
MAX_MPM_STEPS = 4
ENERGY_TOLERANCE = 0.05
#: Energies below this (J) are noise, not growth.
ENERGY_FLOOR = 1e-3


def reachable_speed(objects, ground_z: float = 0.0) -> float:
    """Fastest speed (m/s) the scene's own contents give a body: its authored velocity or push plus free
    fall from the highest point to the ground."""
    top = max((float(o.points[:, 2].max()) for o in objects), default=0.0)
    fall = math.sqrt(2 * GRAVITY * max(top - ground_z, 0.0))
    pushed = 0.0
    for o in objects:
        for name in ("physics:velocity", "physomni:initialVelocity"):
            a = o.prim.GetAttribute(name)
            v = a.Get() if a and a.HasAuthoredValue() else None
            if v is not None:
                pushed = max(pushed, float(np.linalg.norm(np.asarray(v, float))))
    return pushed + fall


@dataclass
class StepPlan:
    fps: float
    substeps: int  # rigid / cloth / soft substeps per frame
    mpm_steps: int = 0  # MPM steps per frame (0: no MPM)
    reasons: dict = field(default_factory=dict)

    @property
    def dt(self) -> float:
        return 1.0 / (self.fps * self.substeps)

    @property
    def mpm_dt(self) -> float | None:
        return 1.0 / (self.fps * self.mpm_steps) if self.mpm_steps else None

    def refined(self) -> StepPlan:
        """The same plan at half the step."""
        return StepPlan(self.fps, min(self.substeps * 2, MAX_SUBSTEPS * 4),
                        self.mpm_steps * 2 if self.mpm_steps else 0, dict(self.reasons))

    def as_dict(self) -> dict:
        out = {"fps": self.fps, "substeps": self.substeps, "dt": self.dt, "reasons": self.reasons}
        if self.mpm_steps:
            out |= {"mpm_steps": self.mpm_steps, "mpm_dt": self.mpm_dt}
        return out


def plan_steps(objects, fps: float, base_substeps: int, *, mpm=None, cloth_masses=None,
               cloth_stiffness: float = 0.0, soft_dt: float | None = None,
               fixed_substeps: bool = False) -> StepPlan:
    """Substeps per frame from the scene (see the module's rules). ``base_substeps`` is the solver's
    recommended count; ``fixed_substeps`` keeps it as given (the user asked for it)."""
    frame = 1.0 / fps
    v = reachable_speed(objects)
    reasons = {"base": base_substeps, "reachable_speed_m_s": round(v, 4)}
    need = base_substeps
    moving = [o for o in objects if o.family == "rigid" and not o.fixed]
    colliders = [o for o in objects if o.family == "rigid"]
    if colliders and v > 0:
        thinnest = min(float(np.min(o.trimesh().extents)) for o in colliders)
        tunnel = math.ceil(frame * v / (0.5 * max(thinnest, 1e-4)))
        reasons["tunnelling"] = {"thinnest_m": round(thinnest, 5), "substeps": tunnel}
        need = max(need, tunnel)
    if len(moving) > 1:
        masses = [abs(o.trimesh().volume) * float(o.params.get("density", 1000.0)) for o in moving]
        ratio = max(masses) / max(min(masses), 1e-12)
        if ratio > 100:
            factor = math.ceil(math.sqrt(ratio / 100))
            reasons["mass_ratio"] = {"ratio": round(ratio, 1), "factor": factor}
            need = max(need, base_substeps * factor)
    if cloth_masses is not None and len(cloth_masses) and cloth_stiffness > 0:
        m = float(np.min(cloth_masses[cloth_masses > 0])) if (cloth_masses > 0).any() else 1.0
        dt_cloth = 0.5 * math.sqrt(m / cloth_stiffness)
        reasons["cloth"] = {"dt": dt_cloth, "substeps": math.ceil(frame / dt_cloth)}
        need = max(need, math.ceil(frame / dt_cloth))
    if soft_dt:
        reasons["soft_body"] = {"dt": soft_dt, "substeps": math.ceil(frame / soft_dt)}
        need = max(need, math.ceil(frame / soft_dt))
    substeps = base_substeps if fixed_substeps else min(need, MAX_SUBSTEPS)
    mpm_steps = 0
    if mpm is not None:
        c = max(mpm.wave_speed, v, 1e-6)
        cfl = 0.5 * mpm.spacing / c
        wanted = math.ceil(frame / cfl)
        mpm_steps = max(1, min(wanted, MAX_MPM_STEPS))
        reasons["mpm_cfl"] = {"spacing_m": mpm.spacing, "wave_speed_m_s": round(mpm.wave_speed, 3),
                              "dt": cfl, "steps_wanted": wanted, "steps": mpm_steps,
                              "capped": wanted > MAX_MPM_STEPS}
        # rigid substeps are a whole multiple of the MPM steps, so both meet at every MPM step
        substeps = math.ceil(substeps / mpm_steps) * mpm_steps
    return StepPlan(fps, substeps, mpm_steps, reasons)


class Guard:
    """Energy, speed and finiteness of the whole scene, checked once per frame."""

    def __init__(self, tolerance: float = ENERGY_TOLERANCE, max_speed: float = MAX_SPEED):
        self.tolerance = tolerance
        self.max_speed = max_speed
        self.initial = None
        self.work = 0.0
        self.last_energy = 0.0

    def add_work(self, joules: float) -> None:
        """Energy put in from outside (a push, a force field) since the start."""
        self.work += max(float(joules), 0.0)

    def check(self, energy: float, speed: float, finite: bool) -> str | None:
        """``None`` when the frame is good, else why it is not."""
        if not finite or not math.isfinite(energy):
            return "a value became NaN or infinite"
        if speed > self.max_speed:
            return f"a speed of {speed:.3g} m/s (bound {self.max_speed:g} m/s)"
        if self.initial is None:
            self.initial = energy
        budget = self.initial + self.work
        allowed = budget + self.tolerance * max(abs(budget), ENERGY_FLOOR) + ENERGY_FLOOR
        self.last_energy = energy
        if energy > allowed:
            return (f"the energy grew to {energy:.4g} J, above the initial {self.initial:.4g} J plus "
                    f"{self.work:.4g} J of work")
        return None


def body_energy(model, state) -> tuple[float, float]:
    """Kinetic + gravitational energy (J, z = 0 the ground) of the rigid bodies, and their top speed."""
    if not model.body_count:
        return 0.0, 0.0
    q = state.body_q.numpy().astype(np.float64)
    qd = state.body_qd.numpy().astype(np.float64)
    mass = model.body_mass.numpy().astype(np.float64)
    inertia = model.body_inertia.numpy().astype(np.float64)
    com = model.body_com.numpy().astype(np.float64)
    rot = np.stack([from_wxyz((w, x, y, z)) for x, y, z, w in q[:, 3:7]])
    com_world = q[:, :3] + np.einsum("bij,bj->bi", rot, com)
    w_body = np.einsum("bji,bj->bi", rot, qd[:, 3:])
    kinetic = 0.5 * mass * (qd[:, :3] ** 2).sum(1) + 0.5 * np.einsum("bi,bij,bj->b", w_body, inertia, w_body)
    energy = float((kinetic + mass * GRAVITY * com_world[:, 2]).sum())
    return energy, float(np.linalg.norm(qd[:, :3], axis=1).max())


def particle_energy(model, state) -> tuple[float, float]:
    """Kinetic + gravitational energy (J) of a model's particles, and their top speed."""
    if not model.particle_count:
        return 0.0, 0.0
    x = state.particle_q.numpy().astype(np.float64)
    v = state.particle_qd.numpy().astype(np.float64)
    m = model.particle_mass.numpy().astype(np.float64)
    moving = m > 0
    e = float((0.5 * m * (v ** 2).sum(1) + m * GRAVITY * x[:, 2]).sum())
    speed = float(np.linalg.norm(v[moving], axis=1).max()) if moving.any() else 0.0
    return e, speed
