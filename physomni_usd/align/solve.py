"""The joint place solve: every placed object's pose refined together against the photo.

After each object has a mesh and a first pose (``align.photo_scene.place_on_ground`` or
``align.external.place_external``), :func:`solve_places` moves all of them at once, each horizontally (it stays on
the ground or on what holds it) and, where it holds nothing up, by a scale about its base, minimising with
``scipy.optimize.least_squares``:

- reprojection: the distance in pixels between the outline of its projected mesh and its (completed) mask's,
  both by their convex hulls, sampled at ``OUTLINE_SAMPLES`` points each way;
- overlap: for two objects at the same heights, neither holding the other, the depth (pixels at their
  distance) by which their ground footprints (convex hulls) overlap;
- occlusion: the object the photo shows in front is no farther from the camera than the one it hides;
- sizes: objects with the same label keep the same longest dimension;
- a small pull towards the first pose, so directions the photo does not constrain stay put.

An object resting on another moves with it. The result is taken only where it lowers the objective, brings
some object at least ``MIN_PX_GAIN`` nearer its outline or makes the deepest overlap of two meshes shallower,
and breaks nothing that held: no two meshes deeper in
each other than before (signed distances), every object resting on another still over its top (its centre,
and no less of its foot), every visible mask as covered by its mesh as it was (frame 0 shows the plate where
it is not), and no fewer of the pixels where the photo shows one object hiding another with its mesh in
front (ray by ray). Otherwise the first
poses stay. What the solve did (per object: reprojection before and after in pixels, move in mm, scale)
goes into ``report.json``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from ..texture.hidden import occlusion_kept
from .place import footprint, separation
from .support import TOP_BAND

#: Points sampled along each outline (the mask's and the projected mesh's).
OUTLINE_SAMPLES = 32
#: Weights of the overlap, occlusion and size terms against one pixel of reprojection.
OVERLAP_WEIGHT = 10.0
OCCLUSION_WEIGHT = 10.0
SIZE_WEIGHT = 20.0  # per unit of log-size difference
#: Pixels of residual for a move of one object's own size, keeping unconstrained directions still.
STAY_WEIGHT = 0.5
#: An object's scale stays within this factor of its first one.
MAX_SCALE = 1.25
#: The solve is taken only when it lowers the objective by at least this fraction.
MIN_GAIN = 0.02
#: ... and brings some object at least this many pixels nearer its outline: both outlines are pixel-rounded, so
#: a lesser gain is rounding, and every move shifts the object's texture off the photo's pixels in frame 0.
MIN_PX_GAIN = 1.0
#: ... and leaves no more of an object's visible mask uncovered than this share more than before: frame 0 is the
#: photo only where the meshes cover the masks (the plate, behind them, has the objects painted out).
COVER_SLACK = 0.005
#: Meshes may end at most this much deeper in each other than they started (metres).
OVERLAP_SLACK_M = 0.0005
#: The share of the pixels where one object hides another that the solve may lose (rays, ``occlusion_kept``).
OCCLUSION_SLACK = 0.02
#: Evaluations of the objective the optimiser may spend, per parameter.
EVALS_PER_PARAMETER = 40


@dataclass
class Solved:
    vertices: list[np.ndarray]  # (n_i, 3) world metres, the solve's where taken, else the first poses
    info: dict  # for report.json


def _resample(poly: np.ndarray, k: int) -> np.ndarray:
    """(k, 2) points evenly spaced along the closed polygon ``poly`` (m, 2)."""
    closed = np.vstack([poly, poly[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    at = np.r_[0.0, np.cumsum(seg)]
    if at[-1] <= 0:
        return np.repeat(poly[:1], k, 0)
    s = np.linspace(0.0, at[-1], k, endpoint=False)
    return np.stack([np.interp(s, at, closed[:, 0]), np.interp(s, at, closed[:, 1])], 1)


def _hull_px(uv: np.ndarray) -> np.ndarray:
    return cv2.convexHull(uv.astype(np.float32))[:, 0, :].astype(float)


class _Outline:
    """A mask's convex outline: samples along it and its signed distance (pixels, > 0 outside)."""

    def __init__(self, mask: np.ndarray):
        ys, xs = np.nonzero(mask)
        pts = np.stack([xs, ys], 1).astype(float) + 0.5
        self.hull = _hull_px(pts)
        self.samples = _resample(self.hull, OUTLINE_SAMPLES)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (pixels, > 0 outside the outline) of ``points`` (n, 2)."""
        return _signed_distance(self.hull, points)


def _signed_distance(hull: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance (pixels) of ``points`` (n, 2) to the convex polygon ``hull`` (m, 2)'s edges, > 0 outside."""
    a = hull
    b = np.roll(hull, -1, axis=0)
    ab = b - a
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
    nearest = a[None] + t[..., None] * ab[None]
    d = np.linalg.norm(points[:, None, :] - nearest, axis=-1).min(1)
    # inside a convex polygon a point lies on the same side of every edge
    cross = ab[None, :, 0] * (points[:, None, 1] - a[None, :, 1]) - ab[None, :, 1] * (points[:, None, 0] - a[None, :, 0])
    inside = np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)
    return np.where(inside, -d, d)


def _chain(i: int, supports: dict) -> list[int]:
    """``i`` and every object under it (what holds it, what holds that, ...)."""
    out, seen = [i], {i}
    while i in supports and supports[i][0] not in seen:
        i = supports[i][0]
        out.append(i)
        seen.add(i)
    return out


def solve_places(camera, vertices, faces, masks, supports=None, labels=None, occlusion=(), visible=None) -> Solved:
    """All objects' poses refined together (see the module); ``vertices`` (n_i, 3) world metres, ``masks`` (H, W)
    bool outlines to reproject onto (completed behind occluders), ``supports`` {upper: (lower, how)},
    ``occlusion`` (front, behind) index pairs, ``visible`` what the photo shows of each (default ``masks``)."""
    import trimesh

    from ..metrics.geometry import max_penetration
    from .photo_scene import balances_on
    from .support import rests_on

    supports = dict(supports or {})
    n = len(vertices)
    verts0 = [np.asarray(v, float) for v in vertices]
    labels = list(labels or [str(i) for i in range(n)])
    outlines = [_Outline(m) if np.asarray(m).any() else None for m in masks]
    holds = {j for j, _ in supports.values()}
    scalable = [i not in holds for i in range(n)]
    base = [np.r_[0.5 * (v[:, :2].min(0) + v[:, :2].max(0)), v[:, 2].min()] for v in verts0]
    size = [max(float(np.ptp(v, axis=0).max()), 1e-6) for v in verts0]
    px_per_m = [camera.focal_px / max(float(np.linalg.norm(b - camera.origin)), 1e-6) for b in base]
    chains = [_chain(i, supports) for i in range(n)]
    heights = [(float(v[:, 2].min()), float(v[:, 2].max())) for v in verts0]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)
             if i not in chains[j] and j not in chains[i]
             and min(heights[i][1], heights[j][1]) - max(heights[i][0], heights[j][0]) > 1e-3]
    same = [(i, j) for i in range(n) for j in range(i + 1, n) if labels[i] == labels[j]]
    # a cup hides its saucer's back, yet the saucer's front is nearer: the order of nearest points holds only
    # between objects neither of which rests on the other (the acceptance checks the rest ray by ray)
    apart = [(f, b) for f, b in occlusion if f not in chains[b] and b not in chains[f]]
    visible = list(masks) if visible is None else list(visible)
    forward = camera.world_from_camera[:, 2].copy()
    forward[2] = 0.0
    forward /= max(np.linalg.norm(forward), 1e-12)

    # a horizontal move and a scale about the base map an object's convex hull and footprint onto the moved
    # object's: both are found once, and the objective transforms only them
    hull_pts = [_hull_points(v) for v in verts0]
    prints = [np.c_[footprint(v), np.zeros(len(footprint(v)))] for v in verts0]

    def moved(x: np.ndarray, points: list[np.ndarray], flat: bool = False) -> list[np.ndarray]:
        p = x.reshape(n, 3)
        out = []
        for i in range(n):
            s = np.exp(p[i, 2]) if scalable[i] else 1.0
            move = np.zeros(3)
            for k in chains[i]:
                move[:2] += p[k, :2]
            centre = base[i] * np.array([1.0, 1.0, 0.0 if flat else 1.0])
            out.append(centre + s * (points[i] - centre) + move)
        return out

    def posed(x: np.ndarray) -> list[np.ndarray]:
        return moved(x, verts0)

    def reprojection(v: np.ndarray, o: _Outline) -> np.ndarray:
        uv, depth = camera.project(v)
        if (depth <= 0).any():
            return np.full(2 * OUTLINE_SAMPLES, 1e3)
        hull = _hull_px(uv)
        mesh_side = _resample(hull, OUTLINE_SAMPLES)
        mask_side = _signed_distance(hull, o.samples)
        return np.r_[o.distance(mesh_side), mask_side] / np.sqrt(2.0)

    def residuals(x: np.ndarray) -> np.ndarray:
        v = moved(x, hull_pts)
        fps = [f[:, :2] for f in moved(x, prints, flat=True)]
        p = x.reshape(n, 3)
        r = []
        for i in range(n):
            if outlines[i] is not None:
                r.append(reprojection(v[i], outlines[i]))
            r.append(STAY_WEIGHT * np.r_[p[i, :2] / size[i], p[i, 2]] * np.sqrt(OUTLINE_SAMPLES))
        for i, j in pairs:
            far = np.any(fps[i].min(0) > fps[j].max(0)) or np.any(fps[j].min(0) > fps[i].max(0))
            mtv = None if far else separation(fps[i], fps[j])
            depth = 0.0 if mtv is None else float(np.linalg.norm(mtv))
            r.append([OVERLAP_WEIGHT * depth * 0.5 * (px_per_m[i] + px_per_m[j])])
        for front, behind in apart:
            near = lambda k: float(((v[k] - camera.origin) @ forward).min())  # noqa: E731
            r.append([OCCLUSION_WEIGHT * max(0.0, near(front) - near(behind)) * px_per_m[front]])
        for i, j in same:
            r.append([SIZE_WEIGHT * (np.log(np.ptp(v[i], axis=0).max()) - np.log(np.ptp(v[j], axis=0).max()))])
        return np.concatenate([np.ravel(a) for a in r]) if r else np.zeros(1)

    def per_object_px(v) -> list[float | None]:
        return [None if o is None else float(np.sqrt(np.mean(reprojection(vi, o) ** 2 * 2.0)))
                for vi, o in zip(v, outlines)]

    x0 = np.zeros(3 * n)
    lo = np.tile([-np.inf, -np.inf, -np.log(MAX_SCALE)], n)
    hi = np.tile([np.inf, np.inf, np.log(MAX_SCALE)], n)
    for i in range(n):
        if not scalable[i]:
            lo[3 * i + 2], hi[3 * i + 2] = -1e-9, 1e-9
    r0 = residuals(x0)
    cost0 = float(r0 @ r0)
    diff = np.tile([1e-3, 1e-3, 1e-3], n) * np.repeat(np.array(size) / max(size), 3) + 1e-6
    fit = least_squares(residuals, x0, bounds=(lo, hi), x_scale=np.repeat(size, 3) * np.tile([1, 1, 0.0], n)
                        + np.tile([0, 0, 0.1], n), diff_step=diff, max_nfev=EVALS_PER_PARAMETER * 3 * n,
                        method="trf", ftol=1e-3, xtol=1e-4)
    x = fit.x
    cost = float(fit.fun @ fit.fun)
    before_v, after_v = verts0, posed(x)
    info = {"objective_before": round(cost0, 3), "objective_after": round(cost, 3), "evaluations": int(fit.nfev)}
    reason = None
    px0, px1 = per_object_px(before_v), per_object_px(after_v)
    gains = [a - b for a, b in zip(px0, px1) if a is not None and b is not None]
    meshes0 = [trimesh.Trimesh(v, f, process=False) for v, f in zip(before_v, faces)]
    meshes1 = [trimesh.Trimesh(v, f, process=False) for v, f in zip(after_v, faces)]
    all_pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    deep0 = [max_penetration({"a": meshes0[i], "b": meshes0[j]}) for i, j in all_pairs]
    deep1 = [max_penetration({"a": meshes1[i], "b": meshes1[j]}) for i, j in all_pairs]
    if cost > (1.0 - MIN_GAIN) * cost0:
        reason = "no lower objective"
    elif max(gains, default=0.0) < MIN_PX_GAIN and max(deep1, default=0.0) >= max(deep0, default=0.0) - OVERLAP_SLACK_M:
        reason = f"no object comes {MIN_PX_GAIN:g} px nearer its outline, and no overlap gets shallower"
    if reason is None:
        for i in range(n):
            covered = [_covered(camera, v[i], visible[i]) for v in (before_v, after_v)]
            if covered[1] < covered[0] - COVER_SLACK:
                reason = (f"object {i} would leave {100 * (1 - covered[1]):.1f} % of its mask uncovered "
                          f"(from {100 * (1 - covered[0]):.1f} %), where frame 0 would show the plate")
                break
    if reason is None:
        for (i, j), was, now in zip(all_pairs, deep0, deep1):
            if now > max(was, 0.0) + OVERLAP_SLACK_M:
                reason = f"objects {i} and {j} would overlap {1000 * now:.1f} mm"
                break
    if reason is None:
        for i, (j, _) in supports.items():
            inside = [_base_inside(v[i], v[j]) for v in (before_v, after_v)]
            # over all it may rest on together (a fruit in a pile's hollow: photo_scene.lift_all)
            beside = [_Lifted(after_v[k]) for k in range(n) if k not in (i, j) and not rests_on(k, i, supports)]
            if not balances_on(_Lifted(after_v[i]), _Lifted(after_v[j]), float(after_v[i][:, 2].min()), beside) \
                    or inside[1] < inside[0] - 0.01:
                reason = f"object {i} would leave the top of object {j}"
                break
    if reason is None:
        for front, behind in occlusion:
            ys, xs = np.nonzero(np.asarray(visible[front], bool) & np.asarray(masks[behind], bool))
            pixels = np.stack([xs, ys], 1)
            kept = [occlusion_kept(camera, m[front], m[behind], pixels) for m in (meshes0, meshes1)]
            if kept[0] is not None and (kept[1] is None or kept[1] < kept[0] - OCCLUSION_SLACK):
                reason = f"object {front} would no longer hide object {behind} where the photo shows it does"
                break
    taken = reason is None
    p = x.reshape(n, 3)
    info["taken"] = taken
    if reason:
        info["kept_first_poses"] = reason
    info["objects"] = [{"reprojection_px_before": None if a is None else round(a, 2),
                        "reprojection_px_after": None if b is None else round(b if taken else a, 2),
                        "moved_mm": round(1000 * float(np.linalg.norm(
                            (after_v[i] - before_v[i]).mean(0))) if taken else 0.0, 1),
                        "scale": round(float(np.exp(p[i, 2])) if taken and scalable[i] else 1.0, 4)}
                       for i, (a, b) in enumerate(zip(px0, px1))]
    return Solved([v.copy() for v in (after_v if taken else before_v)], info)


def _base_inside(upper: np.ndarray, lower: np.ndarray) -> float:
    """Share of ``upper``'s base vertices (within 2 % of its height of its lowest) that stand, seen from above,
    inside the hull of the part of ``lower`` that reaches up to them (``support.TOP_BAND``): a cup whose
    centre stays on its saucer but whose foot hangs over the rim rocks off it."""
    zu, zl = upper[:, 2], lower[:, 2]
    base = upper[zu <= zu.min() + 0.02 * max(float(np.ptp(zu)), 1e-9), :2]
    top = lower[zl >= zu.min() - TOP_BAND * max(float(np.ptp(zl)), 1e-9)]
    if len(top) < 3 or not len(base):
        return 0.0
    hull = footprint(top).astype(np.float32).reshape(-1, 1, 2)
    return float(np.mean([cv2.pointPolygonTest(hull, (float(x), float(y)), False) >= 0 for x, y in base]))


def _hull_points(vertices: np.ndarray) -> np.ndarray:
    """The vertices of the convex hull of ``vertices`` (n, 3): all that a projected outline is drawn from."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return vertices[ConvexHull(vertices).vertices]
    except (QhullError, ValueError):
        return vertices


def _covered(camera, vertices: np.ndarray, mask: np.ndarray) -> float:
    """Share of ``mask``'s pixels (H, W bool) inside the convex hull of ``vertices`` projected by ``camera``."""
    mask = np.asarray(mask, bool)
    if not mask.any():
        return 1.0
    uv, depth = camera.project(vertices)
    if (depth <= 0).any():
        return 0.0
    hull = np.round(_hull_px(uv) * 16).astype(np.int32)
    drawn = cv2.fillConvexPoly(np.zeros(mask.shape, np.uint8), hull, 1, shift=4) > 0
    return float((drawn & mask).sum() / mask.sum())


@dataclass
class _Lifted:
    vertices: np.ndarray
