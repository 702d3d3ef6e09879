"""Objects resting on others in the photo (a cup on its saucer, a book on a box, fruit in a bowl).

From the masks alone: object A rests on object B when

- seen from the side, most of A's lowest outline (the bottom pixel of each of
  its columns) touches B's mask just below it, A's foot is higher in the photo
  than B's, and most of A's bottom lies within B's columns (it may overhang); or
- seen from above, most of the ring just outside A's mask is B, its lowest
  quarter included (A lies inside B's outline, B partly hidden by A; an
  object standing in front of B shows the ground below it instead); or
- A's foot (its lowest tenth) lies on B's face, below B's top and above B's
  foot, though the rest of its lowest outline does not (a plant whose lowest
  leaf hangs over its pot's front);
- seen from nearly straight above (:func:`supports_from_above`, under each camera the pitch search tries), A
  hides B over the middle of B's completed outline or lies within it: from there a thing can only hide what
  is under it, and
  the side view's readings, which look for A's foot, find none.

The masks cannot tell a cup on a saucer from a cup hidden behind the saucer's
rim; the first reading is taken, which the README states.
With the photo's occlusion order, an object that hides A stands in front of it and
gives way to one that does not (a ball in a bowl, partly behind another ball, rests
on the bowl, :func:`find_supports`).

An object that rests on nothing the masks show (on a shelf, hung on a wall, on an object its contact was not
seen with) is read from its size instead (:func:`raise_unseen`): stood on the ground, its foot's ray lands far
behind the others and its outline makes it larger than its label's typical size by more than the others'
sizes allow. It is brought nearer along the camera's rays (a scale about the camera's centre, which keeps its
outline exactly) to the depth at which its size agrees with the others'; there it stands on the object under
its base, or, with none, is held where it is by what the photo shows no mask of. Each upper object
then stands on its lower one's surface (``align.photo_scene.surface_under``)
instead of on the ground, moves with it when objects are moved apart, and is
raised out of it where it starts inside it (:func:`settle_on_supports`); one held over an open vessel's mouth
goes down the camera's rays into its hollow first (:func:`into_vessel`), its outline kept.
An object that rests on several together (a fruit in a pile's hollow) and whose centre of mass is beyond
the top of the one it was stood on is lowered into their hollow (:func:`into_hollow`, from the steadying pass):
moved onto that one's top it balances on a dome and rolls off.
:func:`start_contacts` says, for the report, what each object starts on and
how far from it.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..lift.footprint import upright_plate
from ..lift.silhouette import fill_holes, foot_pixel
from .wall import depth_against

#: Fraction of A's lowest outline that must touch B (side view), or of the ring around A that must be B (above).
CONTACT_FRACTION = 0.6
ENCLOSED_FRACTION = 0.6
#: The part of a supporter an object can rest on: what lies within this fraction of its height below the
#: surface the object stands on.
TOP_BAND = 0.15
#: A's foot: its pixels within this fraction of its height of its lowest row; a foot on B's face scores this
#: fraction of what a contact along the whole lowest outline does.
FOOT_BAND = 0.1
FOOT_WEIGHT = 0.5
#: Seen from the side, this fraction of A's columns must lie within B's (A may overhang B by the rest).
WITHIN_FRACTION = 0.7
#: Seen at least this steeply (every ray through A's outline this far below the horizontal), A that hides
#: the middle of B's completed outline rests on B (:func:`supports_from_above`). From 60° down a thing on the
#: ground hides at most 0.58 of its height of the ground behind it, so one beside B rarely covers B's middle;
#: from 86° down two stacked boxes were built side by side on the ground, the upper one twice its width.
ABOVE_MIN_DEG = 60.0
#: ... or that lies within B's completed outline's hull by this fraction of its visible pixels (on B's top).
ABOVE_WITHIN = 0.8


def _lowest_outline(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns and rows of each column's lowest pixel."""
    cols = np.nonzero(mask.any(axis=0))[0]
    rows = mask.shape[0] - 1 - np.argmax(mask[::-1, cols], axis=0)
    return cols, rows


def support_score(upper: np.ndarray, lower: np.ndarray, reach: int) -> tuple[float, str]:
    """(score in [0, 1], 'contact' | 'enclosed' | 'foot') of ``upper`` resting on ``lower``; 0 when it does not."""
    a = fill_holes(upper)
    b = lower.astype(bool)
    h = a.shape[0]
    cols, rows = _lowest_outline(a)
    touch = np.array([b[min(r + 1, h - 1):min(r + 1 + reach, h), c].any() for c, r in zip(cols, rows)])
    contact = float(touch.mean()) if len(touch) else 0.0
    b_cols = np.nonzero(b.any(axis=0))[0]
    # most of A's width over B's: an upper box turned or shifted on its lower one overhangs it by a little
    within = (cols >= b_cols.min() - reach) & (cols <= b_cols.max() + reach) if len(b_cols) else cols < 0
    inside = bool(len(b_cols)) and float(within.mean()) >= WITHIN_FRACTION
    foot_a, foot_b = foot_pixel(a)[1], foot_pixel(fill_holes(b))[1]
    if contact >= CONTACT_FRACTION and inside and foot_a < foot_b - 1:
        return contact, "contact"
    ring = cv2.dilate(a.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    ring &= ~a
    enclosed = float((ring & b).sum() / max(ring.sum(), 1))
    # below A too: an object standing in front of B shows the ground under it, not B
    ys = np.nonzero(ring)[0]
    low = ring & (np.arange(h)[:, None] >= np.percentile(ys, 75)) if len(ys) else ring
    below = float((low & b).sum() / max(low.sum(), 1))
    if enclosed >= ENCLOSED_FRACTION and below >= ENCLOSED_FRACTION:
        return enclosed, "enclosed"
    # A's foot over B's face, inside B's outline, between B's top and its foot: a plant whose lowest leaf hangs over its pot's front,
    # a toy sitting in a box; it ranks under a contact along A's whole lowest outline
    rows_a = np.nonzero(a.any(axis=1))[0]
    rows_b = np.nonzero(b.any(axis=1))[0]
    if len(rows_a) and len(rows_b) and rows_b[0] < foot_a < foot_b - 1:
        band = a & (np.arange(h)[:, None] >= foot_a - FOOT_BAND * (rows_a[-1] - rows_a[0] + 1))
        # on B's face, in front of it: inside B's outline, not on its edge (a fruit in the hollow behind another
        # touches that one's top edge only)
        ys, xs = np.nonzero(b)
        hull = cv2.convexHull(np.stack([xs, ys], 1).astype(np.int32))
        over_b = cv2.fillConvexPoly(np.zeros(b.shape, np.uint8), hull, 1) > 0
        on = float((band & over_b).sum() / max(band.sum(), 1))
        if on >= CONTACT_FRACTION:
            return FOOT_WEIGHT * on, "foot"
    return 0.0, ""


def find_supports(masks, hides=()) -> dict[int, tuple[int, str]]:
    """``{upper index: (lower index, how)}`` (how: 'contact', 'enclosed' or 'foot'); no object rests on
    itself or, through others, on itself.

    ``hides``: (occluder, occluded) index pairs (``perceive.amodal.occlusion_order``). An object that hides
    another stands in front of it: what the completed outline's foot touches there is that object's front,
    not a top it stands on. Of the readings along the whole lowest outline or all around ('contact',
    'enclosed'), one by an object that does not hide it goes first (a ball in a bowl, half hidden by the
    ball in front of it, rests on the bowl); where only what hides it reads as a support, that reading
    stands (a cup whose base the saucer's front rim hides), and the lift judges it
    (``align.photo_scene.behind_what_hides_it``)."""
    if not masks:
        return {}
    hides = set(hides)
    reach = max(2, int(round(0.01 * masks[0].shape[0])))
    found: dict[tuple[int, int], tuple[float, str]] = {}
    for i, a in enumerate(masks):
        for j, b in enumerate(masks):
            if i == j:
                continue
            score, how = support_score(a, b, reach)
            if score > 0:
                found[(i, j)] = (score, how)

    def rank(i, j):
        score, how = found[(i, j)]
        return (how != "foot" and (j, i) not in hides, score)

    best: dict[int, tuple[float, int, str]] = {}
    for (i, j) in found:
        if i not in best or rank(i, j) > rank(i, best[i][1]):
            best[i] = (found[(i, j)][0], j, found[(i, j)][1])
    # in a stack, the completed outline of a lower object reaches up behind the ones on it, so the top one touches
    # every object under it: it rests on the one between (a candidate that itself rests on the chosen one, and
    # that does not hide it: one in front of it is not under it)
    for i in list(best):
        for _ in range(len(masks)):
            j = best[i][1]
            between = [k for (a, k) in found if a == i and k != j and (k, j) in found and (k, i) not in hides]
            if not between:
                break
            k = max(between, key=lambda k: found[(i, k)][0])
            best[i] = (found[(i, k)][0], k, found[(i, k)][1])
    for i, a in enumerate(masks):
        if i not in best:
            together = rests_on_several(i, masks, hides, reach)
            if together is not None:
                best[i] = (together[1], together[0], "contact")
    out = {i: (j, how) for i, (_, j, how) in best.items()}
    # break cycles: in a cycle, the object lowest in the photo rests on nothing
    feet = [foot_pixel(fill_holes(m))[1] for m in masks]
    for start in list(out):
        seen, k = [], start
        while k in out and k not in seen:
            seen.append(k)
            k = out[k][0]
        if k in seen:
            cycle = seen[seen.index(k):]
            out.pop(max(cycle, key=lambda n: feet[n]), None)
    return out


def touching_below(i: int, masks, hides, reach: int) -> dict[int, float]:
    """``{j: share of masks[i]'s lowest outline that touches masks[j] just below it}`` for each object ``j``
    whose foot is lower in the photo and that does not hide ``i`` (one in front of it is not under it)."""
    a = fill_holes(masks[i])
    h = a.shape[0]
    cols, rows = _lowest_outline(a)
    out = {}
    if not len(cols):
        return out
    foot_a = foot_pixel(a)[1]
    hides = set(hides)
    for j, m in enumerate(masks):
        b = np.asarray(m, bool)
        if j == i or (j, i) in hides or not b.any() or not foot_a < foot_pixel(fill_holes(b))[1] - 1:
            continue
        t = np.array([b[min(r + 1, h - 1):min(r + 1 + reach, h), c].any() for c, r in zip(cols, rows)])
        if t.any():
            out[j] = float(t.mean())
    return out


def centre_depression_deg(mask: np.ndarray, camera) -> float:
    """The angle (degrees) below the horizontal of the camera's ray through the centre of ``mask`` (H, W) bool."""
    ys, xs = np.nonzero(mask)
    d = camera.rays(float(xs.mean()) + 0.5, float(ys.mean()) + 0.5)
    return float(np.degrees(np.arcsin(np.clip(-d[2], -1.0, 1.0))))


def supports_from_above(masks, visible, hides, camera, found) -> dict[int, tuple[int, str]]:
    """The supports ``found`` (:func:`find_supports`, which reads feet) as a steep view shows them: where
    ``upper`` hides ``lower`` (``hides``: (occluder, occluded) pairs), is seen at least :data:`ABOVE_MIN_DEG`
    down by ``camera`` through its centre, rests on nothing else in ``found`` and covers the centre of
    ``lower``'s completed outline (``masks``, (H, W) bool) with its visible one's (``visible``) hull, or lies
    within that outline's hull by :data:`ABOVE_WITHIN` of its visible pixels, it rests
    on ``lower`` ('above'), and a reading of ``lower`` resting on it is dropped: from above, the lowest outline
    the side view reads as a foot is the far side of the one beneath. Of several such lowers, the one it covers
    most of. The lift judges each (``align.photo_scene.balances_on``): one that would topple off stands on the
    ground."""
    out = dict(found)
    cover: dict[int, float] = {}
    for i, j in hides:
        if i in found or not visible[i].any() or not masks[j].any():
            continue
        if centre_depression_deg(visible[i], camera) < ABOVE_MIN_DEG:
            continue
        hull = cv2.fillConvexPoly(np.zeros(visible[i].shape, np.uint8),
                                  cv2.convexHull(np.argwhere(visible[i])[:, ::-1].astype(np.int32)), 1) > 0
        ys, xs = np.nonzero(masks[j])
        lower = cv2.fillConvexPoly(np.zeros(masks[j].shape, np.uint8),
                                   cv2.convexHull(np.stack([xs, ys], 1).astype(np.int32)), 1) > 0
        # over B's middle (a box on a box that hides most of it), or within B's outline (a cup on a book's edge)
        within = float((lower & visible[i]).sum() / visible[i].sum())
        if not hull[int(round(ys.mean())), int(round(xs.mean()))] and within < ABOVE_WITHIN:
            continue
        share = float((hull & masks[j]).sum() / masks[j].sum())
        if share <= cover.get(i, 0.0):
            continue
        if out.get(j, (None,))[0] == i:
            out.pop(j)
        if rests_on(j, i, out):
            continue
        out[i], cover[i] = (j, "above"), share
    return out


def reaching_under(masks, visible, supports) -> list:
    """``masks`` (completed outlines, (H, W) bool) with each lower of an 'above' support (:func:`supports_from_above`)
    reaching, behind its upper, under that one's middle: the convex hull of its completed outline and the middle
    half of its upper's visible outline (shrunk to half about its centre), cut to what the upper hides. Seen from
    above, what holds a thing lies under its centre; a completion that closes the lower's visible sliver alone
    (a strip beside the box on it) stood the upper off its top and both on the ground, side by side."""
    out = list(masks)
    for i, (j, how) in supports.items():
        if how != "above":
            continue
        ys, xs = np.nonzero(visible[i])
        middle = np.stack([0.5 * (xs + xs.mean()), 0.5 * (ys + ys.mean())], 1)
        pts = np.concatenate([np.argwhere(out[j])[:, ::-1].astype(float), middle])
        hull = cv2.fillConvexPoly(np.zeros(out[j].shape, np.uint8),
                                  np.round(cv2.convexHull(pts.astype(np.float32))[:, 0, :]).astype(np.int32), 1) > 0
        out[j] = out[j] | (hull & visible[i])
    return out


def rests_on_several(i: int, masks, hides, reach: int) -> tuple[int, float] | None:
    """(the one it touches most, the contact) where ``masks[i]``'s lowest outline rests on several objects
    together, none of which alone reads as its support (a fruit in the hollow on top of a pile, a board over
    two boxes): most of that outline touches one of them just below (:func:`touching_below`), and most of its
    columns lie within theirs. None where it does not. Its balance over all of them is judged once they are
    lifted (``align.photo_scene.balances_on``)."""
    a = fill_holes(masks[i])
    h = a.shape[0]
    cols, rows = _lowest_outline(a)
    each = touching_below(i, masks, hides, reach)
    if len(each) < 2:
        return None
    touch, within = np.zeros(len(cols), bool), np.zeros(len(cols), bool)
    for j in each:
        b = np.asarray(masks[j], bool)
        touch |= np.array([b[min(r + 1, h - 1):min(r + 1 + reach, h), c].any() for c, r in zip(cols, rows)])
        b_cols = np.nonzero(b.any(axis=0))[0]
        within |= (cols >= b_cols.min() - reach) & (cols <= b_cols.max() + reach)
    if touch.mean() < CONTACT_FRACTION or within.mean() < WITHIN_FRACTION:
        return None
    j = max(each, key=each.get)
    return j, float(touch.mean())


def support_order(n: int, supports: dict[int, tuple[int, str]]) -> list[int]:
    """Indices with every lower object before the objects resting on it."""
    order, placed = [], set()

    def visit(i):
        if i in placed:
            return
        if i in supports:
            visit(supports[i][0])
        placed.add(i)
        order.append(i)

    for i in range(n):
        visit(i)
    return order


def root_of(i: int, supports: dict[int, tuple[int, str]]) -> int:
    while i in supports:
        i = supports[i][0]
    return i


def start_contacts(vertex_sets, faces, supports: dict[int, tuple[int, str]], names, held=()) -> list[dict]:
    """What each placed object stands on and how far from it it starts, for ``report.json``.

    ``support``: 'ground', the name of the object it rests on, or 'held' (``held``: indices resting on what
    no mask shows, :func:`raise_unseen`); ``clearance_m``: the gap under it (its
    lowest point above the ground, or its lowest vertices' distance outside the supporter's mesh; < 0 when
    inside); ``overlap_m``: the deepest any vertex of it lies inside another object's mesh (0 when none).
    """
    import trimesh

    from ..metrics.geometry import max_penetration

    meshes = [trimesh.Trimesh(v, f, process=False) for v, f in zip(vertex_sets, faces)]
    out = []
    for i, m in enumerate(meshes):
        z = m.vertices[:, 2]
        entry = {"support": "ground", "clearance_m": round(float(z.min()), 4)}
        if i in held:
            entry = {"support": "held", "clearance_m": round(float(z.min()), 4)}
        if i in supports:
            j = supports[i][0]
            low = m.vertices[z <= z.min() + 0.2 * max(float(np.ptp(z)), 1e-9)]
            outside = -trimesh.proximity.signed_distance(meshes[j], low)  # signed distance is > 0 inside
            entry = {"support": names[j], "clearance_m": round(float(outside.min()), 4)}
        entry["overlap_m"] = round(max((max_penetration({"a": m, "b": meshes[k]}) for k in range(len(meshes))
                                        if k != i), default=0.0), 4)
        out.append(entry)
    return out


#: An object starting deeper than this inside what holds it is raised out of it (metres).
SETTLE_TOLERANCE_M = 0.0005


def settle_on_supports(vertex_sets, faces, supports: dict[int, tuple[int, str]], vessels=(),
                       eye=None) -> tuple[list[np.ndarray], list[float]]:
    """Vertex sets with every object that starts inside what holds it raised until it rests on it, and each
    object's rise (metres; < 0 for one lowered into a vessel). Objects resting on a moved one move with it;
    lower objects first.

    Standing on the supporter's surface where the foot's ray meets it (``align.photo_scene.surface_under``)
    can leave the rest of an object's base inside a supporter that is higher elsewhere (a cup's back over a
    saucer's rim); a simulation would push it out with energy it never had. An object held over an open
    vessel's mouth (``vessels``: a flag per object, ``lift.vessel``) goes down into it first
    (:func:`into_vessel`, along the rays from the camera at ``eye``).
    """
    import trimesh

    verts = [np.asarray(v, float).copy() for v in vertex_sets]
    rise = [0.0] * len(verts)
    for i in support_order(len(verts), supports):
        if i not in supports:
            continue
        j = supports[i][0]
        if eye is not None and j < len(vessels) and vessels[j]:
            t = into_vessel(verts[i], verts[j], eye)
            if t is not None:
                o = np.asarray(eye, float)
                low = float(verts[i][:, 2].min())
                for k in riders(i, supports):
                    verts[k] = o + t * (verts[k] - o)
                rise[i] += float(verts[i][:, 2].min()) - low
        z = verts[i][:, 2]
        low = verts[i][z <= z.min() + 0.2 * max(float(np.ptp(z)), 1e-9)]
        inside = float(trimesh.proximity.signed_distance(trimesh.Trimesh(verts[j], faces[j], process=False),
                                                         low).max())  # > 0 inside
        if inside > SETTLE_TOLERANCE_M:
            up = np.array([0.0, 0.0, inside])
            for k in range(len(verts)):
                if k == i or rests_on(k, i, supports):
                    verts[k] = verts[k] + up
                    rise[k] += inside
    return verts, rise


#: An object lowered into a vessel (:func:`into_vessel`) is scaled about the camera by at most this factor: farther,
#: the photo shows it elsewhere than in that vessel.
VESSEL_REACH = 1.6


def into_vessel(points: np.ndarray, vessel: np.ndarray, eye) -> float | None:
    """The factor about the camera at ``eye`` (3,) that brings the object ``points`` (N, 3), held over the mouth
    of the open vessel ``vessel`` (its vertices, ``lift.vessel.vessel_mesh`` moved whole), down into it until it
    touches the vessel's inner floor or wall; None where it is wider than the mouth (foliage over a pot rests on
    the rim, ``lift.rim``), or where no factor up to :data:`VESSEL_REACH` puts it in the hollow (its centre
    within the inner rim, below the rim, clear of the wall and the floor).

    A fruit in a bowl, seen from above the rim, shows its foot in the bowl's mouth: stood where that ray meets
    the rim, a ball rests on the rim's edge, drops in and rolls up the far wall and out (an apple in a bowl
    rolled 18 cm). Scaled about the camera, its outline in the photo stays exactly as it was; it moves down the
    rays into the bowl and grows by the factor, which the tangent cone of a ball resting on the inner floor
    also gives (``lift.footprint.sphere_from_outline``)."""
    from ..lift.rim import vessel_frame
    from ..lift.vessel import SECTIONS

    f = vessel_frame(vessel)
    pts = np.asarray(points, float)
    o = np.asarray(eye, float)
    axis = np.asarray(f["centre"], float)
    half = 0.5 * float(np.ptp(pts[:, :2], axis=0).max())
    if half >= f["inner"]:
        return None
    flat = np.cos(np.pi / SECTIONS)  # the revolved wall's flat sides lie this far in of its corners

    def clear(t: float) -> bool:  # no point of it inside the vessel's wall or floor
        p = o + t * (pts - o)
        low = p[p[:, 2] < f["rim_z"]]
        if not len(low):
            return True
        wall = flat * (f["inner"] - f["slope"] * (f["rim_z"] - low[:, 2]))
        return bool((low[:, 2] >= f["floor_z"]).all() and (np.linalg.norm(low[:, :2] - axis, axis=1) <= wall).all())

    if not clear(1.0):
        return None  # already in the wall: raised out of it as any

    def inside(t: float) -> bool:  # below the rim, within the mouth, and clear of the vessel
        p = o + t * (pts - o)
        return float(p[:, 2].min()) < f["rim_z"] and float(np.linalg.norm(p[:, :2].mean(0) - axis)) <= f["inner"] \
            and clear(t)

    # a placement, not a motion: the path down the rays may pass through the front rim (the vessel is lifted
    # from its outline, a few millimetres either way); what counts is where it ends, in the hollow on what holds it
    step = 0.002
    ts = np.arange(1.0, VESSEL_REACH, step)
    ok = np.array([inside(t) for t in ts])
    if not ok.any():
        return None
    k = int(np.nonzero(ok)[0].max())  # the last stretch in the hollow ends on its floor or far wall
    if k + 1 >= len(ts):
        return None
    lo, hi = float(ts[k]), float(ts[k + 1])
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if clear(mid) else (lo, mid)
    return lo if lo > 1.0 + 1e-6 else None


def rests_on(k: int, i: int, supports: dict[int, tuple[int, str]]) -> bool:
    """Whether ``k`` rests, directly or through others, on ``i``."""
    seen = set()
    while k in supports and k not in seen:
        seen.add(k)
        k = supports[k][0]
        if k == i:
            return True
    return False


#: An object stood on the ground whose size, under the scale the other objects' sizes give, is this many times
#: its label's typical size (and which stands behind all of them) rests on something the masks do not show.
RAISE_RATIO = 1.5
#: ... brought nearer to the depth at which it is this many times its typical size: the middle of what the
#: other objects' own sizes spread over, rather than the prior exactly.
RAISE_TO = 1.0
#: Raised, it stands on another object whose top lies within this fraction of its own height of its base.
LAND_FRACTION = 0.35


def riders(i: int, supports: dict) -> list[int]:
    """``i`` and every object resting on it, directly or through others (``supports``: {upper: (lower, how)})."""
    out, grew = [i], True
    while grew:
        grew = False
        for k, (j, _) in supports.items():
            if j in out and k not in out:
                out.append(k)
                grew = True
    return out


def raise_unseen(lifted, labels, supports: dict, camera, scale: float = 1.0, photo=None,
                 masks=None) -> dict[int, dict]:
    """Objects stood on the ground that rest on something the masks do not show, brought to where their size
    agrees with the others' (see the module); ``lifted`` (``lift.silhouette.LiftedMesh``, under ``camera``) are
    changed in place, objects resting on a raised one move with it, and ``supports`` gains those that now stand
    on another object (how: 'size'). Returns {index: what was done} for the report; a raised object that stands
    on nothing has ``held`` True (``build`` holds it fixed where the photo shows it).

    ``scale`` turns the camera's units into metres (the labels' typical sizes are metres). With the ``photo``
    and the ``masks`` lifted, a wall's line across the photo (``align.wall``) bounds the ground first: an
    object whose foot is above it, while another's stands below it, is held in front of the wall, its back
    against the wall's plane, whatever its size says. A plate that would be held up by nothing is first stood
    upright where its outline reads so (``lift.footprint.upright_plate``: a card pinned on a wall), and raised
    by its size standing; its entry has ``upright`` True."""
    from ..geometry.mesh import longest_dimension
    from ..sizes import size_prior
    from .place import footprint

    n = len(lifted)
    priors = [size_prior(label) for label in labels]
    typical = [p.longest_m / scale if p is not None and p.votes and p.longest_m else None for p in priors]
    longest = [longest_dimension(m.vertices) for m in lifted]
    origin = np.asarray(camera.origin, float)
    free = [i for i in range(n) if i not in supports]
    out: dict[int, dict] = {}

    def reach(i):  # horizontal distance from the camera of an object's farthest and nearest vertex
        d = np.linalg.norm(lifted[i].vertices[:, :2] - origin[:2], axis=1)
        return float(d.min()), float(d.max())

    holders = {j for j, _ in supports.values()}
    wall = _wall(photo, masks, camera, free, holders)
    for i in free:
        # what holds others up stands on the ground (a stack on a shelf is left where the cues put it), and so
        # does one behind a pile that holds up the fruit read as on it (``holds``, from ``align.photo_scene``)
        if lifted[i].info.get("foot") or i in holders or lifted[i].info.get("holds"):
            continue
        near = reach(i)[0]

        def attempt(verts, size):
            """(t, entry, land) that raises ``verts`` (object ``i`` read ``size`` long) to where the others'
            sizes or the wall put it, or None where it stays on the ground."""
            others = [j for j in range(n) if j != i and typical[j] is not None and j not in riders(i, supports)]
            ratio = None
            if typical[i] is not None and others:
                # the scene's scale as the others' sizes read it: each is its typical size over its lifted one
                ref = float(np.exp(np.median([np.log(typical[j] / max(longest[j], 1e-9)) for j in others])))
                ratio = ref * size / typical[i]
            t = None
            # its size must not deny it: one that already reads smaller than its label's typical size on the
            # ground would be smaller still nearer (a shaded band across the floor read as the wall's foot, fruit
            # behind it)
            if wall is not None and i in wall[1] and (ratio is None or ratio >= WALL_MIN_RATIO):
                t = depth_against(verts, wall[0], origin)
                t = t if t is not None and t < 1.0 else None
            entry = {"against_wall": True}
            if t is None:
                if ratio is None:
                    return None
                ground = [j for j in free if j != i and j not in riders(i, supports)]
                # behind all on the ground as lifted lying, where the photo put it
                behind = bool(ground) and near > max(reach(j)[1] for j in ground)
                if ratio <= RAISE_RATIO or not behind:
                    return None
                t = RAISE_TO / ratio
                entry = {"size_ratio": round(ratio, 3)}
            base0 = float(verts[:, 2].min())
            z_base = origin[2] + t * (base0 - origin[2])
            moved = origin + t * (verts - origin)
            height = float(np.ptp(moved[:, 2]))
            centre = moved[:, :2].mean(0)
            land = None
            for j in range(n):
                if j in riders(i, supports):
                    continue
                top = float(lifted[j].vertices[:, 2].max())
                hull = footprint(lifted[j].vertices).astype(np.float32).reshape(-1, 1, 2)
                inside = cv2.pointPolygonTest(hull, (float(centre[0]), float(centre[1])), False) >= 0
                if inside and abs(top - z_base) <= LAND_FRACTION * height and (land is None or top > land[1]):
                    land = (j, top)
            if land is not None:  # on what is under it: the depth at which its base meets that top
                t = (land[1] - origin[2]) / (base0 - origin[2])
            return t, entry, land

        raised, stood = None, None
        if getattr(lifted[i], "shape", None) == "plate" and len(riders(i, supports)) == 1:
            # a plate that would be held up by nothing seen lies on nothing: it may be pinned upright (a card on
            # the wall). Whether it stands does not depend on its depth; its depth depends on its size standing
            # (lying, a card's outline cast on the ground is a plate many times its size, read far too near)
            stood = upright_plate(lifted[i].vertices, camera)
            if stood is not None:
                raised = attempt(stood[0], longest_dimension(stood[0]))
                if raised is None or raised[2] is not None:  # on the ground or on another: it lies as lifted
                    raised = stood = None
        def stand(mesh):
            lifted[i].vertices, lifted[i].faces = mesh
            lifted[i].contact = mesh[0][np.argmin(mesh[0][:, 2])]

        if stood is not None:
            thickness = float(np.ptp(lifted[i].vertices[:, 2]))
            stand(stood)
            longest[i] = longest_dimension(stood[0])
        else:
            raised = attempt(lifted[i].vertices, longest[i])
            if raised is None:
                continue
        t, entry, land = raised
        _hold(i, t, lifted, supports, origin, scale, out, entry, land)
        if stood is not None:
            if entry.get("against_wall"):  # its back on the wall's plane
                on = upright_plate(lifted[i].vertices, camera, wall[0], thickness)
                if on is not None:
                    stand(on)
            out[i] |= {"upright": True, "base_m": round(float(lifted[i].vertices[:, 2].min()) * scale, 4)}
            lifted[i].info["raised"] = out[i]
    return out


#: An object held against the wall reads at least this many times its typical size stood on the ground.
WALL_MIN_RATIO = 1.0


def _wall(photo, masks, camera, free, holders):
    """(the wall's plane, the objects held above the ground by it) where the photo shows a wall's line that
    some object on the ground stands in front of (its foot below the line); None otherwise."""
    from .wall import find_wall_line, foot_above, wall_plane

    if photo is None or masks is None:
        return None
    line = find_wall_line(photo, masks)
    if line is None:
        return None
    plane = wall_plane(line, camera)
    if plane is None:
        return None
    h = np.asarray(masks[0]).shape[0]
    feet = {i: foot_pixel(fill_holes(masks[i])) for i in free}
    above = {i for i in free if i not in holders and foot_above(line, *feet[i], h)}
    # a line above no object's foot is no wall's foot the scene stands in front of (a horizon, a print's edge)
    if not above or len(above) == len(free):
        return None
    return plane, above


def _hold(i, t, lifted, supports, origin, scale, out, entry, land=None):
    """Object ``i`` and what rests on it scaled by ``t`` about the camera's ``origin`` (its outline kept);
    it then stands on ``land`` (index, top) or is held where it is."""
    for k in riders(i, supports):
        m = lifted[k]
        m.vertices = origin + t * (m.vertices - origin)
        m.contact = origin + t * (np.asarray(m.contact, float) - origin)
    entry = entry | {"nearer": round(1.0 - t, 4), "base_m": round(float(lifted[i].vertices[:, 2].min()) * scale, 4)}
    if land is not None:
        supports[i] = (land[0], "size")
        entry["on"] = land[0]
    else:
        entry["held"] = True
    lifted[i].info["raised"] = entry
    out[i] = entry


#: A supporter is deepened (:func:`reach_under`) to at most this many times its width.
MAX_REACH = 2.5


def reach_under(lower, upper, camera, base: float) -> np.ndarray | None:
    """``lower``'s vertices deepened away from the camera until ``upper`` (standing at height ``base`` on it)
    has its centre well over its top, or None where depth is not what it lacks.

    The top of a box that another stands on is hidden by it, so the photo shows the box's front and sides and
    not how deep it is: lifted shallow, what the photo shows on it would overhang its back and topple. Its
    depth is the one dimension the photo leaves free, so the box reaches back under what it holds (its front,
    which the photo shows, stays), up to :data:`MAX_REACH` times its width. Where the upper's centre is beside
    the top rather than behind it (a box on the crown of a crumpled bag), nothing is deepened."""
    v = np.asarray(lower.vertices, float)
    fwd = np.asarray(camera.world_from_camera, float)[:, 2].copy()
    fwd[2] = 0.0
    if np.linalg.norm(fwd) < 1e-6:  # straight down: the depth is what the photo shows
        return None
    fwd /= np.linalg.norm(fwd)
    side = np.array([-fwd[1], fwd[0], 0.0])
    z = v[:, 2]
    top = v[z >= base - TOP_BAND * max(float(np.ptp(z)), 1e-9)]
    u = np.asarray(upper.vertices, float)
    centre = u.mean(0)
    across = top @ side
    if len(top) < 3 or not across.min() <= centre @ side <= across.max():
        return None
    along = v @ fwd
    front, back = float(along.min()), float(along.max())
    target = float(centre @ fwd + 0.2 * (np.max(u @ fwd) - centre @ fwd))  # its centre well inside
    width = float(np.ptp(v @ side))
    if target <= back or target - front > MAX_REACH * max(width, back - front):
        return None
    k = (target - front) / max(back - front, 1e-9)
    return v + np.outer((k - 1.0) * (along - front), fwd)


#: The level grid (m) on which :func:`into_hollow` compares an upper object's underside with the tops of the rest.
HOLLOW_CELL = 0.002
#: How far an upper object may move level into a hollow: this fraction of its smaller level width along the
#: line of sight (the photo hardly shows depth), :data:`HOLLOW_ACROSS` of it across (its image moves).
HOLLOW_ALONG = 0.5
HOLLOW_ACROSS = 0.1
#: Surfaces this close (m) touch: what an object rests on is everything this near under its underside.
HOLLOW_CONTACT = 0.003


def _height_grid(points: np.ndarray, lo: np.ndarray, shape: tuple[int, int], top: bool,
                 cell: float = HOLLOW_CELL) -> np.ndarray:
    """The highest (``top``) or lowest of ``points`` (N, 3) in each cell of a level grid of ``cell`` cells from
    ``lo`` (2,), ``-inf`` / ``inf`` where none falls."""
    cells = np.floor((points[:, :2] - lo) / cell).astype(int)
    ok = (cells >= 0).all(1) & (cells[:, 0] < shape[0]) & (cells[:, 1] < shape[1])
    grid = np.full(shape, -np.inf if top else np.inf)
    (np.maximum if top else np.minimum).at(grid, (cells[ok, 0], cells[ok, 1]), points[ok, 2])
    return grid


def _surface_points(vertices: np.ndarray, faces: np.ndarray, cell: float = HOLLOW_CELL, keep=None,
                    per_cell: float = 8.0) -> np.ndarray:
    """The vertices and enough points on the faces (those of ``keep``, a mask, where given) that every ``cell``
    cell of the surface has some (``per_cell`` of them on average)."""
    import trimesh

    if keep is not None:
        faces = np.asarray(faces)[keep]
        if not len(faces):
            return np.asarray(vertices, float)[:0]
        vertices = np.asarray(vertices, float)
        used = np.unique(faces)
        vertices, faces = vertices[used], np.searchsorted(used, faces)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    # the coarse grid's sampling as it was; the finer one samples only underside and window, so may take more
    n = int(min(200_000 if cell >= HOLLOW_CELL else 400_000, max(2_000, per_cell * mesh.area / cell ** 2)))
    return np.vstack([np.asarray(vertices, float), trimesh.sample.sample_surface(mesh, n, seed=0)[0]])


def into_hollow(verts, faces, supports: dict, i: int, com: np.ndarray, eye=None,
                margin: float = 0.0, ground_z: float = 0.0) -> tuple[np.ndarray, list[int]] | None:
    """The shift (3,) that lowers object ``i`` (resting on ``supports[i]``) into the hollow of what lies around
    it, and the objects it then rests on; None where none holds it. A fruit read as resting on one of a
    pile's fruits stands, lifted, on that one's rounded side with its centre of mass beyond it: put on
    that one's top it balances on a dome and rolls off into the hollow; dropped into the hollow it rests on all
    of them together, as the photo shows. Of the level moves within :data:`HOLLOW_ALONG` of its width along
    the line of sight from ``eye`` and :data:`HOLLOW_ACROSS` across, with its fall to the first touch of any
    other object (or the ground at ``ground_z``) below, the lowest place is taken; it holds if its centre of
    mass ``com`` lies ``margin`` inside the level hull of where it then touches, the supporter among them.
    What rests on it moves with it."""
    from scipy.spatial import ConvexHull, QhullError

    movers = riders(i, supports)
    pts = _surface_points(verts[i], faces[i])
    width = float(np.ptp(pts[:, :2], axis=0).min())
    ray = np.asarray(com, float) - np.asarray(eye, float) if eye is not None else np.array([1.0, 0.0, 0.0])
    along = ray[:2] / max(float(np.linalg.norm(ray[:2])), 1e-12) if np.linalg.norm(ray[:2]) > 1e-9 \
        else np.array([1.0, 0.0])
    reach = HOLLOW_ALONG * width
    steps = int(np.ceil(reach / HOLLOW_CELL))
    lo = pts[:, :2].min(0) - (steps + 1) * HOLLOW_CELL
    shape = tuple(np.ceil((pts[:, :2].max(0) + (steps + 1) * HOLLOW_CELL - lo) / HOLLOW_CELL).astype(int) + 1)
    under = _height_grid(pts, lo, shape, top=False)
    tops, owner = np.full(shape, ground_z), np.full(shape, -1)
    for k in range(len(verts)):
        if k in movers:
            continue
        box_lo, box_hi = verts[k][:, :2].min(0), verts[k][:, :2].max(0)
        if (box_hi < lo).any() or (box_lo > lo + np.array(shape) * HOLLOW_CELL).any():
            continue
        h = _height_grid(_surface_points(verts[k], faces[k]), lo, shape, top=True)
        owner[h > tops] = k
        tops = np.maximum(tops, h)
    rows, cols = np.nonzero(np.isfinite(under))
    best = None
    for dx in range(-steps, steps + 1):
        for dy in range(-steps, steps + 1):
            s = np.array([dx, dy], float) * HOLLOW_CELL
            a, c = float(s @ along), float(np.linalg.norm(s - (s @ along) * along))
            if (a / reach) ** 2 + (c / (HOLLOW_ACROSS * width)) ** 2 > 1.0:
                continue
            r, q = rows + dx, cols + dy
            gap = under[rows, cols] - tops[r, q]
            drop = float(gap.min())
            # lower is better; a move across the line of sight costs what it moves the image, and of places
            # as low, the nearest
            score = drop - c - 0.01 * float(np.linalg.norm(s))
            if best is None or score > best[0] + 1e-9:
                best = (score, dx, dy, drop)
    if best is None:
        return None
    _, dx, dy, drop = best
    if drop > 0.5 * float(np.ptp(pts[:, 2])):
        return None  # not a hollow: a fall past half its height is off what holds it
    r, q = rows + dx, cols + dy
    touch = under[rows, cols] - drop - tops[r, q] <= HOLLOW_CONTACT
    on = sorted({int(k) for k in owner[r[touch], q[touch]]})
    if supports[i][0] not in on:
        return None
    feet = lo + (np.column_stack([r[touch], q[touch]]) + 0.5) * HOLLOW_CELL
    c = np.asarray(com, float)[:2] + np.array([dx, dy]) * HOLLOW_CELL
    try:
        eq = ConvexHull(feet).equations
    except (QhullError, ValueError):
        return None
    if float((eq[:, :2] @ c + eq[:, 2]).max()) > -margin:
        return None
    # each cell's highest and lowest points stop the fall a slope's rise across a cell early (a fruit left 3 mm
    # over the hollow fell into it and rolled 5°): the place is found again on a finer grid around this one
    shift = _finer(verts, faces, movers, i, np.array([dx, dy]) * HOLLOW_CELL, along, reach, width, ground_z)
    return (shift if shift is not None else np.array([dx * HOLLOW_CELL, dy * HOLLOW_CELL, -drop])), on


#: The finer grid of :func:`_finer`: this fraction of :data:`HOLLOW_CELL`, searched this many coarse cells around
#: (one: the coarse grid's own error; farther, the coarse place's checks of touch and balance no longer hold).
HOLLOW_FINE = 0.25
HOLLOW_AROUND = 1
#: ... with this many surface points a cell on average (a few cells left empty cost less than the sampling).
HOLLOW_FINE_SAMPLES = 2.0


def _finer(verts, faces, movers, i: int, start: np.ndarray, along: np.ndarray, reach: float, width: float,
           ground_z: float) -> np.ndarray | None:
    """The move (3,) of object ``i`` into the lowest place within :data:`HOLLOW_AROUND` coarse cells of the level
    shift ``start`` (2,), as :func:`into_hollow` finds it, on a grid :data:`HOLLOW_FINE` as fine; None where
    none lies within its reach."""
    cell = HOLLOW_FINE * HOLLOW_CELL
    v, f = np.asarray(verts[i], float), np.asarray(faces[i])
    middle = 0.5 * (float(v[:, 2].min()) + float(v[:, 2].max()))
    # its underside: what meets what is under it
    pts = _surface_points(v, f, cell, (v[f, 2] <= middle).any(axis=1), HOLLOW_FINE_SAMPLES)
    steps = int(round(HOLLOW_AROUND / HOLLOW_FINE))
    pad = np.abs(start) + (steps + 1) * cell
    lo = pts[:, :2].min(0) - pad
    hi = pts[:, :2].max(0) + pad
    shape = tuple(np.ceil((hi - lo) / cell).astype(int) + 1)
    under = _height_grid(pts, lo, shape, False, cell)
    tops = np.full(shape, ground_z)
    for k in range(len(verts)):
        if k in movers:
            continue
        w, g = np.asarray(verts[k], float), np.asarray(faces[k])
        corner = w[g]  # (M, 3, 3): only faces over the window and as high as its underside matter
        keep = ((corner[:, :, :2].max(1) >= lo).all(1) & (corner[:, :, :2].min(1) <= hi).all(1)
                & (corner[:, :, 2].max(1) >= float(pts[:, 2].min()) - 0.5 * (middle - float(v[:, 2].min()))))
        if keep.any():
            tops = np.maximum(tops, _height_grid(_surface_points(w, g, cell, keep, HOLLOW_FINE_SAMPLES), lo, shape,
                                                 True, cell))
    rows, cols = np.nonzero(np.isfinite(under))
    base = np.round(start / cell).astype(int)
    best = None
    for dx in range(base[0] - steps, base[0] + steps + 1):
        for dy in range(base[1] - steps, base[1] + steps + 1):
            s = np.array([dx, dy], float) * cell
            a, c = float(s @ along), float(np.linalg.norm(s - (s @ along) * along))
            if (a / reach) ** 2 + (c / (HOLLOW_ACROSS * width)) ** 2 > 1.0:
                continue
            drop = float((under[rows, cols] - tops[rows + dx, cols + dy]).min())
            score = drop - c - 0.01 * float(np.linalg.norm(s))
            if best is None or score > best[0] + 1e-12:
                best = (score, s, drop)
    return None if best is None else np.r_[best[1], -best[2]]
