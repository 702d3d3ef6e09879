"""The built scene settled before it is written for good: the rest pose each rigid object reaches under
gravity alone, found by the same solver, settings and guard ``simulate`` uses, and what of it the build keeps.

Placement is geometry: a fruit put in a bowl's hollow, a plant on its pot's rim, a cup on a book each stand
where the photo shows them, on supports the geometric passes judged steady. Whether they stay is the
simulator's to say, so ``build`` asks it (:func:`settle_shot`): the shot as written, nothing pushed and no
force field acting, is stepped until everything is still (``runner.at_rest``) or the settle's seconds are
up (longer, :data:`SETTLE_LONGER`, while what still moves could yet come to rest near where it stood). Each
rigid object's motion is then judged (:func:`judge`):

- still (every point within ``runner.REST_METRES``, turned under :data:`STILL_DEG`): nothing changes;
- settled a little (within :data:`KEEP_M` and :data:`KEEP_DEG`) and come to rest (still over the settle's last
  :data:`STILL_WINDOW_S`), its outline from the photo's camera still the photo's (IoU down by at most
  :data:`KEEP_IOU_DROP`, or still at least ``align.compare.WARN_IOU``, the build's own bar for a match): the
  settled pose is its rest pose;
- gone farther (it falls, rolls away, slides off) or still moving: not kept, reported by name, left where the
  photo shows it.

No object is made fixed to hold it: what the settle cannot keep still is said, not hidden."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from .runner import REST_METRES

#: An object that turns less than this (degrees) and moves less than ``REST_METRES`` is still.
STILL_DEG = 1.0
#: The most a settled pose may move (m, any point of the object) and turn (degrees) from where the photo
#: shows it and still be kept: a fruit finding the bottom of a bowl's hollow, a box seating on a lid; more
#: is a fall, which the photo does not show.
KEEP_M = 0.03
KEEP_DEG = 10.0
#: How much the object's silhouette IoU against its mask (from the photo's camera) may drop for the settled
#: pose to be kept: the photo is the arbiter of where it is.
KEEP_IOU_DROP = 0.05
#: Settles one build runs at most: a pose kept is written and settled again, for what still rocks where it
#: came to rest (a fruit in a hollow); each round costs a model and at least :data:`STILL_WINDOW_S` of stepping.
SETTLE_ROUNDS = 2
#: Still for this long (s), no point of any body farther than ``runner.REST_METRES`` from where it was at the
#: window's start, ends the settle early: most scenes stand still from the start and pay this much. A body
#: balanced on a narrow foot tips slowly at first: a bowl standing on its rim's line (235726/004) moved
#: 0.4 mm in its first 0.2 s, 1.1 mm in 0.5 s, 4.6 mm in 1 s and turned 15° by 2 s; a 0.2 s window called it
#: still and the settle ended before it tipped. Over 0.5 s to within 0.5 mm, resting fruit rocking by
#: tenths of a millimetre never came to rest and every settle ran its full length.
STILL_WINDOW_S = 1.0
#: A settle not at rest after its seconds goes on, up to this many times as long, while an object still moving
#: has gone no farther than a settled pose may (:data:`KEEP_M`, :data:`KEEP_DEG`): a fruit finding the bottom of
#: a bowl's hollow (235726/020) was still at 2.6 s, 7.0 mm and 4.5° from where the photo shows it (7.7 mm and
#: 5° after the second round), where a 2 s settle called it still moving, kept nothing, and the shot started it
#: rolling. Where nothing moving can be kept (still, or gone too far) it ends at its seconds, as before.
SETTLE_LONGER = 2.0


@dataclass
class Motion:
    """One rigid object's motion over the settle: its points ``x`` go to ``x @ rotation.T + translation``."""

    name: str
    rotation: np.ndarray  # (3, 3)
    translation: np.ndarray  # (3,)
    moved_m: float  # farthest any of its points went
    turned_deg: float
    #: still over the settle's last :data:`STILL_WINDOW_S` (within ``runner.REST_METRES``): come to rest
    resting: bool = True

    def apply(self, points: np.ndarray) -> np.ndarray:
        return points @ self.rotation.T + self.translation

    def after(self, first: "Motion | None", points: np.ndarray) -> "Motion":
        """This motion made after ``first`` (None: nothing before it), measured on ``points`` (N, 3), the
        object where the photo shows it: a later round is judged by how far it has gone in all."""
        if first is None:
            return self
        rot = self.rotation @ first.rotation
        trans = first.translation @ self.rotation.T + self.translation
        moved = float(np.linalg.norm(points @ rot.T + trans - points, axis=1).max())
        turned = float(np.degrees(Rotation.from_matrix(rot).magnitude()))
        return Motion(self.name, rot, trans, moved, turned, self.resting)

    @property
    def still(self) -> bool:
        return self.moved_m <= REST_METRES and self.turned_deg <= STILL_DEG


@dataclass
class Settled:
    """What the settle simulated: each rigid object's :class:`Motion` (name → it), the seconds simulated,
    whether it ended with everything still, why it was skipped (None where it ran), its wall time, and what each
    ball collided as (``physics.round``: name → ``collides_as`` and its fit)."""

    motions: dict[str, Motion] = field(default_factory=dict)
    simulated_s: float = 0.0
    at_rest: bool = False
    skipped: str | None = None
    seconds: float = 0.0
    colliders: dict = field(default_factory=dict)


def settle_shot(stage, seconds: float, echo=lambda m: None) -> Settled:
    """Simulate the composed ``stage`` (a built shot, its sim layer muted) for ``seconds`` with nothing pushed
    (longer while what moves could still be kept: :data:`SETTLE_LONGER`; shorter once all is still), as
    ``simulate`` would (``physics.prepare``, ``runner.run_guarded``), and return each rigid
    object's motion from its start to the end. A scene with a non-rigid object or a force field is not
    settled (``skipped`` says why): their motion under gravity is the shot's, not a placement's error."""
    from ..settings import SimulateSettings
    from .objects import scene_objects
    from .prepare import prepare_simulation
    from .runner import run_guarded

    t0 = time.perf_counter()
    objects = scene_objects(stage)
    soft = [o.name for o in objects if o.family != "rigid"]
    if soft:
        return Settled(skipped=f"not rigid: {', '.join(soft)}", seconds=time.perf_counter() - t0)
    window = min(STILL_WINDOW_S, 0.5 * seconds)  # a shorter settle keeps its first half to move in
    # a model of its own (reuse False), not simulate's cached one: a rewound model does not step exactly as a new
    # one (235726/004 simulated twice in one process: a bowl moved 12.2 mm, then 7.8 mm), so a simulate after a
    # settle that kept nothing runs as it would have without one; reused, it saved 0.45 s of 0.6 s at load 15
    prep = prepare_simulation(stage, SimulateSettings(seconds=SETTLE_LONGER * seconds, rest_seconds=window),
                              reuse=False, echo=echo)  # a first settle compiles the solver's kernels: say so
    models = prep.models
    if models.fields.fields:
        return Settled(skipped="force fields act on the shot", seconds=time.perf_counter() - t0)
    stepper = models.stepper
    stepper.pending = []  # nothing pushed: no push to come, and no start velocity (a push at 0 s is one)
    if stepper.state.body_qd is not None and stepper.state.body_qd.shape[0]:
        stepper.state.body_qd.zero_()
    free = {o.path: o for o in prep.objects if not o.fixed and o.path in models.path_body}
    start = stepper.state.body_q.numpy().copy()
    fps = prep.plan.fps
    steps = max(1, round(window * fps))

    def stop(q: np.ndarray) -> bool:  # past its seconds: whether nothing still moving could be kept
        f = len(q) - 1
        if f < round(seconds * fps) or f < steps:
            return False
        for o in free.values():
            b = models.path_body[o.path]
            if (_turned(start[b], q[f, b]) <= KEEP_DEG and _moved(o.points, start[b], start[b], q[f, b]) <= KEEP_M
                    and _moved(o.points, start[b], q[f - steps, b], q[f, b]) > REST_METRES):
                return False
        return True

    run = run_guarded(models, prep.plan, SETTLE_LONGER * seconds, rest_seconds=window, stop=stop)
    end = stepper.state.body_q.numpy()
    frames = run.take.body_q  # (F, B, 7)
    last = frames[max(0, len(frames) - 1 - round(window * prep.plan.fps))]
    out = Settled(simulated_s=float(run.take.seconds), at_rest=run.rest is not None,
                  colliders=models.rounded.report())
    for path, o in free.items():
        b = models.path_body[path]
        r0, r1 = Rotation.from_quat(start[b, 3:7]), Rotation.from_quat(end[b, 3:7])
        rot = (r1 * r0.inv()).as_matrix()
        trans = end[b, :3] - start[b, :3] @ rot.T
        moved = float(np.linalg.norm(o.points @ rot.T + trans - o.points, axis=1).max())
        out.motions[o.name] = Motion(o.name, rot, trans, moved, _turned(start[b], end[b]),
                                     _moved(o.points, start[b], last[b], end[b]) <= REST_METRES)
    out.seconds = time.perf_counter() - t0
    return out


def _turned(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees a body turned between its poses ``a`` and ``b`` (x y z qx qy qz qw)."""
    return float(np.degrees((Rotation.from_quat(b[3:7]) * Rotation.from_quat(a[3:7]).inv()).magnitude()))


def _moved(points: np.ndarray, start: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """How far (m) the farthest of ``points`` (placed at body pose ``start``, x y z qx qy qz qw) went between
    the body's poses ``a`` and ``b``."""
    r0 = Rotation.from_quat(start[3:7])
    local = r0.inv().apply(points - start[:3])
    return float(np.linalg.norm(Rotation.from_quat(b[3:7]).apply(local) + b[:3]
                                - Rotation.from_quat(a[3:7]).apply(local) - a[:3], axis=1).max())


def judge(settled: Settled, names, vertex_sets, faces, camera, masks) -> tuple[dict[str, Motion], dict[str, str]]:
    """Which settled poses to keep (name → :class:`Motion`) and which objects went too far (name → why), for
    the objects ``names`` with their placed ``vertex_sets`` and ``faces``, seen by ``camera`` against
    ``masks`` (their visible masks, as ``align.compare.visible_ious`` takes them)."""
    from ..align.compare import WARN_IOU, visible_ious

    moving = {n: m for n, m in settled.motions.items() if not m.still}
    far = {n: f"moved {m.moved_m * 100:.1f} cm and turned {m.turned_deg:.0f}° with nothing pushing it"
           for n, m in moving.items() if m.moved_m > KEEP_M or m.turned_deg > KEEP_DEG}
    near = {n: m for n, m in moving.items() if n not in far}
    # where it got to is not where it rests: kept, it would start the shot mid-roll (235726/005: a fruit kept
    # 4 mm along its roll rolled on 18 mm from there, 8 mm from where the photo shows it)
    far.update({n: f"was still moving after {settled.simulated_s:g} s (moved {m.moved_m * 100:.1f} cm and "
                   f"turned {m.turned_deg:.0f}° with nothing pushing it)" for n, m in near.items() if not m.resting})
    near = {n: m for n, m in near.items() if m.resting}
    if not near:
        return {}, far
    before = visible_ious(vertex_sets, faces, camera, masks)
    after_sets = [near[n].apply(v) if n in near else v for n, v in zip(names, vertex_sets)]
    after = visible_ious(after_sets, faces, camera, masks)
    keep = {}
    for n, b, a in zip(names, before, after):
        if n not in near:
            continue
        if b - a <= KEEP_IOU_DROP or a >= WARN_IOU:  # a small object's IoU drops a tenth for a pixel's shift
            keep[n] = near[n]
        else:
            far[n] = (f"settles {near[n].moved_m * 100:.1f} cm, turned {near[n].turned_deg:.0f}°, to where its "
                      f"outline no longer matches the photo's (silhouette IoU {b:.2f} → {a:.2f})")
    return keep, far
