"""The last pass of placement: no two objects start inside each other, whatever the cues did before.

Every earlier step of ``align`` keeps objects apart by its own reading of the photo (footprints made shallower,
objects moved apart, stood on their supporters' surfaces, the joint solve), and each can leave a pair deeper in
each other than ``simulate`` accepts (``physics.diagnose``: an object starting more than 5 mm, and a quarter of
its smallest side, inside another is refused). This pass measures every pair as ``simulate`` will (the depth of
the deepest vertex of one inside the other's collider: its convex hull, or its convex pieces for an open vessel)
and separates each pair deeper than :data:`TARGET_M` by the least of three remedies, the one that changes the
photo's silhouettes least (:func:`silhouette_change`, the projected outlines' lost overlap):

- *up*: the upper object (and what rests on it) rises onto the one under it;
- *apart*: one of them moves horizontally, away from the other;
- *shrink*: the thinner one is made smaller about its base, which stays where it stands.

Each remedy takes the least amount that separates the pair (doubled, then halved back). Moves can press a
pair that was apart, so passes repeat; a pair that :data:`MAX_PASSES` passes leave deeper than ``simulate``
accepts is :class:`Unseparable`, which ``build`` reports in one line naming the pair.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .support import riders

#: A pair deeper in each other than this (metres) is separated; the contact margin is what is left.
TARGET_M = 0.0015
#: What each remedy leaves between the pair once it separates them (metres), under the 2 mm of a contact.
CLEARANCE_M = 0.0005
#: Passes over every pair; a pair still deeper than ``simulate`` accepts after these is unseparable.
MAX_PASSES = 6
#: The least an object is shrunk to (a fraction of its size): below it the object is no longer the photo's.
MIN_SCALE = 0.6
#: Halvings of the interval in which each remedy's least amount lies.
BISECTIONS = 10


class Unseparable(Exception):
    """A pair no pass could separate: ``names``, and its depth (metres) after the last pass."""

    def __init__(self, names: tuple[str, str], depth: float):
        super().__init__(f"{names[0]} and {names[1]} overlap {depth * 1000:.1f} mm")
        self.names, self.depth = names, depth


@dataclass
class Remedy:
    how: str  # 'up' | 'apart' | 'shrink'
    moved: int  # the object the remedy changes (objects resting on it follow)
    amount: float  # metres risen or moved, or the scale (< 1)
    change: float  # silhouette change (0: none, 1: a wholly different outline)
    vertices: dict  # object index → its new (n, 3) vertices


def _meshes(vertices, faces):
    import trimesh

    return [trimesh.Trimesh(v, f, process=False) for v, f in zip(vertices, faces)]


def pair_depth(a, b, hollow=(False, False)) -> float:
    """How deep meshes ``a`` and ``b`` (trimesh) are in each other, as ``simulate``'s check measures it."""
    from ..geometry.overlap import overlap_depth

    return overlap_depth(a, b, hollow)


def _outline(camera, vertices: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(H, W) bool: the convex hull of ``vertices`` projected through ``camera``."""
    uv, depth = camera.project(vertices)
    drawn = np.zeros(shape, np.uint8)
    if (depth > 0).sum() >= 3:
        hull = cv2.convexHull(np.round(uv[depth > 0] * 16).astype(np.int32))
        cv2.fillConvexPoly(drawn, hull, 1, shift=4)
    return drawn > 0


def silhouette_change(camera, before: dict, after: dict, shape: tuple[int, int]) -> float:
    """1 − IoU of the projected outlines of the objects in ``before`` and ``after`` (index → vertices), summed:
    how much of the photo frame 0 no longer shows where the photo does."""
    total = 0.0
    for i, v in after.items():
        a, b = _outline(camera, before[i], shape), _outline(camera, v, shape)
        union = (a | b).sum()
        total += 0.0 if union == 0 else 1.0 - (a & b).sum() / union
    return total


def _least(separated, hi: float, lo: float = 0.0, limit: float = np.inf) -> float | None:
    """The least amount in (lo, limit] for which ``separated(amount)`` holds, starting the search at ``hi`` and
    doubling it; None when even ``limit`` does not separate."""
    while not separated(hi):
        lo, hi = hi, 2.0 * hi
        if hi > limit:
            if lo >= limit or not separated(limit):
                return None
            hi = limit
            break
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if separated(mid):
            hi = mid
        else:
            lo = mid
    return hi


def separate_pairs(vertices, faces, hollow, supports, camera, image_shape, names, passes: int | None = None,
                   error=lambda depth, a, b: True):
    """``vertices`` (list of (n_i, 3) world metres) with every pair apart to :data:`TARGET_M`, and what was done
    (a list of dicts for ``report.json``). ``hollow``: whether each collides as convex pieces; ``supports``:
    {upper: (lower, how)}; ``camera`` and ``image_shape`` (H, W): the photo's, to judge the silhouettes;
    ``error(depth, a, b)``: whether a pair left that deep (meshes ``a``, ``b``) would be refused — such a pair
    raises :class:`Unseparable` after the last pass."""
    verts = [np.asarray(v, float).copy() for v in vertices]
    n = len(verts)
    done = []
    for _ in range(MAX_PASSES if passes is None else passes):
        meshes = _meshes(verts, faces)
        deep = []
        for i in range(n):
            for j in range(i + 1, n):
                d = pair_depth(meshes[i], meshes[j], (hollow[i], hollow[j]))
                if d > TARGET_M:
                    deep.append((d, i, j))
        if not deep:
            return verts, done
        for d0, i, j in sorted(deep, reverse=True):
            meshes = _meshes(verts, faces)
            if pair_depth(meshes[i], meshes[j], (hollow[i], hollow[j])) <= TARGET_M:
                continue  # an earlier remedy of this pass separated it
            remedy = _best_remedy(verts, faces, hollow, supports, camera, image_shape, i, j)
            if remedy is None:
                continue
            for k, v in remedy.vertices.items():
                verts[k] = v
            done.append({"pair": [names[i], names[j]], "depth_mm": round(d0 * 1000, 2), "how": remedy.how,
                         "object": names[remedy.moved], "amount": round(remedy.amount, 4),
                         "silhouette_change": round(remedy.change, 4)})
    meshes = _meshes(verts, faces)
    worst = None
    for i in range(n):
        for j in range(i + 1, n):
            d = pair_depth(meshes[i], meshes[j], (hollow[i], hollow[j]))
            if d > TARGET_M and error(d, meshes[i], meshes[j]) and (worst is None or d > worst[0]):
                worst = (d, i, j)
    if worst is not None:
        raise Unseparable((names[worst[1]], names[worst[2]]), worst[0])
    return verts, done


def _best_remedy(verts, faces, hollow, supports, camera, image_shape, i, j) -> Remedy | None:
    """Of the remedies that separate objects ``i`` and ``j``, the one whose silhouettes change least."""
    import trimesh

    pair = (i, j)
    flags = (hollow[i], hollow[j])

    def depth_with(changed: dict) -> float:
        a = trimesh.Trimesh(changed.get(i, verts[i]), faces[i], process=False)
        b = trimesh.Trimesh(changed.get(j, verts[j]), faces[j], process=False)
        return pair_depth(a, b, flags)

    size = [float(np.ptp(verts[k], axis=0).max()) for k in pair]
    start = max(depth_with({}), TARGET_M) + CLEARANCE_M
    candidates = []

    def consider(how, moved, amount_of, changed_by, limit):
        def separated(amount):
            return depth_with(changed_by(amount)) <= TARGET_M - CLEARANCE_M * 0.5
        amount = _least(separated, start if how != "shrink" else 0.02, limit=limit)
        if amount is None:
            return
        changed = changed_by(amount)
        moved_all = {k: v for k, v in _with_riders(changed, moved, verts, supports, how, amount).items()}
        before = {k: verts[k] for k in moved_all}
        candidates.append(Remedy(how, moved, amount_of(amount), silhouette_change(camera, before, moved_all,
                                                                                  image_shape), moved_all))

    low = [float(verts[k][:, 2].min()) for k in pair]
    upper, lower = (i, j) if (supports.get(i, (None,))[0] == j or low[0] > low[1] + 1e-4) else (j, i)
    if not (supports.get(upper, (None,))[0] == lower or low[pair.index(upper)] > low[pair.index(lower)] + 1e-4):
        upper = None
    if upper is not None:
        consider("up", upper, lambda a: a, lambda a: {upper: verts[upper] + [0.0, 0.0, a]},
                 float(np.ptp(np.vstack([verts[i], verts[j]])[:, 2])) + start)
    for moved, other in ((i, j), (j, i)):
        away = verts[moved][:, :2].mean(0) - verts[other][:, :2].mean(0)
        norm = float(np.linalg.norm(away))
        away = away / norm if norm > 1e-9 else np.array([1.0, 0.0])
        step = np.r_[away, 0.0]
        consider("apart", moved, lambda a: a, lambda a, m=moved, s=step: {m: verts[m] + a * s}, sum(size) + start)
    thin = min(pair, key=lambda k: float(np.ptp(verts[k], axis=0).min()))
    base = np.r_[0.5 * (verts[thin][:, :2].min(0) + verts[thin][:, :2].max(0)), verts[thin][:, 2].min()]
    # the amount searched is how much smaller (0 → 1 − MIN_SCALE), so that the least amount is the least change
    consider("shrink", thin, lambda a: 1.0 - a,
             lambda a, k=thin: {k: base + (1.0 - a) * (verts[k] - base)}, 1.0 - MIN_SCALE)
    return min(candidates, key=lambda r: r.change, default=None)


def _with_riders(changed: dict, moved: int, verts, supports, how: str, amount: float) -> dict:
    """``changed`` with every object resting on ``moved`` carried along: by the same move, or, for a shrink,
    by the drop of the top of what holds them."""
    out = dict(changed)
    carried = [k for k in riders(moved, supports) if k != moved]
    if not carried:
        return out
    delta = np.zeros(3)
    if how in ("up", "apart"):
        delta = out[moved].mean(0) - verts[moved].mean(0)
    else:
        delta[2] = float(out[moved][:, 2].max() - verts[moved][:, 2].max())
    for k in carried:
        out[k] = verts[k] + delta
    return out
