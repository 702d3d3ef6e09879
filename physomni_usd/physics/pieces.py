"""Rigid bodies that are hollow (an open bowl, a pot): collided as convex pieces, not as their hull.

Newton collides a rigid mesh as its convex hull, which closes a bowl's
top: what lay in it would rest on a lid that is not there and roll off.
The stage marks such a collider with UsdPhysics' own token,
``physics:approximation = convexDecomposition``; Newton's importer hands that
to CoACD, which this project does not depend on, so these bodies are left
out of the import and added here. A vessel the built-in lifter makes
(``lift/vessel.py``: a floor and a straight wall turned about a vertical
axis) splits exactly into convex parts: the floor below the lowest point
of its inside, and the wall above it cut into wedges about the vertical
axis (``geometry/overlap.py`` cuts them, as the scene check measures them too).
Each piece's hull is one shape of the same body, with the material's
density, friction and restitution.
"""

from __future__ import annotations

import numpy as np
from pxr import UsdPhysics

from ..geometry.overlap import convex_pieces
from ..rotations import to_wxyz

def is_decomposed(prim) -> bool:
    """Whether the stage asks for ``prim``'s collider to be cut into convex pieces."""
    attr = prim.GetAttribute("physics:approximation")
    return bool(attr) and attr.Get() == UsdPhysics.Tokens.convexDecomposition


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
