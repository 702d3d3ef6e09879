"""Geometric checks on a composed stage: where the objects' meshes are, how deep they overlap."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, cKDTree
from pxr import Usd, UsdGeom

from ..usd.author import OBJECTS
from ..usd.layers import transform_may_vary


def world_meshes(stage: Usd.Stage, time: float) -> dict[str, trimesh.Trimesh]:
    """Every Mesh under /World/Objects at ``time``, in world coordinates, keyed by prim name."""
    return WorldMeshes(stage).at(time)


class WorldMeshes:
    """The triangle Meshes under /World/Objects of ``stage``, read at any number of times: topology, and
    points that no time sample moves, read once; a time's world vertices are then one transform each."""

    def __init__(self, stage: Usd.Stage):
        root = stage.GetPrimAtPath(OBJECTS)
        self.meshes = []  # (name, points attribute, (F, 3) faces, (N, 3) still points or None, prim)
        for prim in (root.GetChildren() if root else []):
            if not prim.IsA(UsdGeom.Mesh):
                continue
            mesh = UsdGeom.Mesh(prim)
            counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
            if counts.size == 0 or np.any(counts != 3):
                continue
            faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
            points = mesh.GetPointsAttr()
            still = None if points.ValueMightBeTimeVarying() else np.asarray(points.Get(), float)
            self.meshes.append((prim.GetName(), points, faces, still, prim))

    def still(self) -> bool:
        """Whether no time sample moves any of the meshes: neither its points nor its or an ancestor's
        transform varies, so every time's vertices are the default time's."""
        for _name, _points, _faces, still, prim in self.meshes:
            if still is None or transform_may_vary(prim):
                return False
        return True

    def vertices(self, time: float) -> dict[str, np.ndarray]:
        """Prim name → (N, 3) world vertices (m) at ``time``."""
        cache = UsdGeom.XformCache(Usd.TimeCode(time))
        out = {}
        for name, points, _faces, still, prim in self.meshes:
            pts = still if still is not None else np.asarray(points.Get(Usd.TimeCode(time)), float)
            m = np.array(cache.GetLocalToWorldTransform(prim))
            out[name] = pts @ m[:3, :3] + m[3, :3]
        return out

    def faces(self, name: str) -> np.ndarray:
        return next(f for n, _p, f, _s, _prim in self.meshes if n == name)

    def at(self, time: float) -> dict[str, trimesh.Trimesh]:
        """Prim name → world mesh at ``time``."""
        return self.of(self.vertices(time))

    def of(self, vertices: dict[str, np.ndarray], names=None) -> dict[str, trimesh.Trimesh]:
        """The meshes of :meth:`vertices`' output (``names``: those only)."""
        return {n: trimesh.Trimesh(v, self.faces(n), process=False) for n, v in vertices.items()
                if names is None or n in names}


class Penetrations:
    """:func:`max_penetration` of a :class:`WorldMeshes` at any number of times, the same depths for a small
    part of the cost: a frame of a pile of boxes was hundreds of signed distances, each building a mesh and its
    hull anew.

    Whether a point is inside a mesh's convex hull, and how deep, is a half-space test against the hull's
    planes. The hull is taken once per mesh whose points no time sample moves, as indices into its points:
    an affine transform maps the hull of points to the hull of the transformed points, so the same triangles
    give every frame's planes. Inside a convex mesh (its own hull) the depth of a point is its distance to the
    nearest plane, which is what the signed distance returns (to rounding; trimesh's search for the nearest
    face can settle on a farther one, by microns); for any other mesh the exact signed distance runs on the
    points inside its hull alone.
    """

    #: (points × hull planes) entries one block of the half-space test holds (bounds its memory).
    BLOCK = 2_000_000

    def __init__(self, meshes: WorldMeshes):
        self.meshes = meshes
        self._shapes = {}  # name -> (hull simplices (k, 3) into the mesh's points, convex) or None

    def at(self, time: float) -> float:
        """Deepest vertex of any mesh inside another at ``time``, metres (0 when none overlap)."""
        return max(self.pairs(time).values(), default=0.0)

    def pairs(self, time: float) -> dict[tuple[str, str], float]:
        """:func:`overlaps` at ``time``: each overlapping pair's depth, metres, keyed by the sorted names."""
        verts = self.meshes.vertices(time)
        names = sorted(verts)
        if len(names) < 2:
            return {}
        lo = np.array([verts[n].min(axis=0) for n in names])  # (n, 3) m
        hi = np.array([verts[n].max(axis=0) for n in names])
        touch = (lo[:, None] <= hi[None]).all(axis=2) & (lo[None] <= hi[:, None]).all(axis=2)
        out = {}
        planes = {}  # a mesh's hull planes at this time, shared by every pair it is in
        for i, j in zip(*np.nonzero(np.triu(touch, 1))):
            depth = max(self._deepest(verts[names[x]], names[y], verts[names[y]], lo[y], hi[y], planes)
                        for x, y in ((i, j), (j, i)))
            if depth > 0:
                out[(names[i], names[j])] = depth
        return out

    def _deepest(self, points: np.ndarray, name: str, verts: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 planes: dict) -> float:
        """Deepest of ``points`` inside mesh ``name`` (world vertices ``verts``, bounds ``lo``..``hi``);
        ``planes`` holds each mesh's hull planes at this time once found (a mesh in a pile meets several)."""
        pts = points[np.all((points >= lo) & (points <= hi), axis=1)]
        if not len(pts):
            return 0.0
        shape = self._shape(name, verts)
        if shape is None:  # no solid hull (a flat or degenerate mesh): the exact computation as it stands
            return _deepest_inside(pts, trimesh.Trimesh(verts, self.meshes.faces(name), process=False))
        convex = shape[1]
        if name not in planes:
            planes[name] = _hull_planes(verts, shape[0])
        normal, offset = planes[name]
        step = max(1, self.BLOCK // len(normal))
        # depth below the nearest plane: > 0 strictly inside the hull
        depth = np.concatenate([(offset - pts[k:k + step] @ normal.T).min(axis=1) for k in range(0, len(pts), step)])
        if convex:
            return max(0.0, float(depth.max()))
        # a hair of slack: a point the half-space test puts on the hull goes on to the exact test
        pts = pts[depth > -1e-9 * max(1.0, float(np.abs(hi - lo).max()))]
        if not len(pts):
            return 0.0
        mesh = trimesh.Trimesh(verts, self.meshes.faces(name), process=False)
        return max(0.0, float(trimesh.proximity.signed_distance(mesh, pts).max()))

    def _shape(self, name: str, verts: np.ndarray):
        if name in self._shapes:
            return self._shapes[name]
        from scipy.spatial import ConvexHull, QhullError

        still = next(s for n, _p, _f, s, _prim in self.meshes.meshes if n == name)
        try:
            simplices = ConvexHull(verts).simplices
        except (QhullError, ValueError):
            simplices = None
        shape = None
        if simplices is not None:
            mesh = trimesh.Trimesh(verts, self.meshes.faces(name), process=False)
            shape = (simplices, bool(mesh.is_watertight and mesh.is_convex))
        if still is not None:  # the same points every frame: the same hull and convexity
            self._shapes[name] = shape
        return shape


def max_penetration(meshes: dict[str, trimesh.Trimesh]) -> float:
    """Deepest vertex of any mesh inside another, metres (0 when none overlap).

    Measured on the meshes themselves with signed distances, not on boxes.
    """
    names = sorted(meshes)
    worst = 0.0
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if not _bounds_overlap(meshes[a], meshes[b]):
                continue
            for x, y in ((a, b), (b, a)):
                worst = max(worst, _deepest_inside(meshes[x].vertices, meshes[y]))
    return worst


def _hull_planes(verts: np.ndarray, simplices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The outward unit normals (k, 3) and offsets (k,) of a hull's triangles ``simplices`` over ``verts``."""
    tri = verts[simplices]  # (k, 3, 3)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1)
    keep = length > 0
    normal, tri = normal[keep] / length[keep, None], tri[keep]
    # outward: away from the vertices' mean, which lies inside a solid hull whatever the winding
    normal[np.einsum("ij,ij->i", normal, verts.mean(axis=0) - tri[:, 0]) > 0] *= -1
    return normal, np.einsum("ij,ij->i", normal, tri[:, 0])


def _deepest_inside(points: np.ndarray, mesh: trimesh.Trimesh) -> float:
    """Deepest of ``points`` (n, 3) inside ``mesh``, metres (0 when none is).

    Only points inside the mesh's bounds and its convex hull (a few faces, so cheap) can be inside it;
    the exact signed distance, which costs points × faces, runs on those alone.
    """
    lo, hi = mesh.bounds
    pts = np.asarray(points)[np.all((points >= lo) & (points <= hi), axis=1)]
    if not len(pts):
        return 0.0
    hull = mesh.convex_hull
    pts = pts[trimesh.proximity.signed_distance(hull, pts) > 0]
    if not len(pts):
        return 0.0
    return max(0.0, float(trimesh.proximity.signed_distance(mesh, pts).max()))  # > 0 inside


def _bounds_overlap(a: trimesh.Trimesh, b: trimesh.Trimesh) -> bool:
    return bool(np.all(a.bounds[0] <= b.bounds[1]) and np.all(b.bounds[0] <= a.bounds[1]))


def overlaps(meshes: dict[str, trimesh.Trimesh]) -> dict[tuple[str, str], float]:
    """Deepest overlap of each pair of meshes whose bounds meet, metres, keyed by the (sorted) pair of names.

    The depth is the deepest vertex of either mesh inside the other (signed distances), as
    :func:`max_penetration` takes it; pairs that do not overlap are left out.
    """
    names = sorted(meshes)
    out = {}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if not _bounds_overlap(meshes[a], meshes[b]):
                continue
            depth = max(_deepest_inside(meshes[a].vertices, meshes[b]), _deepest_inside(meshes[b].vertices, meshes[a]))
            if depth > 0:
                out[(a, b)] = depth
    return out


def rest_drift(stage: Usd.Stage, names=None) -> dict[str, float]:
    """Largest displacement of any point of each object over the stage's frames, metres, prim name → metres.

    Compares every authored frame (start to end time code, step 1) with the start frame, in world
    coordinates, so that a rigid body that slides, tips or falls shows how far its farthest point went.
    ``names`` keeps those prims only (e.g. the rigid ones); the default is every Mesh under /World/Objects.
    """
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    first = world_meshes(stage, start)
    keep = [n for n in first if names is None or n in names]
    drift = dict.fromkeys(keep, 0.0)
    for t in np.arange(start + 1, end + 0.5):
        now = world_meshes(stage, float(t))
        for n in keep:
            d = np.linalg.norm(now[n].vertices - first[n].vertices, axis=1).max()
            drift[n] = max(drift[n], float(d))
    return drift


def rest_turn(stage: Usd.Stage, names=None) -> dict[str, float]:
    """Largest rotation of each object over the stage's frames against its start frame, degrees, prim name →
    degrees: what :func:`rest_drift` misses on a small object that tips over (it turns far while its points
    move little). The rotation is the best fit (Kabsch) of the frame's points to the start's, so it reads a
    rigid body's turn exactly and a deforming body's mean turn."""
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    meshes = WorldMeshes(stage)
    first = meshes.vertices(start)
    keep = [n for n in first if names is None or n in names]
    turn = dict.fromkeys(keep, 0.0)
    centred = {n: first[n] - first[n].mean(0) for n in keep}
    for t in np.arange(start + 1, end + 0.5):
        now = meshes.vertices(float(t))
        for n in keep:
            u, _s, vt = np.linalg.svd(centred[n].T @ (now[n] - now[n].mean(0)))
            d = np.sign(np.linalg.det(u @ vt))
            r = u @ np.diag([1.0, 1.0, d]) @ vt
            angle = np.degrees(np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)))
            turn[n] = max(turn[n], float(angle))
    return turn


#: The thinnest a solid may come out, as a fraction of the smaller side of the outline a photo would show of it
#: (issue: no slab where the photo shows a block); a round thing (a ball-shaped label) as deep as this
#: fraction of its width instead.
THIN_FRACTION = 1.0 / 3.0
ROUND_FRACTION = 0.8
#: The share of the least thickness a solid must reach to pass: one deepened to exactly that thickness
#: measures a little under it once judged again.
THIN_SLACK = 0.98
#: A label whose typical resting height is under this fraction of its longest side says the thing is flat
#: (a coin, a card, a book, a plate): it may be as thin as it is.
FLAT_LABEL_RATIO = 1.0 / 3.0
#: A thin side the photo sees (its axis within 60° of the image plane) is what the outline says: not judged.
SEEN_AXIS_COS = 0.5


def label_says(label: str) -> str | None:
    """'flat' for a label whose typical size is flat, 'vessel' for an open container (a bowl, a pot: its rim
    and wall in the photo measure its height), 'round' for a ball-shaped one, else None (``sizes``)."""
    from ..sizes import body_kind, size_prior

    p = size_prior(label or "")
    if p is not None and p.longest_m is not None and p.height_m is not None \
            and p.height_m < FLAT_LABEL_RATIO * p.longest_m:
        return "flat"
    if body_kind(label or "") == "vessel":
        return "vessel"
    return "round" if p is not None and p.longest_m is not None and p.shape == "ball" else None


def thin_side(vertices: np.ndarray, label: str, camera_origin) -> dict | None:
    """How an object (``vertices`` (n, 3), world metres) is too thin, or None when it is not.

    Its thickness is its least width over every direction (:func:`least_width`); the smaller side of its
    outline the least width of what it shows looking along that direction. It is too thin below
    :data:`THIN_FRACTION` of that side (:data:`ROUND_FRACTION` for a ball-shaped label), unless its label says
    flat or an open vessel, or the thin side lies across the line of sight from ``camera_origin`` (3,) so that
    the photo itself shows it thin. Both widths move as little as the vertices do: a smallest-volume box, which
    this was, can snap between two boxes of near equal volume at a rounding of the vertices (a slab read back
    from a shot's 32-bit points judged with its outline's side 4.35 cm where the built one had 3.83 cm).
    Returns ``thickness_m``, ``side_m``, ``need_m`` (the least thickness allowed), ``axis`` (3,) unit and
    ``centre`` (3,) of the box the widths span."""
    says = label_says(label)
    if says in ("flat", "vessel"):  # as thin as it is: a flat thing, or a vessel whose rim measured it
        return None
    v = np.asarray(vertices, float)
    thickness, axis = least_width(v)
    across = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    across /= np.linalg.norm(across)
    frame = np.stack([across, np.cross(axis, across)], axis=1)
    side, turn = least_width(v @ frame)
    if side <= 0:
        return None
    need = (ROUND_FRACTION if says == "round" else THIN_FRACTION) * side
    if thickness >= need * THIN_SLACK:
        return None
    box = np.stack([axis, frame @ turn, frame @ np.array([-turn[1], turn[0]])])
    span = v @ box.T
    centre = 0.5 * (span.min(0) + span.max(0)) @ box
    view = centre - np.asarray(camera_origin, float)
    view /= max(np.linalg.norm(view), 1e-12)
    if abs(float(axis @ view)) < SEEN_AXIS_COS:
        return None
    return {"thickness_m": float(thickness), "side_m": float(side), "need_m": need, "axis": axis, "centre": centre}


def least_width(points: np.ndarray) -> tuple[float, np.ndarray]:
    """(width, unit direction (d,)) of the narrowest slab between two parallel planes (lines in 2-D) holding
    ``points`` (n, d), d = 2 or 3: the least of ``ptp(points @ u)`` over unit ``u``, which moves no more than
    the points do. Exact on their convex hull: the narrowest slab rests on a facet of the hull with the farthest
    vertex on the other plane, or (3-D) on two hull edges whose directions it spans. A flat or collinear set
    has width 0 across it."""
    p = np.asarray(points, float)
    d = p.shape[1]
    try:
        hull = ConvexHull(p)
    except Exception:  # noqa: BLE001 — qhull refuses a (nearly) flat set: its spread across that plane
        centred = p - p.mean(0)
        normal = np.linalg.svd(centred, full_matrices=True)[2][-1]
        return float(np.ptp(p @ normal)), normal
    h = p[hull.vertices]
    normals = hull.equations[:, :d]
    candidates = [normals]
    if d == 3:
        candidates.append(_edge_pair_directions(hull))
    dirs = np.vstack(candidates)  # unit rows: qhull's facet normals, the edge pairs' normalised crosses
    widths = np.concatenate([np.ptp(h @ dirs[k:k + 1024].T, axis=0) for k in range(0, len(dirs), 1024)])
    best = int(np.argmin(widths))
    return float(widths[best]), dirs[best]


#: An edge of a hull whose arc of normals is this wide (radians) or less is blunt (:func:`_edge_pair_directions`).
EDGE_CAP_RAD = np.radians(10.0)


def _edge_pair_directions(hull) -> np.ndarray:
    """(m, 3) unit directions across pairs of edges of a 3-D ``hull`` that can bound one slab from either
    side. An edge holds a supporting plane for the normals on the arc between its two facets' normals; two edges
    are opposite sides of one slab only where the arc of one meets the other's, reversed. Pairs whose arcs'
    bounding caps miss each other are passed over, so the work stays near the number of edges, not its square."""
    normals = hull.equations[:, :3]
    facets = np.arange(len(hull.simplices))
    ab, fg = [], []
    for k in range(3):  # the edge opposite each facet's vertex k, shared with its k-th neighbour
        g = hull.neighbors[:, k]
        once = facets < g
        ab.append(np.stack([hull.simplices[once, (k + 1) % 3], hull.simplices[once, (k + 2) % 3]], axis=1))
        fg.append(np.stack([facets[once], g[once]], axis=1))
    ab, fg = np.vstack(ab), np.vstack(fg)
    n1, n2 = normals[fg[:, 0]], normals[fg[:, 1]]
    cos = np.einsum("ij,ij->i", n1, n2)
    # an edge inside a flat face of the hull bounds a slab only in that face's plane: its facets' normal holds it
    real = cos < 1.0 - 1e-9
    ab, n1, n2, cos = ab[real], n1[real], n2[real], cos[real]
    if len(ab) == 0:
        return np.zeros((0, 3))
    mid = n1 + n2
    mid /= np.maximum(np.linalg.norm(mid, axis=1), 1e-12)[:, None]
    radius = 0.5 * np.arccos(np.clip(cos, -1.0, 1.0))
    # the caps of edge i's arc and edge j's reversed arc meet, angle(mid_i, -mid_j) <= r_i + r_j: looked up
    # by the chord between the caps' centres (a round body's hull has thousands of edges). Most edges of a
    # dense smooth hull are blunt; reaching every one by the widest cap (one square rim edge) would pair each
    # with a quarter of the rest. A blunt edge looks only as far as another blunt one reaches; a sharp edge
    # looks as far as any reaches, so finding the pairs with a sharp edge is its own query's work.
    blunt = radius <= EDGE_CAP_RAD
    reach_of = np.where(blunt, radius + EDGE_CAP_RAD, radius + radius.max())
    reach = 2.0 * np.sin(np.minimum(reach_of, np.pi) / 2.0) + 1e-9
    near = cKDTree(mid).query_ball_point(-mid, reach)
    i = np.repeat(np.arange(len(mid)), [len(n) for n in near])
    j = np.fromiter((k for n in near for k in n), int, len(i))
    pair = np.unique(np.sort(np.stack([i, j], axis=1), axis=1), axis=0)
    i, j = pair[:, 0], pair[:, 1]
    meet = np.arccos(np.clip(-np.einsum("ij,ij->i", mid[i], mid[j]), -1.0, 1.0)) <= radius[i] + radius[j] + 1e-9
    meet &= i != j
    i, j = i[meet], j[meet]
    pts = hull.points
    e = pts[ab[:, 1]] - pts[ab[:, 0]]
    u = np.cross(e[i], e[j])
    norm = np.linalg.norm(u, axis=1)
    keep = norm > 1e-12 * np.linalg.norm(e[i], axis=1) * np.linalg.norm(e[j], axis=1)
    return u[keep] / norm[keep][:, None]
