"""How deep two closed meshes are in each other, as the solver will collide them.

Shared by the last pass of placement (``align/separate.py``), which must leave a scene that ``simulate``
accepts, and by the scene check itself (``physics/diagnose.py``), so that both measure an overlap alike. A
hollow body (an open bowl, a pot) collides as convex pieces, not as its hull: ``convex_pieces`` cuts the
vessel the built-in lifter makes (``lift/vessel.py``: a floor and a straight wall turned about a vertical
axis) exactly into convex parts, the floor below the lowest point of its inside and the wall above it cut
into ``WEDGES`` wedges about the axis (each wedge's hull bridges its inner arc by under 1 % of the radius).
"""

from __future__ import annotations

import numpy as np

#: Wedges the wall is cut into about the vertical axis.
WEDGES = 24



def convex_pieces(points: np.ndarray, faces: np.ndarray, wedges: int = WEDGES) -> list[np.ndarray]:
    """Vertex sets (k, 3) whose convex hulls together make the closed mesh ``points`` (N, 3) m / ``faces``
    (M, 3), open at the top about a vertical axis (see the module); ``[points]`` for a mesh whose inside does
    not show from above (it is its own hull)."""
    import trimesh
    from trimesh.intersections import slice_faces_plane

    def keep(part, normal):  # (vertices, faces) of ``part`` on the side of the plane ``normal`` points to
        return slice_faces_plane(part[0], part[1], np.asarray(normal, float), origin)[:2]

    mesh = trimesh.Trimesh(points, faces, process=False)
    lo, hi = mesh.bounds
    axis = 0.5 * (lo[:2] + hi[:2])
    height = float(hi[2] - lo[2])
    down, _, _ = mesh.ray.intersects_location(np.array([[axis[0], axis[1], hi[2] + height]]),
                                              np.array([[0.0, 0.0, -1.0]]))
    if not len(down) or float(down[:, 2].max()) >= hi[2] - 0.05 * height:
        return [np.asarray(points, float)]
    floor = float(down[:, 2].max()) + 1e-5 * height
    origin = np.array([axis[0], axis[1], floor])
    whole = (np.asarray(points, float), np.asarray(faces, np.int64))
    pieces = [keep(whole, [0.0, 0.0, -1.0])]
    wall = keep(whole, [0.0, 0.0, 1.0])
    angles = np.linspace(0.0, 2 * np.pi, wedges + 1)
    for a0, a1 in zip(angles[:-1], angles[1:]):
        part = keep(wall, [-np.sin(a0), np.cos(a0), 0.0])
        if len(part[1]):
            pieces.append(keep(part, [np.sin(a1), -np.cos(a1), 0.0]))
    # a face's vertices that the cuts left unreferenced belong to no piece
    return [v[np.unique(f)] for v, f in pieces if len(f) and len(np.unique(f)) >= 4]


def overlap_depth(a, b, hollow=(False, False)) -> float:
    """Deepest vertex of ``a`` inside ``b`` or of ``b`` inside ``a`` (metres; 0 when apart); ``hollow``: whether
    each collides as convex pieces (``pieces.py``) rather than its hull."""
    import trimesh

    if not (np.all(a.bounds[0] <= b.bounds[1]) and np.all(b.bounds[0] <= a.bounds[1])):
        return 0.0
    worst = 0.0
    for x, y, cut in ((a, b, hollow[1]), (b, a, hollow[0])):
        # signed distance is only meaningful against closed meshes; convex hulls are what the solver collides
        hulls = ([trimesh.convex.convex_hull(p) for p in convex_pieces(y.vertices, y.faces)] if cut
                 else [y.convex_hull])
        inside = np.max([trimesh.proximity.signed_distance(h, x.vertices) for h in hulls], axis=0)
        worst = max(worst, float(inside.max()))
    return worst
