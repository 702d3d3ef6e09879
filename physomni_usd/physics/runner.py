"""The one guarded stepping loop, used by ``simulate``, the live preview and the benchmarks that run
them: a frame at a time through :class:`~.stepping.FrameGraphs` (replayed graphs where a frame allows),
start overlaps held to a bounded separation speed (:mod:`.depenetration`), and every few frames the
guard's check of finiteness, speed and energy against the work done. When energy grows the loop first
finds why: the solver separating a start overlap (counted as its work, the frame kept), or a step too
long for a stiff material, contact or force (rolled back to the last good check and redone at half the
step; a field's work is counted step by step, and the diagnosis says how much it was). Every roll-back
and every counted growth is logged with its cause and remedy, for the report."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import PhysOmniError
from .depenetration import Depenetration
from .diagnose import FRAME_WALL_BUDGET_S, failure_line
from .recording import Recorder, Take
from .stability import ENERGY_TOLERANCE, ContactTally, Guard, StepPlan
from .stepping import FrameGraphs

#: Whether frames of rigid XPBD scenes are captured as warp graphs and replayed (False: launch by launch).
CAPTURE = True

#: How often a diverging stretch is rolled back and redone, each time with half the step.
MAX_RETRIES = 4
#: Motion a take at rest may still show (m, at any point of any object): a 10 cm box resting on the ground
#: rocks 0.45° peak to peak at 3 Hz under XPBD, 1 mm at its corners, which a viewer does not see.
REST_METRES = 2e-3
#: Frames between the guard's checks (each a read-back of the state and a checkpoint to roll back to):
#: 5 frames at 30 fps, so a divergence is caught within a sixth of a second of simulated time.
CHECK_EVERY = 5


class GuardedRun:
    """A shot's stepper advanced frame by frame from t = 0 under the guard. ``frame`` is the last frame
    completed (0: the start); after :meth:`advance` it may have gone back (a roll-back), so callers record
    the frame ``frame`` names. ``tolerance`` is the guard's (``math.inf``: speed and finiteness only, as the
    preview, whose hand's work is not known, runs it); ``give_up`` False keeps stepping after the last
    retry instead of raising (the preview)."""

    def __init__(self, stepper, plan: StepPlan, *, capture: bool = True, tolerance: float = ENERGY_TOLERANCE,
                 check_every: int = CHECK_EVERY, stage=None, give_up: bool = True, echo=lambda m: None,
                 graphs: FrameGraphs | None = None, bodies: dict[int, str] | None = None):
        self.stepper, self.base_plan, self.plan = stepper, plan, plan
        self.bodies = bodies or {}  # body index → the object's name, to name the fastest where a run fails
        self.graphs = graphs if graphs is not None else FrameGraphs(stepper, enabled=capture)
        self.stage, self.give_up, self.echo = stage, give_up, echo
        self.check_every = max(1, int(check_every))
        self.tolerance = tolerance
        with _device(stepper):
            # a rewound model keeps its bound: its captured graphs read the bound's arrays
            old = stepper.depenetration
            if old is None or old.acceleration != plan.acceleration:
                stepper.depenetration = Depenetration(stepper, plan.acceleration)
            else:
                old.restart()  # the start's window, not one a roll-back of the last run opened
            self.depenetration = stepper.depenetration
            self._start = stepper.checkpoint()
        self.log: list[dict] = []  # every roll-back and every growth counted, with cause and remedy
        self._restart()

    def _restart(self) -> None:
        self.t, self.step, self.frame = 0.0, 0, 0
        self.guard = Guard(self.tolerance)
        self.separation_j = 0.0  # energy the solver added separating start overlaps
        self.contacts = ContactTally()  # the rigid contacts the solver held at each check passed, this take
        energy, speed, finite = _energy(self.stepper)
        self.guard.check(energy, speed, finite)
        self.speed = self.max_speed = speed
        self._saved = self._checkpoint()
        self._t_frame, self._retry_frame = time.perf_counter(), None

    def reset(self) -> None:
        """Back to frame 0 (the state as built; pending pushes again) at the first plan."""
        with _device(self.stepper):
            self.stepper.restore(self._start)
            self.depenetration.restart()
        self.plan = self.base_plan
        self._restart()

    @property
    def rollbacks(self) -> list[dict]:
        return [e for e in self.log if e["remedy"].startswith("halved")]

    def _checkpoint(self, replacing=None):
        """The state now, to roll back to; ``replacing``, the checkpoint this one takes the place of, lends
        its arrays."""
        snap = self.stepper.checkpoint(replacing[0] if replacing is not None else None)
        return snap, self.frame, self.t, self.step, self.speed, self.guard.work, self.separation_j

    def _back(self, saved) -> None:
        snap, self.frame, self.t, self.step, self.speed, self.guard.work, self.separation_j = saved
        self.stepper.restore(snap)

    def advance(self) -> bool:
        """One frame. Returns False where a check failed and the run went back to its last good check
        (``frame`` is then that frame's), True otherwise."""
        stepper, plan = self.stepper, self.plan
        with _device(stepper):
            if self._retry_frame != self.frame + 1:
                self._t_frame = time.perf_counter()
            self.graphs.frame(plan, self.t, self.step, self.guard.add_work, self.speed)
            self.frame += 1
            self.step += plan.substeps
            self.t = self.frame / plan.fps
            if self.frame % self.check_every and not self._must_check():
                # the contact cadence of the next frame follows the speed; no energy between checks
                self.speed = _top_speed(stepper) if plan.collide_every > 1 else self.speed
                return True
            return self._check()

    def _must_check(self) -> bool:
        # the first frames, and those a separation runs in and the frame after, are checked one by one: a
        # scene that diverges at once is caught at once, and a growth found while overlaps separate is told
        # apart from divergence by when it happened
        return self.frame <= self.check_every or self.depenetration.active(self.t - 1.0 / self.plan.fps)

    def _check(self) -> bool:
        energy, speed, finite = _energy(self.stepper)
        why = self.guard.check(energy, speed, finite)
        if why is not None and finite and speed <= self.guard.max_speed:
            counted = self._count(energy)
            if counted:
                why = self.guard.check(energy, speed, finite)
        if why is None:
            self._name_fields(energy)
            if self.stepper.contacts is not None:
                self.contacts.add(self.stepper.contacts.rigid_contact_count)
            self.speed = speed
            self.max_speed = max(self.max_speed, speed)
            self._saved = self._checkpoint(self._saved)
            self._retry_frame = None
            return True
        failed = self.frame
        field_work = self.guard.work - self._saved[5]
        if len(self.rollbacks) >= MAX_RETRIES or time.perf_counter() - self._t_frame > FRAME_WALL_BUDGET_S:
            if not self.give_up:
                self._saved = self._checkpoint(self._saved)  # stepping on, as the preview does, from here
                return True
            finest = len(self.rollbacks) >= MAX_RETRIES
            what = (f"simulation diverged at frame {failed}: {why}, even at {self.plan.substeps} substeps per frame"
                    if finest else
                    f"simulation stuck at frame {failed}: {why}, {FRAME_WALL_BUDGET_S:g} s spent on it")
            objects, named = _fastest(self.stepper, self.bodies)
            what += named
            raise Diverged(failure_line(self.stage, what) if self.stage is not None else what, objects, finest)
        self._back(self._saved)
        self.plan = self.plan.refined()
        self._retry_frame = self.frame + 1
        # an overlap the coarser step left at the state gone back to would be separated at d/dt by the finer
        # one, faster the finer the step: it separates at the bounded speed instead, its energy counted
        with _device(self.stepper):
            overlap = self.depenetration.rearm(self.stepper, self.t)
        if not finite or speed > self.guard.max_speed:
            found = why
        elif self.stepper.fields:
            found = (f"energy grew beyond the {field_work:.3g} J the force fields did since the last check "
                     "(counted) with no start overlap separating: the step is too long for the forces")
        else:
            found = "energy grew with no start overlap separating and no work done: the step is too long"
        if overlap:  # told beside the diagnosis, not instead of it: a NaN or an over-speed stays named
            found += (f"; the state gone back to holds overlaps up to {self.depenetration.depth * 1000:.2g} mm, "
                      "separated from there at a bounded speed")
        self.log.append({"frame": failed, "why": why, "cause": "stiff", "found": found,
                         "remedy": f"halved the step: {self.plan.substeps} substeps per frame",
                         "substeps": self.plan.substeps, "mpm_steps": self.plan.mpm_steps})
        self.echo(f"simulate: frame {failed}: {why}; going back to frame {self.frame} with {self.plan.substeps} "
                  "substeps per frame")
        return False

    def _count(self, energy: float) -> bool:
        """Whether the growth above the guard's budget is work the solver did separating start overlaps
        (then counted). A force field's work is already counted step by step, so growth beyond it is the
        step's, and is refined."""
        g = self.guard
        if g.initial is None:  # no frame has been accepted to measure from
            return False
        budget = g.initial + g.work
        growth = energy - budget
        slack = g.slack(budget)
        t_checked = self._saved[2]
        if self.depenetration.active(t_checked):
            room = self.depenetration.energy_bound(self.t) - self.separation_j
            if growth - slack <= room:
                amount = max(growth, 0.0)
                self.separation_j += amount
                g.add_work(amount)
                which = "overlaps at a roll-back" if self.depenetration.since else "start overlaps"
                self.log.append({"frame": self.frame, "cause": "overlap", "energy_j": round(amount, 6),
                                 "found": f"{which} up to {self.depenetration.depth * 1000:.2g} mm separating",
                                 "remedy": "kept the frame: separated at a bounded speed, the energy counted as "
                                           "the solver's work"})
                return True
        return False

    def _name_fields(self, energy: float) -> None:
        """Where the energy stands above the start by more than the guard's slack and the force fields'
        counted work covers it, say so once, naming the fields: their work, the step kept, nothing refined
        (the entry's figures follow the latest check)."""
        g, fields = self.guard, self.stepper.fields
        if not fields or g.initial is None:
            return
        growth = energy - g.initial
        done = g.work - self.separation_j  # the fields' work, and any push's
        slack = g.slack()
        if growth <= slack or done <= slack:
            return
        entry = next((e for e in self.log if e["cause"] == "field"), None)
        if entry is None:
            names = ", ".join(f"{f.kind} {f.path}".strip() for f in fields.fields)
            entry = {"frame": self.frame, "cause": "field", "fields": names,
                     "remedy": "kept the step: the growth is work done on the scene, counted"}
            self.log.append(entry)
        entry |= {"energy_growth_j": round(growth, 6), "work_j": round(done, 6),
                  "found": f"energy up {growth:.3g} J since the start, within the {done:.3g} J of work "
                           f"the force fields ({entry['fields']}) did"}

    def report(self) -> dict:
        g = self.guard
        return {"energy_initial_j": g.initial, "energy_final_j": g.last_energy, "work_j": g.work,
                "separation_work_j": self.separation_j, "tolerance": g.tolerance, "check_every_frames": self.check_every,
                "rollbacks": self.rollbacks, "diagnoses": self.log, "depenetration": self.depenetration.as_dict(),
                # what the stepping's cost grows with: bench scale fits it against these
                "rigid_contacts": self.contacts.summary()}


@dataclass
class GuardedTake:
    """What :func:`run_guarded` leaves: the ``take`` to write, ``rest`` (None, or the time the scene came
    to rest and the time the run ended, s), the wall seconds spent stepping, the graph capture's counts,
    the fastest speed met (m/s), Newton's warnings and the guard's report; ``cpu_step``: the process's CPU
    seconds over the same stretch, which a shared machine's load does not inflate as it does the wall's."""
    take: Take
    rest: dict | None
    t_step: float
    capture: dict
    max_speed: float
    notes: list
    guard: dict
    cpu_step: float = 0.0


def run_guarded(models, plan: StepPlan, seconds: float, progress=None, echo=lambda m: None,
                rest_seconds: float | None = None, stop=None) -> GuardedTake:
    """Step ``seconds`` of ``models`` (a :class:`~.assembly.ShotModels`), one recorded frame per video frame
    from t = 0, under the guard; with ``rest_seconds``, end early once nothing has moved for that long and
    nothing is left to move it (:func:`at_rest`), keeping that still stretch (the take then simulates
    until then); with ``stop`` (bodies' recorded poses (F, B, 7) up to a frame → bool), end early where it
    says so. The take's plan is the last one stepped (a roll-back refines it)."""
    frames = int(round(seconds * plan.fps)) + 1
    bodies = {b: p.rsplit("/", 1)[-1] for p, b in models.path_body.items()}
    run = GuardedRun(models.stepper, plan, capture=CAPTURE, stage=models.stage, echo=echo,
                     graphs=models.frame_graphs(CAPTURE), bodies=bodies)
    rec = Recorder(models, frames)
    rec.record(0)
    replayed, captures = run.graphs.captured_frames, run.graphs.captures  # the graphs outlive a run
    t1, c1 = time.perf_counter(), time.process_time()
    last = frames - 1
    window = max(1, round(rest_seconds * plan.fps)) if rest_seconds else None
    rest, ended = None, seconds
    while run.frame < last:
        ok = run.advance()
        if not ok:
            continue
        if run.frame == last and run.frame % run.check_every:
            if not run._check():  # the last frame is always checked
                continue
        rec.record(run.frame)
        if progress:
            progress(run.frame, last)
        if window and run.frame < last and at_rest(rec, run.frame, window, models.stepper, run.t):
            if run.frame % run.check_every and not run._check():  # a take never ends on an unchecked frame
                continue
            rest = {"still_from_s": round((run.frame - window) / plan.fps, 4), "ended_s": round(run.t, 4)}
            ended = rest["ended_s"]
            break
        if stop is not None and stop(rec.body_q[:run.frame + 1]):
            if run.frame % run.check_every and not run._check():  # checked, as the last frame always is
                continue
            ended = round(run.t, 4)
            break
    t_step, cpu_step = time.perf_counter() - t1, time.process_time() - c1
    graphs = run.graphs
    if run.frame < last:
        rec.truncate(run.frame + 1)
    capture = {"enabled": graphs.enabled, "frames_replayed": graphs.captured_frames - replayed,
               "graphs": graphs.captures - captures, "graphs_kept": len(graphs.graphs), "error": graphs.error}
    take = rec.take(run.plan, ended)
    return GuardedTake(take, rest, t_step, capture, round(run.max_speed, 4), sorted(set(models.notes)), run.report(),
                        cpu_step)


def at_rest(rec: Recorder, f: int, window: int, stepper, t: float) -> bool:
    """Whether nothing recorded has moved over the ``window`` frames up to frame ``f`` (every point of every
    body, surface and particle within :data:`REST_METRES` of where it was at the window's start), and nothing
    is left to move it after ``t`` (s): no push still to come, no force field acting now or later."""
    if f < window or stepper.pending:
        return False
    if stepper.fields and any(x.enabled and (x.end_time < 0 or x.end_time > t) for x in stepper.fields.fields):
        return False
    return rec.still(f - window, f, REST_METRES)


def _device(stepper):
    import warp as wp

    return wp.ScopedDevice(stepper.model.device)


class Diverged(PhysOmniError):
    """A guarded run that gave up; ``objects`` names what diverged (:func:`_fastest`). ``finest``: it failed at
    its finest step, every roll-back spent; False where it gave up on a frame that took too long
    (``FRAME_WALL_BUDGET_S``), which says as much about the machine's load or a first kernel compile as about
    the scene. Users see it as a :class:`PhysOmniError` (the CLI's ``error:`` line, batch's failure type)."""

    def __init__(self, message: str, objects: list[str], finest: bool = True):
        super().__init__(message)
        self.objects = objects
        self.finest = finest


def _fastest(stepper, bodies: dict[int, str]) -> tuple[list[str], str]:
    """What a failed run diverged in, named (the user's handle on which object or pair to look at): the bodies
    whose velocity is not finite, else the fastest by the speed of its points (its centre's speed plus its spin
    times its radius of gyration: a small block spinning up on a book is found as one sliding off), with
    ``particles`` where theirs are not finite or faster; and the words saying so ("" where none is named;
    ``bodies``: body index → object name)."""
    m = stepper.model
    parts = _particle_speeds(stepper)
    wild = [] if all(np.isfinite(v).all() for v in parts) else ["particles"]
    top = max((float(v.max()) for v in parts if v.size and np.isfinite(v).all()), default=0.0)
    if not bodies or not m.body_count:
        return wild, f"; not finite: {', '.join(wild)}" if wild else ""
    qd = stepper.state.body_qd.numpy().astype(np.float64)
    v, w = np.linalg.norm(qd[:, :3], axis=1), np.linalg.norm(qd[:, 3:6], axis=1)
    mass = m.body_mass.numpy().astype(np.float64)
    trace = np.trace(m.body_inertia.numpy().astype(np.float64), axis1=1, axis2=2)
    radius = np.sqrt(np.divide(trace, 2.0 * mass, out=np.zeros_like(mass), where=mass > 0))
    points = v + w * radius
    finite = {b for b in bodies if b < len(qd) and np.isfinite(points[b])}
    nan = sorted(bodies[b] for b in bodies if b < len(qd) and b not in finite) + wild
    if nan:
        return nan, f"; not finite: {', '.join(nan)}"
    if not finite:
        return [], ""
    b = max(finite, key=lambda k: points[k])
    if top > points[b]:
        return ["particles"], f"; fastest: particles ({top:.3g} m/s)"
    return [bodies[b]], f"; fastest: {bodies[b]} ({v[b]:.3g} m/s, {w[b]:.3g} rad/s)"


def _particle_speeds(stepper) -> list[np.ndarray]:
    """The speeds of the moving particles of each particle model stepped (cloth and soft bodies, MPM)."""
    s, m = stepper.state, stepper.model
    out = []
    for model, state in ((m, s), (stepper.mpm.model, stepper.mpm.state) if stepper.mpm else (None, None)):
        if model is not None and model.particle_count:
            moving = model.particle_mass.numpy() > 0
            out.append(np.linalg.norm(state.particle_qd.numpy()[moving], axis=1))
    return out


def _top_speed(stepper) -> float:
    """The fastest body's or particle's speed (m/s), as :meth:`~.stepping.Stepper.energy` reads it."""
    s, m = stepper.state, stepper.model
    speeds = [0.0]
    if m.body_count:
        speeds.append(float(np.linalg.norm(s.body_qd.numpy()[:, :3], axis=1).max()))
    speeds += [float(v.max()) for v in _particle_speeds(stepper) if v.size]
    return max(speeds)


def _energy(stepper) -> tuple[float, float, bool]:
    energy, speed = stepper.energy()
    return energy, speed, math.isfinite(energy) and all(np.isfinite(a.numpy()).all() for a in _arrays(stepper))


def _arrays(stepper):
    s = stepper.state
    out = [a for a in (s.body_q, s.body_qd, s.particle_q, s.particle_qd) if a is not None and a.shape[0]]
    if stepper.mpm:
        out += [stepper.mpm.state.particle_q, stepper.mpm.state.particle_qd]
    return out
