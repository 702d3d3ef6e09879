"""Support a photo hides: a rigid object standing on the ground whose visible geometry cannot stand.

An object is lifted from the part of it the photo shows. Where the rest is hidden (a bench's far legs
behind a motorcycle) or its feet are seen at different heights (the near wheel of an angled motorcycle
lower in the frame than the far one), the lifted mesh touches the ground at one end only, its centre of
mass overhangs that contact, and it tips over by itself although the photo shows it at rest. Such an
object gets a second collision shape on its body: the convex hull of its points and their footprint on
the ground, without mass, so that it stands on its whole footprint; what it looks like, its mass and its
inertia stay those of the visible mesh."""

from __future__ import annotations

import numpy as np

#: An object whose lowest point is within this of the ground (m, or this fraction of its size if larger)
#: stands on it.
ON_GROUND = 0.01
#: Points within this of the lowest (m, or this fraction of its height if larger) are its contact.
CONTACT_BAND = 0.01
#: The centre of mass may be this far (m) outside the contact and still count as over it (a ball's
#: single contact point, a lying cylinder's contact line).
OVERHANG = 0.005


def overhang(points: np.ndarray, com: np.ndarray) -> float:
    """How far (m) the centre of mass ``com`` (3,) lies, seen from above, outside the convex hull of the
    lowest of ``points`` (N, 3, world, z up); ≤ 0 inside."""
    from scipy.spatial import ConvexHull, QhullError

    low = points[:, 2].min()
    band = max(CONTACT_BAND, CONTACT_BAND * float(np.ptp(points[:, 2])))
    feet = np.unique(np.round(points[points[:, 2] <= low + band, :2], 6), axis=0)
    c = np.asarray(com, float)[:2]
    if len(feet) >= 3:
        try:
            eq = ConvexHull(feet).equations  # unit outward normals: a·x + b·y + d is the signed distance
            return float((eq[:, :2] @ c + eq[:, 2]).max())
        except QhullError:
            pass  # collinear: a line of contact
    a, b = feet[np.argmin(feet @ (feet[-1] - feet[0]))], feet[np.argmax(feet @ (feet[-1] - feet[0]))]
    ab = b - a
    s = np.clip((c - a) @ ab / max(ab @ ab, 1e-18), 0.0, 1.0)
    return float(np.linalg.norm(c - (a + s * ab)))


def needs_support(points: np.ndarray, faces: np.ndarray, ground_z: float) -> bool:
    """Whether an object (world ``points`` (N, 3), triangle ``faces`` (M, 3)) stands on the ground at
    ``ground_z`` with its centre of mass beyond its contact."""
    import trimesh

    size = float(np.ptp(points, axis=0).max())
    if abs(points[:, 2].min() - ground_z) > max(ON_GROUND, ON_GROUND * size):
        return False
    mesh = trimesh.Trimesh(points, faces, process=False)
    solid = mesh if mesh.is_watertight and mesh.volume > 0 else mesh.convex_hull
    return overhang(points, solid.center_mass) > OVERHANG


def add_hidden_support(builder, objects, path_body: dict, ground_z: float, newton, wp) -> list[str]:
    """For each rigid object in ``objects`` that :func:`needs_support`, add a massless collision hull down
    to the ground to its body in ``builder`` (before ``finalize``), with the friction and restitution
    of its first shape. Returns the names of the objects supported."""
    import trimesh

    out = []
    for o in objects:
        b = path_body.get(o.path)
        if b is None or o.family != "rigid" or not needs_support(o.points, o.faces, ground_z):
            continue
        foot = o.points.copy()
        foot[:, 2] = ground_z
        hull = trimesh.convex.convex_hull(np.vstack([o.points, foot]))
        pose = builder.body_q[b]
        t = np.array([pose[0], pose[1], pose[2]], float)
        rot = np.array(wp.quat_to_matrix(wp.quat(pose[3], pose[4], pose[5], pose[6])), float).reshape(3, 3)
        local = (hull.vertices - t) @ rot  # world → the body's frame
        cfg = newton.ModelBuilder.ShapeConfig()
        cfg.density = 0.0  # collision only: the visible mesh keeps the mass and the inertia
        shapes = builder.body_shapes.get(b) or []
        if shapes:
            cfg.mu = float(builder.shape_material_mu[shapes[0]])
            cfg.restitution = float(builder.shape_material_restitution[shapes[0]])
        builder.add_shape_convex_hull(b, mesh=newton.Mesh(local.astype(np.float32),
                                                          hull.faces.ravel().astype(np.int32)),
                                      cfg=cfg, label=f"{o.path}/hidden_support")
        out.append(o.name)
    return out
