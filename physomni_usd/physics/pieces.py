"""Rigid bodies that are hollow (an open bowl, a pot): collided as convex pieces, not as their hull.

Newton collides a rigid mesh as its convex hull, which closes a bowl's
top: what lay in it would rest on a lid that is not there and roll off.
The stage marks such a collider with UsdPhysics' own token,
``physics:approximation = convexDecomposition``; Newton's importer hands that
to CoACD, which this project does not depend on, so these bodies are left
out of the import and added here. A vessel the built-in lifter makes
(``lift/vessel.py``: a floor and a straight wall turned about a vertical
axis) splits exactly into convex parts: the floor below the lowest point
of its inside, and the wall above it cut into ``WEDGES`` wedges about the
axis (each wedge's hull bridges its inner arc by under 1 % of the radius).
Each piece's hull is one shape of the same body, with the material's
density, friction and restitution.
"""

from __future__ import annotations

import numpy as np
from pxr import UsdPhysics

from ..rotations import to_wxyz

#: Wedges the wall is cut into about the vertical axis.
WEDGES = 24


def is_decomposed(prim) -> bool:
    """Whether the stage asks for ``prim``'s collider to be cut into convex pieces."""
    attr = prim.GetAttribute("physics:approximation")
    return bool(attr) and attr.Get() == UsdPhysics.Tokens.convexDecomposition


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


def add_decomposed(builder, objects, newton, wp) -> dict:
    """A rigid body of convex pieces (:func:`convex_pieces`) for each of ``objects`` (``SimObject``); returns
    {prim path: body}."""
    import trimesh

    out = {}
    for o in objects:
        m = o.matrix
        scale = np.linalg.norm(m[:3, :3], axis=1)
        q = to_wxyz((m[:3, :3] / scale[:, None]).T)
        cfg = newton.ModelBuilder.ShapeConfig()
        cfg.density = float(o.params.get("density") or 1000.0)
        cfg.mu = float(o.params.get("dynamic_friction", 0.5))
        if o.params.get("restitution") is not None:
            cfg.restitution = float(o.params["restitution"])
        body = builder.add_body(xform=wp.transform(tuple(m[3, :3]), wp.quat(q[1], q[2], q[3], q[0])), label=o.path)
        for piece in convex_pieces(o.points, o.faces):
            hull = trimesh.convex.convex_hull(o.to_local(piece) * scale)
            builder.add_shape_convex_hull(body, mesh=newton.Mesh(hull.vertices.astype(np.float32),
                                                                 hull.faces.ravel().astype(np.int32)), cfg=cfg)
        out[o.path] = body
    return out
