"""How a lifted rigid object rests on what is under it, in the terms both the build's placement
(``align``: whether a pile's hollow holds a fruit) and the simulator's steadying (``physics.support``) judge
it by: its contact band, its real contact (what touches, and the part of that over a top), the margin its
centre of mass keeps inside a top, the cap a rounded foot loses, and the centre of mass of its solid. Metres;
points (N, 3), world, z up."""

from __future__ import annotations

import numpy as np

from ..settings import REAL_CONTACT, STEADY_TILT_DEG

#: Points within this of the lowest (m, or this fraction of its height if larger) are its contact.
CONTACT_BAND = 0.01
#: A stacked object's centre of mass is brought this far (m, or this fraction of its footprint's smaller side
#: if less) inside the top of what holds it: on the edge, the solver's rocking tips it.
STEADY_MARGIN = 0.01
#: The flattened cap of a rounded foot is at most this fraction of the object's height (an orange: 2-3 mm).
FOOT_CUT = 0.05


def contact_band(points: np.ndarray) -> float:
    """How far above its lowest point (m) a point of ``points`` (N, 3) is still in its contact:
    :data:`CONTACT_BAND`, or that fraction of its height where larger."""
    return max(CONTACT_BAND, CONTACT_BAND * float(np.ptp(points[:, 2])))


def real_contact(points: np.ndarray, gap: np.ndarray | None = None) -> np.ndarray:
    """(K, 2): where ``points`` (N, 3) touch what they rest on, seen from above: those within
    :data:`~physomni_usd.settings.REAL_CONTACT` of the lowest and, where ``gap`` (N, m, each point's height over
    the surface straight under it) is given, those within that of the least gap too. On a slanted top more than
    the lowest point touches; on a level one a slanted foot touches only at its low end; a fruit in a pile's
    hollow rests by its lowest point on the fruits round it, not on the one it was read on alone."""
    pts = np.asarray(points, float)
    near = pts[:, 2] <= float(pts[:, 2].min()) + REAL_CONTACT
    if gap is not None:
        g = np.asarray(gap, float)
        near |= g <= float(np.min(g)) + REAL_CONTACT
    return np.unique(np.round(pts[near, :2], 6), axis=0)


def hull_ring(points: np.ndarray) -> np.ndarray:
    """(K, 2): the convex hull of ``points`` (N, 2) counter-clockwise; empty where it has no area."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.asarray(points, float).reshape(-1, 2)
    if len(pts) < 3:
        return pts[:0]
    try:
        return pts[ConvexHull(pts).vertices]
    except QhullError:
        return pts[:0]


def contact_over(feet: np.ndarray, top: np.ndarray) -> np.ndarray:
    """(K, 2): the convex hull of ``feet`` (a real contact) cut by that of ``top`` (what holds it, seen from
    above), counter-clockwise; empty where they do not overlap. The polygons, not the vertices of one inside the
    other: those move with how finely the object is meshed (a box 12 mm inside a book's edge was left alone on
    its 8 corners and shifted 2.5 mm subdivided twice)."""
    out, ring = hull_ring(feet), hull_ring(top)
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):  # each edge of the top's ring in turn clips what is left
        if not len(out):
            break
        e = b - a
        side = e[0] * (out[:, 1] - a[1]) - e[1] * (out[:, 0] - a[0])  # ≥ 0: on the top's side of the edge
        kept = []
        for k in range(len(out)):
            p, q, sp, sq = out[k - 1], out[k], side[k - 1], side[k]
            if (sp >= 0) != (sq >= 0):
                kept.append(p + (q - p) * sp / (sp - sq))
            if sq >= 0:
                kept.append(q)
        out = np.array(kept).reshape(-1, 2)
    return hull_ring(out)


def least_width(points: np.ndarray) -> float:
    """The least width (m) of the convex hull of ``points`` (N, 2) across any direction; 0 without area. Not
    its extent along x or y: a strip turned 45° is as thin as it was."""
    ring = hull_ring(points)
    if not len(ring):
        return 0.0
    e = np.roll(ring, -1, axis=0) - ring
    n = np.column_stack([-e[:, 1], e[:, 0]]) / np.maximum(np.linalg.norm(e, axis=1), 1e-18)[:, None]
    # for each edge, how far the farthest corner lies from its line: the hull's width across that edge
    return float(np.abs(np.einsum("kmd,kd->km", ring[None, :, :] - ring[:, None, :], n)).max(axis=1).min())


def steady_margin(foot: np.ndarray, height: float = 0.0) -> float:
    """How far (m) inside a top a centre of mass over ``foot`` (M, 2, its contact's points seen from above) is
    kept: :data:`STEADY_MARGIN`, or a quarter of the foot's least width (:func:`least_width`) where less, not of
    its extent along x or y (a strip along x stood; turned 45°, the same strip was judged twice as wide); and,
    that centre ``height`` (m) over the foot, no less than what keeps it up when tilted
    :data:`~physomni_usd.settings.STEADY_TILT_DEG`: how far inside a centre must lie to hold grows with its
    height, and a tall thin slab on a narrow foot passed the width rule and tipped."""
    width = min(STEADY_MARGIN, 0.25 * least_width(foot)) if len(foot) > 1 else STEADY_MARGIN
    return max(width, float(np.tan(np.radians(STEADY_TILT_DEG))) * max(float(height), 0.0))


def solid(points: np.ndarray, faces: np.ndarray):
    """The object as a trimesh solid: its own mesh where watertight with volume, else its convex hull."""
    import trimesh

    mesh = trimesh.Trimesh(points, faces, process=False)
    return mesh if mesh.is_watertight and mesh.volume > 0 else mesh.convex_hull


def solid_com(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The centre of mass (3,) of :func:`solid` at one density."""
    return np.asarray(solid(points, faces).center_mass, float)
