"""Keeping objects apart on the ground, and centring the scene on the origin.

Objects stand on z = 0 (or, held on a wall or shelf, above the others), so two of them can only overlap where
their footprints do and their heights meet. An object's depth is the one dimension a single photo does not
show, so an overlap is first resolved by making the nearer object shallower
(its front, which the camera sees, stays where it is); only what that cannot
fix is resolved by moving objects apart, which shifts them in the image.

Footprints Footprints are the convex hulls of the meshes' vertices
projected on the ground; the separating-axis test gives, for each
overlapping pair, the shortest horizontal move that separates them, and each
object takes half of it. Because the test runs on convex hulls that contain
the meshes, separated footprints mean separated meshes, and nothing is ever
moved vertically, so nothing is pushed into the ground.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

MAX_PASSES = 200


def footprint(vertices: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (n, 2) of the vertices' ground projection."""
    xy = np.asarray(vertices)[:, :2]
    try:
        hull = ConvexHull(xy)
        return xy[hull.vertices]
    except Exception:  # degenerate (flat) footprint: keep its extreme points
        lo, hi = xy.min(0), xy.max(0)
        return np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])


def separation(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """Shortest move (2,) of polygon ``b`` that ends its overlap with ``a``; None if they do not overlap."""
    best, best_axis = np.inf, None
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([edges[:, 1], -edges[:, 0]], 1)
        lengths = np.linalg.norm(normals, axis=1)
        normals = normals[lengths > 1e-12] / lengths[lengths > 1e-12, None]
        for n in normals:
            pa, pb = a @ n, b @ n
            overlap = min(pa.max(), pb.max()) - max(pa.min(), pb.min())
            if overlap <= 0:
                return None
            if overlap < best:
                best = overlap
                best_axis = n if pb.mean() >= pa.mean() else -n
    return best * best_axis


def separate(vertex_sets: list[np.ndarray], gap: float = 0.002) -> list[np.ndarray]:
    """Horizontal offsets (k, 3) that leave every pair of footprints at least ``gap`` apart.

    Each overlapping pair moves apart by half the needed distance each; passes
    repeat until no pair overlaps.
    """
    k = len(vertex_sets)
    offsets = np.zeros((k, 2))
    base = [footprint(v) for v in vertex_sets]
    heights = [(float(np.min(v[:, 2])), float(np.max(v[:, 2]))) for v in map(np.asarray, vertex_sets)]
    for _ in range(MAX_PASSES):
        moved = False
        for i in range(k):
            for j in range(i + 1, k):
                if not _level(heights[i], heights[j]):
                    continue  # one above the other (held on a wall, on a shelf): their footprints may cross
                pa = base[i] + offsets[i]
                pb = base[j] + offsets[j]
                g = effective_gap(pa, pb, gap)
                mtv = separation(pa + g * _outward_dirs(pa), pb + g * _outward_dirs(pb))
                if mtv is None:
                    continue
                step = mtv * (0.5 + 1e-3) + 1e-6 * np.sign(mtv)
                offsets[i] -= step
                offsets[j] += step
                moved = True
        if not moved:
            break
    return [np.array([o[0], o[1], 0.0]) for o in offsets]


#: An object is never made shallower than this fraction of its lifted depth.
MIN_DEPTH_SCALE = 0.25


def squash_depth(vertices: np.ndarray, front: np.ndarray, direction: np.ndarray, scale: float) -> np.ndarray:
    """Vertices with their depth behind the plane through ``front`` (normal ``direction``) scaled by ``scale``."""
    d = (vertices - front) @ direction
    return vertices - np.outer((1.0 - scale) * np.maximum(d, 0.0), direction)


def make_room(vertex_sets: list[np.ndarray], fronts: list[np.ndarray], camera_origin: np.ndarray,
              gap: float = 0.002, fixed_depth: list[bool] | None = None, balls: list[bool] | None = None,
              movable: bool = True) -> tuple[list[np.ndarray], list[float]]:
    """Make nearer objects shallower where their back overlaps an object behind them.

    ``fronts`` (3,) are the points where each object's outline meets the ground
    at its front; objects flagged in ``fixed_depth`` (seen from above, or a
    ball seen standing: their depth was measured) keep theirs and shrink about
    their own vertical axis instead. A ball seen standing (flagged in ``balls``)
    keeps its shape: where the objects will be moved apart after (``movable``)
    it is left as it is, else it shrinks as a whole about the point it rests on.
    Narrowed but not lowered as a footprint is, its image lost 15 % of its width
    and it became an egg taller than wide (0.97 to 0.79 of the photo's mask).
    Returns the new vertex sets and each object's depth scale.
    """
    verts = [np.asarray(v, float).copy() for v in vertex_sets]
    scales = [1.0] * len(verts)
    dirs = []
    for f in fronts:
        d = np.asarray(f, float) - camera_origin
        d[2] = 0.0
        dirs.append(d / max(np.linalg.norm(d), 1e-12))
    dist = [np.linalg.norm((np.asarray(f) - camera_origin)[:2]) for f in fronts]
    order = np.argsort(dist)
    for a in order:
        ball = balls is not None and balls[a]
        if ball and movable:
            continue  # separate() moves it the few millimetres its fit to the mask overlaps a neighbour's
        if ball or (fixed_depth is not None and fixed_depth[a]):
            _shrink_footprint(a, vertex_sets, verts, scales, gap, whole=ball)
            continue
        squashed = lambda k, a=a: squash_depth(vertex_sets[a], fronts[a], dirs[a], k)  # noqa: E731
        for b in order:
            if dist[b] <= dist[a] or _apart(verts[a], verts[b], gap):
                continue
            if not _apart(squashed(MIN_DEPTH_SCALE), verts[b], gap):
                scale = MIN_DEPTH_SCALE  # depth alone cannot fix it; moving apart does the rest
            else:  # largest depth that clears b: bisect between clear (lo) and overlapping (hi)
                lo, hi = MIN_DEPTH_SCALE, scales[a]
                for _ in range(20):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if _apart(squashed(mid), verts[b], gap) else (lo, mid)
                scale = lo
            scales[a] = scale
            verts[a] = squashed(scale)
    return verts, scales


#: A footprint lift is never shrunk below this fraction of its width to clear its neighbours.
MIN_FOOTPRINT_SCALE = 0.85


def _shrink_footprint(a: int, originals, verts, scales, gap: float, whole: bool = False) -> None:
    """Shrink footprint-lifted object ``a`` about its own vertical axis until it clears every other object
    (``whole``: in height too, about its lowest point on that axis, as a ball keeps its shape).

    A footprint's round shape is a fit to the mask; where two masks touch (sweets side by side) the fits
    overlap by a little. Shrinking keeps each object inside the pixels the photo shows it in, so frame 0
    stays the photo; moving them apart (what is left past ``MIN_FOOTPRINT_SCALE``) would not.
    """
    base = np.asarray(originals[a], float)
    centre = np.r_[0.5 * (base[:, :2].min(0) + base[:, :2].max(0)), float(base[:, 2].min()) if whole else 0.0]
    scaled = lambda k: centre + (base - centre) * np.array([k, k, k if whole else 1.0])  # noqa: E731
    others = [b for b in range(len(verts)) if b != a]
    if all(_apart(verts[a], verts[b], gap) for b in others):
        return
    clear = lambda k: all(_apart(scaled(k), verts[b], gap) for b in others)  # noqa: E731
    if not clear(MIN_FOOTPRINT_SCALE):
        k = MIN_FOOTPRINT_SCALE
    else:
        lo, hi = MIN_FOOTPRINT_SCALE, 1.0
        for _ in range(16):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if clear(mid) else (lo, mid)
        k = lo
    scales[a] = k
    verts[a] = scaled(k)


def _level(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether two height ranges (lowest, highest) overlap: only then can two objects' footprints collide."""
    return min(a[1], b[1]) > max(a[0], b[0])


def _apart(va: np.ndarray, vb: np.ndarray, gap: float) -> bool:
    if not _level((va[:, 2].min(), va[:, 2].max()), (vb[:, 2].min(), vb[:, 2].max())):
        return True
    pa, pb = footprint(va), footprint(vb)
    gap = effective_gap(pa, pb, gap)
    return separation(pa + gap * _outward_dirs(pa), pb + gap * _outward_dirs(pb)) is None


#: The clearance between two footprints is at most this fraction of the smaller one's width.
GAP_FRACTION = 0.02


def effective_gap(pa: np.ndarray, pb: np.ndarray, gap: float) -> float:
    """``gap`` (metres), or less between small things: 2 mm is an eighth of a sweet."""
    small = min(float(np.ptp(pa, axis=0).min()), float(np.ptp(pb, axis=0).min()))
    return min(gap, GAP_FRACTION * small)


def _outward_dirs(poly: np.ndarray) -> np.ndarray:
    c = poly.mean(0)
    d = poly - c
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return d / np.maximum(n, 1e-12) * 0.5


def centring_offset(vertex_sets: list[np.ndarray]) -> np.ndarray:
    """Horizontal offset (3,) that puts the middle of all footprints at the origin."""
    xy = np.vstack([np.asarray(v)[:, :2] for v in vertex_sets])
    mid = 0.5 * (xy.min(0) + xy.max(0))
    return np.array([-mid[0], -mid[1], 0.0])


def deepen(vertices: np.ndarray, thin: dict, camera_origin) -> np.ndarray:
    """``vertices`` (n, 3) stretched along the thin axis of ``thin`` (``metrics.geometry.thin_side``) to its
    ``need_m``. A near-vertical axis grows upward from the base, which stays on what holds it; any other grows
    away from the camera behind the face it sees, so the outline the photo shows barely changes. The longest
    side never grows (the least thickness is under the outline's smaller side)."""
    v = np.asarray(vertices, float)
    axis = np.asarray(thin["axis"], float)
    if abs(axis[2]) > 0.7:
        axis = axis if axis[2] > 0 else -axis
    else:
        away = thin["centre"] - np.asarray(camera_origin, float)
        axis = axis if axis @ away > 0 else -axis
    d = v @ axis
    pivot = d.min()  # the base, or the face toward the camera
    factor = thin["need_m"] / max(thin["thickness_m"], 1e-6)
    return v + np.outer((factor - 1.0) * (d - pivot), axis)
