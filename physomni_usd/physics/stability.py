"""Stable steps from the materials, and the guard that watches every frame of a run.

Step rules (each gives a largest step; the simulator takes the smallest that applies):

- rigid bodies, tunnelling: no body may travel more than half the thinnest collider in one step,
  ``dt ≤ 0.5·thinnest / v``, ``v`` the fastest speed the scene can reach (initial velocities and pushes,
  plus free fall from the scene's height);
- rigid bodies, force fields: what a field's largest acceleration ``a`` adds in one step stays under
  half the thinnest collider, ``dt ≤ √(0.5·thinnest / a)``; beyond 10 g, XPBD iterations grow with
  log₁₀(a/g), or a body pressed hard into the ground is thrown up when the push ends, and restitution
  is turned off (XPBD takes an approach faster than 2·g·dt for an impact, and a body pressed by many g
  approaches that fast every step);
- rigid bodies, mass ratio: XPBD's Gauss–Seidel contacts converge more slowly as the heaviest and
  lightest bodies drift apart, so substeps and iterations both grow with √(ratio / 100) beyond a
  ratio of 100;
- rigid bodies, piles: a body held by two or more others at once (a fruit in a pile's hollow) pushes them
  apart, and only friction at both of each supporter's contacts holds them; XPBD's Gauss–Seidel passes at
  the default iterations leave those contacts unconverged and the pile creeps apart, so iterations grow to
  ``PILE_ITERATIONS`` (:func:`held_by_several`);
- cloth: a spring of stiffness ``k`` between particles of mass ``m`` is resolved when
  ``dt ≤ c·√(m / k)`` (the compliance XPBD uses is 1/k), ``c = CLOTH_FACTOR``;
- soft bodies: the elastic wave √(k/ρ) may cross at most a fifth of a tetrahedral cell per step;
- MPM, CFL: a particle must not cross more than half a spacing per step, neither carried by the flow
  nor by an elastic wave: ``dt ≤ 0.5·h / max(v, √(M/ρ))``. Newton's implicit MPM stays stable beyond
  that bound, so its steps per frame are capped at what ``bench physics`` found accurate for the
  scene's kinds of material (``MPM_STEPS``) and the report says when the cap bit.

The guard (:class:`Guard`) checks each frame for non-finite values, speeds beyond ``MAX_SPEED`` and
kinetic + potential energy above the initial energy plus the work done by pushes and force fields by
more than ``ENERGY_TOLERANCE``; the simulator then rolls back to the last good frame and halves the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..settings import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from .checks import MAX_SPEED

GRAVITY = 9.81
MAX_SUBSTEPS = 1000
#: XPBD substeps per frame (30 fps) for each kind of rigid scene: the cheapest setting that met the 1 %
#: target in ``physomni-usd bench physics`` on that kind's reference cases — free motion and sliding
#: (free fall, incline, free rotation), drag fields (linear and quadratic drag), bouncing (restitution
#: apex heights), stacks (a resting stack of five boxes).
RIGID_SUBSTEPS = {"free": DEFAULT_SUBSTEPS, "drag": 16, "bouncy": 16, "stacked": 32}
#: Cloth: dt ≤ CLOTH_FACTOR·√(m/k). From ``bench physics``' cloth sag (the simulator's springs, damping
#: and iterations): c = 0.21 blew up, 0.14 jittered 10 % off the resting sag, 0.104 came within 0.2 %
#: of the 256-substep run.
CLOTH_FACTOR = 0.1
#: Restitution from which a scene counts as bouncy.
BOUNCY = 0.3
#: MPM steps per frame (at 30 fps) by kind of material, from ``bench physics``: the cheapest setting
#: meeting the target of that kind's reference case — the elastic bar's frequency (1 %) at 16, the
#: dam break's front (10 %) at 2; the granular column missed its 15 % at every setting and its error
#: stopped falling at 4. The CFL bound (below) asks for more; the implicit solver is stable without.
MPM_STEPS = {"elastic": 16, "granular": 4, "liquid": 2}
ENERGY_TOLERANCE = 0.05
#: Outer passes of XPBD's restitution solve in a frame that may hold an impact (something moving faster than
#: ``IMPACT_SPEED`` at its start), and in any other frame (Newton's default). The pass couples the contacts
#: of different body pairs by averaging, so a body pressed between two others (a saucer under a thrown spoon,
#: on the ground) converges one pair per pass; at 2 it stops halfway, and what is left is the velocity the
#: position correction gave while pushing the overlap out, which the next substep keeps as a separation: a
#: 5 mm steel spoon thrown at 3 m/s onto a saucer rose 12 mm above where it came to rest at restitution 0,
#: and onto a 5 mm plate 4.3 cm of the 41 cm e²v²/2g at 0.9. At 16 passes: 2 mm (the frame it lands in)
#: and 40 cm, as on a fixed saucer; 8 passes reached 32 cm. Within a frame that may hold an impact the full
#: passes go only to the substeps where a contact meets its pair faster than ``IMPACT_SPEED`` (``impacts``):
#: the rest of the frame keeps Newton's default, as a slow frame does.
RESTITUTION_PASSES = (16, 2)
#: m/s: a frame whose fastest body starts slower than this holds no impact worth the passes (objects at
#: rest, a start overlap separating at up to ``depenetration.SEPARATION_SPEED``).
IMPACT_SPEED = 0.15
#: XPBD iterations for a scene with a pile (:func:`held_by_several`). A fruit resting on three others, nothing
#: pushed, over 2 s (a generated scene of two piles of four fruits, 8 substeps): at 2 iterations the supporters
#: rolled apart and it fell 11 cm, at 8 it held for a second and then fell 7 cm, at 16 nothing moved 5 mm.
PILE_ITERATIONS = 16
#: A body touches another below it where its lower half comes this close (m) to it.
PILE_CONTACT_M = 0.003
#: Energies below this (J) are noise, not growth.
ENERGY_FLOOR = 1e-3
#: m beyond a particle's radius within which the contact search gives it a contact with a shape (Newton's
#: default, written here because the reuse of particle contacts is bounded by it: a contact found at a search
#: serves while the particle cannot have closed more than half of this on a shape it had none with).
PARTICLE_CONTACT_GAP = 0.01


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


def held_by_several(objects) -> list[str]:
    """The rigid objects of ``objects`` that rest on two or more other rigid objects at once: their lower half
    within :data:`PILE_CONTACT_M` of each, and each lower (a fruit in a pile's hollow, a board over two boxes)."""
    import trimesh

    rigid = [o for o in objects if o.family == "rigid"]
    boxes = [(o.points.min(axis=0), o.points.max(axis=0)) for o in rigid]
    out = []
    for i, a in enumerate(rigid):
        if a.fixed:
            continue
        lo_a, hi_a = boxes[i]
        low = a.points[a.points[:, 2] <= 0.5 * (lo_a[2] + hi_a[2])]
        under = 0
        for j, b in enumerate(rigid):
            lo_b, hi_b = boxes[j]
            if j == i or lo_b[2] >= lo_a[2] or np.any(lo_a - PILE_CONTACT_M > hi_b) \
                    or np.any(lo_b - PILE_CONTACT_M > hi_a):
                continue
            near = low[np.all((low >= lo_b - PILE_CONTACT_M) & (low <= hi_b + PILE_CONTACT_M), axis=1)]
            if len(near) and float(trimesh.proximity.signed_distance(b.trimesh(), near).max()) > -PILE_CONTACT_M:
                under += 1
                if under >= 2:
                    out.append(a.name)
                    break
    return out


def scene_kinds(objects, field_kinds=()) -> list[str]:
    """Which kinds of :data:`RIGID_SUBSTEPS` a scene is: always 'free', plus 'drag' (a drag field),
    'bouncy' (a rigid restitution ≥ BOUNCY) and 'stacked' (a rigid object resting on another, or inside it
    above its bottom: in an open vessel)."""
    kinds = ["free"]
    rigid = [o for o in objects if o.family == "rigid"]
    if "drag" in field_kinds:
        kinds.append("drag")
    if any(float(o.params.get("restitution", 0.0)) >= BOUNCY for o in rigid):
        kinds.append("bouncy")
    boxes = [(o.points.min(axis=0), o.points.max(axis=0)) for o in rigid]
    for i, (lo_a, hi_a) in enumerate(boxes):
        for j, (lo_b, hi_b) in enumerate(boxes):
            overlap = min(hi_a[0], hi_b[0]) > max(lo_a[0], lo_b[0]) and min(hi_a[1], hi_b[1]) > max(lo_a[1], lo_b[1])
            tol = 0.01 * max(hi_b[2] - lo_b[2], 1e-3) + 1e-3
            # on top of it, or inside it above its bottom (a ball on an open bowl's inner floor)
            within = bool(np.all(lo_a[:2] >= lo_b[:2]) and np.all(hi_a[:2] <= hi_b[:2])
                          and lo_b[2] + tol < lo_a[2] < hi_b[2])
            if i != j and overlap and (abs(lo_a[2] - hi_b[2]) < tol or within):
                kinds.append("stacked")
                break
        if "stacked" in kinds:
            break
    return kinds


@dataclass
class StepPlan:
    fps: float
    substeps: int  # rigid / cloth / soft substeps per frame
    mpm_steps: int = 0  # MPM steps per frame (0: no MPM)
    reasons: dict = field(default_factory=dict)
    iterations: int | None = None  # XPBD iterations, None: the shot's
    collide_every: int = 1  # contacts are found at most every this many substeps
    thinnest: float | None = None  # m, the thinnest rigid collider, for :meth:`collide_interval`
    acceleration: float = GRAVITY  # m/s², the largest a body can get (gravity, force fields)
    restitution: bool = True  # XPBD restitution on (see ``plan_steps`` for when it is not)
    particle_gap: float | None = None  # m, the particles' contact gap where the model steps particles

    def collide_interval(self, speed: float) -> int:
        """Substeps between contact searches for a frame whose fastest body or particle starts at ``speed``
        (m/s, linear: a body's spin is not counted): contacts found at a search hold while nothing moves more
        than a quarter of the thinnest collider, nor a particle more than half its contact gap
        (:data:`PARTICLE_CONTACT_GAP`)."""
        reach = [0.25 * self.thinnest] if self.thinnest else []
        if self.particle_gap:
            reach.append(0.5 * self.particle_gap)
        if self.collide_every <= 1 or not reach:
            return 1
        v = speed + self.acceleration / self.fps
        return max(1, min(self.collide_every, int(min(reach) / max(v * self.dt, 1e-12))))

    def restitution_passes(self, speed: float) -> int:
        """Outer passes of the restitution solve for a frame starting at ``speed`` (m/s; see
        :data:`RESTITUTION_PASSES`)."""
        return RESTITUTION_PASSES[0] if speed > IMPACT_SPEED else RESTITUTION_PASSES[1]

    @property
    def dt(self) -> float:
        return 1.0 / (self.fps * self.substeps)

    @property
    def mpm_dt(self) -> float | None:
        return 1.0 / (self.fps * self.mpm_steps) if self.mpm_steps else None

    def refined(self) -> StepPlan:
        """The same plan at half the step and twice the iterations. A rigid plan finds contacts every substep;
        a plan stepping particles, whose substeps a light cloth sets, searches half as many substeps apart
        (four times as often a frame, still bounded by ``collide_interval``): the run keeps the refined plan
        for the rest of the take, and a search every substep would cost a cloth scene 2000 a frame."""
        collide_every = max(1, self.collide_every // 2) if self.particle_gap else 1
        return StepPlan(self.fps, min(self.substeps * 2, MAX_SUBSTEPS * 4),
                        self.mpm_steps * 2 if self.mpm_steps else 0, dict(self.reasons),
                        min(self.iterations * 2, 200) if self.iterations else None, collide_every, self.thinnest,
                        self.acceleration, self.restitution, self.particle_gap)

    def as_dict(self) -> dict:
        out = {"fps": self.fps, "substeps": self.substeps, "dt": self.dt, "iterations": self.iterations,
               "collide_every": self.collide_every, "restitution": self.restitution, "reasons": self.reasons}
        if self.mpm_steps:
            out |= {"mpm_steps": self.mpm_steps, "mpm_dt": self.mpm_dt}
        return out


def contact_reuse(substeps: int, particles: bool = False, others: int | None = None) -> int:
    """Most substeps one contact search serves (``StepPlan.collide_every``). A search costs more than an
    XPBD substep, so rigid scenes search again only as often as their bodies' speed needs
    (:meth:`StepPlan.collide_interval`), at most once a frame. A scene stepping particles searches at least
    ``others`` times a frame, the substeps all but its cloths ask (rigid bodies, soft bodies): a light cloth
    can ask a thousand, and each search costs more than the cloth's own substep. A particle contact (particle,
    shape, the point on the shape in the body's frame, the world-space normal found at the search) follows the
    body's moves by its point; its normal does not turn with the body, so it serves while the particle stays
    within its contact gap (``collide_interval`` bounds that by linear speed; a body's spin is not read, a
    limit for a fast-spinning body under a cloth). ``bench physics``
    steps its rigid cases with this same reuse, so its errors include it."""
    if not particles:
        return substeps
    return max(1, substeps // max(1, others or substeps))


def mpm_family(kind: str) -> str:
    """The kind of MPM material a paper type is, for :data:`MPM_STEPS`: elastic, granular or liquid."""
    if kind in ("mpm_sand", "pbd_particle"):
        return "granular"
    if kind in ("mpm_liquid", "pbd_liquid"):
        return "liquid"
    return "elastic"


@dataclass(frozen=True)
class SceneConfig:
    """The solver and rates a shot is stepped at: the command's where given, else its physics scene's
    (``physics.prepare.scene_settings``)."""
    solver: str  # physomni:solver
    substeps: int  # the solver's recommended substeps per frame
    iterations: int  # XPBD iterations
    fps: float  # frames per second of the take


@dataclass(frozen=True, eq=False)
class PlanInputs:
    """What a step plan is chosen from: the scene's objects, the rates asked for, and what the built
    models say of the scene (``physics.prepare.plan_inputs`` reads them from a shot's models)."""
    objects: list  # SimObject
    fps: float
    base_substeps: int  # the solver's recommended substeps per frame
    base_iterations: int = DEFAULT_ITERATIONS
    fixed_substeps: bool = False  # keep ``base_substeps`` as given (the user asked for it)
    mpm_steps: int | None = None  # MPM steps per frame given by the user, None: chosen here
    mpm: object = None  # the MPM scene (``mpm.MPMScene``), or None
    cloth_masses: np.ndarray | None = None  # (P,) kg, the cloths' particle masses
    cloth_stiffness: float | np.ndarray = 0.0  # N/m, the stiffest cloth spring, or (P,) the stiffest on each particle
    soft_dt: float | None = None  # s, the largest step the soft bodies allow
    acceleration: float = 0.0  # m/s², the largest a force field gives
    field_kinds: tuple = ()  # the force fields' kinds
    particles: bool = False  # whether the XPBD model steps particles (cloth, soft bodies)


def plan_steps(inputs: PlanInputs) -> StepPlan:
    """Substeps per frame from the scene (see the module's rules): at least ``inputs.base_substeps``,
    exactly that with ``fixed_substeps``; MPM steps per frame as given, else from the CFL bound and
    :data:`MPM_STEPS`."""
    objects, fps, base_substeps = inputs.objects, inputs.fps, inputs.base_substeps
    mpm, mpm_steps, acceleration = inputs.mpm, inputs.mpm_steps, inputs.acceleration
    cloth_masses, cloth_stiffness, soft_dt = inputs.cloth_masses, inputs.cloth_stiffness, inputs.soft_dt
    frame = 1.0 / fps
    v = reachable_speed(objects)
    kinds = scene_kinds(objects, inputs.field_kinds)
    by_kind = max(round(RIGID_SUBSTEPS[k] * 30.0 / fps) for k in kinds)
    reasons = {"base": base_substeps, "scene": kinds, "by_scene": by_kind, "reachable_speed_m_s": round(v, 4)}
    need = max(base_substeps, by_kind)
    # what all but the cloths ask by the rules alone, never the user's or the scene's base: the contact search's
    # rate (``contact_reuse``); started from the base, a user's --substeps would make every substep a search
    others = by_kind
    thinnest = None
    iterations = inputs.base_iterations
    restitution = True
    moving = [o for o in objects if o.family == "rigid" and not o.fixed]
    colliders = [o for o in objects if o.family == "rigid"]
    if colliders and v > 0:
        thinnest = min(float(np.min(o.trimesh().extents)) for o in colliders)
        tunnel = math.ceil(frame * v / (0.5 * max(thinnest, 1e-4)))
        reasons["tunnelling"] = {"thinnest_m": round(thinnest, 5), "substeps": tunnel}
        need = max(need, tunnel)
        others = max(others, tunnel)
        if acceleration > 0:
            dt_a = math.sqrt(0.5 * max(thinnest, 1e-4) / acceleration)
            entry = {"acceleration_m_s2": acceleration, "substeps": math.ceil(frame / dt_a)}
            need = max(need, math.ceil(frame / dt_a))
            others = max(others, math.ceil(frame / dt_a))
            if acceleration > 10 * GRAVITY:
                # a body pressed by many g keeps a residual overlap each step, which comes back as a
                # launch when the push ends unless the contacts are iterated tighter
                iterations = max(iterations, 8 * math.ceil(math.log10(acceleration / GRAVITY)))
                entry["iterations"] = iterations
                # XPBD tells an impact from a resting contact by the approach speed gravity gives in one
                # step (2·g·dt); a body pressed by many g reads as an impact every step and bounces off
                restitution = False
                entry["restitution"] = "off: fields beyond 10 g make resting contacts read as impacts"
            reasons["force_fields"] = entry
    if len(moving) > 1:
        masses = [abs(o.trimesh().volume) * float(o.params.get("density", 1000.0)) for o in moving]
        ratio = max(masses) / max(min(masses), 1e-12)
        if ratio > 100:
            factor = math.ceil(math.sqrt(ratio / 100))
            iterations = max(iterations, 4 * factor)
            reasons["mass_ratio"] = {"ratio": round(ratio, 1), "factor": factor, "iterations": iterations}
            need = max(need, base_substeps * factor)
            others = max(others, by_kind * factor)
    piled = held_by_several(objects)
    if piled:
        iterations = max(iterations, PILE_ITERATIONS)
        reasons["pile"] = {"held_by_several": piled, "iterations": iterations}
    stiff = np.broadcast_to(np.asarray(cloth_stiffness, float), np.shape(cloth_masses)) \
        if cloth_masses is not None else np.zeros(0)
    if len(stiff) and (stiff > 0).any():
        # the particle of the shortest time scale √(m/k): a light cloth softened to the cap beside a heavier one
        # at the clamp pairs neither's mass with the other's springs
        sprung = (cloth_masses > 0) & (stiff > 0)
        if sprung.any():
            i = int(np.argmin(cloth_masses[sprung] / stiff[sprung]))
            m, cloth_stiffness = float(cloth_masses[sprung][i]), float(stiff[sprung][i])
        else:
            m, cloth_stiffness = 1.0, float(stiff.max())
        dt_cloth = CLOTH_FACTOR * math.sqrt(m / cloth_stiffness)
        wanted = math.ceil(frame / dt_cloth)
        # what the rule read, and whether the substeps taken fall short of it (MAX_SUBSTEPS, or the user's: a
        # cloth stepped beyond the rule; ``cloth.add_cloth`` softens a light cloth's springs until those substeps
        # resolve them); every rigid body of the scene runs at the cloth's substeps, its contacts are searched
        # at the rate the rest asks
        taken = base_substeps if inputs.fixed_substeps else MAX_SUBSTEPS
        reasons["cloth"] = {"dt": dt_cloth, "substeps": wanted, "particle_kg": m,
                            "stiffness_n_m": cloth_stiffness, "capped": wanted > taken}
        need = max(need, wanted)
    if soft_dt:
        reasons["soft_body"] = {"dt": soft_dt, "substeps": math.ceil(frame / soft_dt)}
        need = max(need, math.ceil(frame / soft_dt))
        others = max(others, math.ceil(frame / soft_dt))
    substeps = base_substeps if inputs.fixed_substeps else min(need, MAX_SUBSTEPS)
    if mpm is None:
        mpm_steps = 0
    else:
        c = max(mpm.wave_speed, v, 1e-6)
        cfl = 0.5 * mpm.spacing / c
        wanted = math.ceil(frame / cfl)
        families = sorted({mpm_family(o.obj.kind) for o in mpm.objects})
        cap = max(max(1, round(MPM_STEPS[f] * 30.0 / fps)) for f in families)
        chosen = max(1, min(wanted, cap))
        reasons["mpm_cfl"] = {"spacing_m": mpm.spacing, "wave_speed_m_s": round(mpm.wave_speed, 3),
                              "dt": cfl, "steps_wanted": wanted, "materials": families, "cap": cap,
                              "steps": mpm_steps or chosen, "capped": wanted > cap}
        if mpm_steps:
            reasons["mpm_cfl"]["given"] = mpm_steps
        mpm_steps = mpm_steps or chosen
        # rigid substeps are a whole multiple of the MPM steps, so both meet at every MPM step
        substeps = math.ceil(substeps / mpm_steps) * mpm_steps
    # from the substeps that run (after the MPM round-up), so the searches a frame are what the report says
    collide_every = contact_reuse(substeps, inputs.particles, others)
    if collide_every > 1:
        reasons["contacts"] = {"searches_a_frame": others, "collide_every": collide_every,
                               "why": "particles: searched at the rate all but the cloths ask"}
    return StepPlan(fps, substeps, mpm_steps, reasons, iterations, collide_every, thinnest,
                    GRAVITY + acceleration, restitution, PARTICLE_CONTACT_GAP if inputs.particles else None)


class Guard:
    """Energy, speed and finiteness of the whole scene, checked once per frame."""

    def __init__(self, tolerance: float = ENERGY_TOLERANCE, max_speed: float = MAX_SPEED):
        self.tolerance = tolerance
        self.max_speed = max_speed
        self.initial = None
        self.work = 0.0
        self.last_energy = 0.0

    def add_work(self, joules: float) -> None:
        """Energy put in (positive) or taken out (negative) from outside — a push, a force field."""
        self.work += float(joules)

    def slack(self, budget: float = 0.0) -> float:
        """Joules the energy may stand above ``budget`` (the start plus the work counted) before it is growth:
        the tolerance of the larger of the budget and the start, never under ``ENERGY_FLOOR``."""
        return self.tolerance * max(abs(budget), abs(self.initial), ENERGY_FLOOR) + ENERGY_FLOOR

    def check(self, energy: float, speed: float, finite: bool) -> str | None:
        """``None`` when the frame is good, else why it is not."""
        if not finite or not math.isfinite(energy):
            return "a value became NaN or infinite"
        if speed > self.max_speed:
            return f"a speed of {speed:.3g} m/s (bound {self.max_speed:g} m/s)"
        if self.initial is None:
            self.initial = energy
        budget = self.initial + self.work
        allowed = budget + self.slack(budget)
        self.last_energy = energy
        if energy > allowed:
            return (f"the energy grew to {energy:.4g} J, above the initial {self.initial:.4g} J plus "
                    f"{self.work:.4g} J of work")
        return None


class ContactTally:
    """The rigid contacts the solver held at each of the guard's checks passed, kept on the solver's device:
    a check copies the count there into a log beside it (an asynchronous copy, where reading it back would
    wait for a GPU's queue to drain at every check) and the log is read once, when the take is reported."""

    def __init__(self):
        self._log = None  # device array of counts, grown by doubling
        self.checks = 0

    def add(self, count) -> None:
        """Log ``count`` (the solver's one-element ``rigid_contact_count``) without reading it back."""
        import warp as wp

        if self._log is None or self.checks == self._log.shape[0]:
            grown = wp.empty(max(64, 2 * self.checks), dtype=count.dtype, device=count.device)
            if self.checks:
                wp.copy(grown, self._log, count=self.checks)
            self._log = grown
        wp.copy(self._log, count, dest_offset=self.checks, count=1)
        self.checks += 1

    def counts(self) -> np.ndarray:
        """The counts logged, in order: the one read-back."""
        return self._log.numpy()[:self.checks].copy() if self.checks else np.zeros(0, dtype=np.int32)

    def summary(self) -> dict | None:
        """The report's ``guard.rigid_contacts``: mean (0.1), max and how many checks; None where none."""
        c = self.counts()
        if not len(c):
            return None
        return {"mean": round(float(np.mean(c)), 1), "max": int(c.max()), "checks": int(len(c))}


def body_energy(model, state) -> tuple[float, float]:
    """Kinetic + gravitational energy (J, z = 0 the ground) of the rigid bodies, and their top speed."""
    if not model.body_count:
        return 0.0, 0.0
    q = state.body_q.numpy().astype(np.float64)
    qd = state.body_qd.numpy().astype(np.float64)
    mass = model.body_mass.numpy().astype(np.float64)
    inertia = model.body_inertia.numpy().astype(np.float64)
    com = model.body_com.numpy().astype(np.float64)
    rot = Rotation.from_quat(q[:, 3:7]).as_matrix()  # Newton and SciPy both store x, y, z, w
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
