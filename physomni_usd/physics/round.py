"""A ball collides as a sphere: the one collision shape of a rigid object lifted as a ball (``sphere``).

A ball is lifted as a tessellated sphere, and its convex hull is what Newton collides. Resting on its
hull it stands on a vertex or a small facet, and the solver does not keep it there: 235726/005's apple on a
flat 1.2 cm foot, alone on the ground, rocked by 0.3° within 0.1 s, the rocking grew, and by 2 s it had
turned 8° and wandered 5 mm with nothing pushing it. A sphere about its centre of mass touches what holds it
at one point straight below that centre, as a real ball does, and stays (the same apple: not a tenth of a
millimetre in 2 s). The sphere is the largest about the centre of mass inside the hull, so it reaches
nowhere the visible mesh does not and starts inside nothing the mesh does not; where the mesh is taller
than wide it rests that much lower (the settle keeps that drop: ``physics.settle``). Its mass and inertia
stay the visible mesh's."""

from __future__ import annotations

import numpy as np

#: The lifted shape (``physomni:liftedShape``) that collides as a sphere.
BALL = "sphere"


def inscribed_radius(local: np.ndarray, centre: np.ndarray) -> float:
    """The radius (m) of the largest sphere about ``centre`` (3,) inside the convex hull of ``local`` (N, 3);
    ≤ 0 where the centre lies outside it."""
    import trimesh

    hull = trimesh.convex.convex_hull(local)
    normals = np.asarray(hull.face_normals, float)
    origins = np.asarray(hull.triangles[:, 0], float)
    return float(np.min(np.einsum("ij,ij->i", origins - centre, normals)))


def sphere_balls(builder, objects, path_body: dict, newton, wp) -> list[str]:
    """Make the one collision shape of each rigid object of ``objects`` lifted as a ball a sphere about its
    body's centre of mass (``builder`` before ``finalize``); returns the names of those changed."""
    out = []
    for o in objects:
        b = path_body.get(o.path)
        if b is None or o.family != "rigid" or o.prim.GetCustomDataByKey("physomni:liftedShape") != BALL:
            continue
        shapes = builder.body_shapes.get(b) or []
        if len(shapes) != 1 or builder.shape_type[shapes[0]] != newton.GeoType.CONVEX_MESH:
            continue  # a second shape (a hidden support) means the lift's ball is not what holds it
        s = shapes[0]
        pose = builder.body_q[b]
        t = np.array([pose[0], pose[1], pose[2]], float)
        rot = np.array(wp.quat_to_matrix(wp.quat(pose[3], pose[4], pose[5], pose[6])), float).reshape(3, 3)
        local = (o.points - t) @ rot  # world → the body's frame
        com = np.array(builder.body_com[b], float)
        radius = inscribed_radius(local, com)
        if radius <= 0.0:
            continue
        builder.shape_type[s] = newton.GeoType.SPHERE
        builder.shape_source[s] = None
        builder.shape_scale[s] = (radius, 0.0, 0.0)
        builder.shape_transform[s] = wp.transform(wp.vec3(*map(float, com)), wp.quat_identity())
        builder.shape_collision_radius[s] = radius
        out.append(o.name)
    return out
