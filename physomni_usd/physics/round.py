"""A round ball collides as a sphere: the one collision shape of a rigid object lifted as what may be a ball,
and what each such object was given (``Rounded``, for the report).

A ball is lifted as a tessellated sphere, and its convex hull is what Newton collides. Resting on its
hull it stands on a vertex or a small facet, and the solver does not keep it there: 235726/005's apple on a
flat 1.2 cm foot, alone on the ground, rocked by 0.3° within 0.1 s, the rocking grew, and by 2 s it had
turned 8° and wandered 5 mm with nothing pushing it. A smooth surface touches what holds it at one point,
as a real ball does, and stays.

The fit that decides is the upright ellipsoid with the hull's extents (its horizontal axes along the hull's
principal ones). The ball collides as a Newton sphere where its semi-axes agree within
``settings.BALL_SPHERE_SPREAD``, or where it is round across (its level ones within that spread) and its upright
one is the longest by at most ``settings.BALL_TALL_SPREAD`` (a ball lifted from its footprint or seen standing
takes its height from its outline's tangent cone, that uncertain). The sphere's radius is the smallest
semi-axis, the level one (no wider than the hull: one as tall as a ball 3 % taller than wide started inside the
fruit beside it, and both rolled 8 cm), its lowest point the hull's, straight under the centre of mass (it
rests at the height the mesh rests at and starts balanced). It is used only where that sphere is the hull's
shape: the ellipsoid holds at least ``settings.BALL_MIN_FILL`` of the hull's volume and the sphere pokes out of
the hull by at most ``settings.BALL_MAX_PROTRUSION`` of its radius (not a cup, a box, a ball whose centre of
mass is off its middle), and nothing rests on it (a sphere does not resist rolling, and rolls away from under
what stands on it). Everything else keeps its hull. An ellipsoid collider was tried and dropped: a ball taller
than wide balances on its end as the ellipsoid does, unstably (256721/018's three oranges 1.13x taller than wide
rolled 18-77 cm where their hulls moved 1-3 mm), and Newton's ellipsoid contacts, its general convex search's,
rolled 235726/019's round apple out of its bowl, 52 cm in 2 s, where its sphere of the same size moved 1 mm.
A body that collides as a sphere moves as that sphere: its mass stays the mesh's, its centre of mass is the
sphere's centre and its inertia a solid sphere's (a ball a little taller than wide kept its mesh's centre of
mass 1-3 mm over the sphere's centre, balanced on top of its round bottom, and a 2 cm/s push tipped it 4-17 cm
where a round one rolled 4 mm)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..settings import BALL_LOAD_GAP, BALL_MAX_PROTRUSION, BALL_MIN_FILL, BALL_SPHERE_SPREAD, BALL_TALL_SPREAD
from .support import body_frame

#: The lifted shapes (``physomni:liftedShape``) that may be a ball: the footprint's ball (``sphere``), the
#: lofted body of a round outline (``round``: a ball seen from the side, or a cup, which the fit refuses) and an
#: organic one's dome (``inflated``: an orange lifted from its outline).
BALLS = ("sphere", "round", "inflated")
#: Points on the collider at which its poke out of the hull is measured (their spacing on a 3 cm ball: 1.2 mm).
_SAMPLES = 2000


@dataclass
class BallFit:
    """A ball's hull fitted: the upright ellipsoid with the hull's extents, made the sphere it collides as
    where it is round, in the world: its ``centre`` (3,), ``axes`` (3, 3; columns: its two horizontal axes
    and +z) and ``semi`` (3,) semi-axes (m; all equal where it is a sphere), with how the hull fits it:
    ``fill`` (the volume of the ellipsoid filling the hull's box over the hull's: before it is made a
    sphere), ``protrusion`` (how far the collider pokes out of the hull, over its shortest semi-axis)."""

    centre: np.ndarray
    axes: np.ndarray
    semi: np.ndarray
    fill: float
    protrusion: float

    @property
    def sphere(self) -> bool:
        """Whether it is a sphere (its semi-axes equal: Newton collides it as one)."""
        return bool(np.ptp(self.semi) == 0.0)

    @property
    def fits(self) -> bool:
        """Whether the ball collides as this sphere: it is one, and it is the hull's shape."""
        return self.sphere and self.fill >= BALL_MIN_FILL and self.protrusion <= BALL_MAX_PROTRUSION

    def as_dict(self) -> dict:
        return {"semi_axes_m": [round(float(x), 4) for x in self.semi], "fill": round(self.fill, 3),
                "protrusion": round(self.protrusion, 4)}


def _sphere_points(n: int) -> np.ndarray:
    """``n`` nearly even points on the unit sphere (a Fibonacci spiral)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (1.0 + 5 ** 0.5) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def fit_ball(points: np.ndarray, com: np.ndarray | None = None) -> BallFit:
    """The upright ellipsoid for the convex hull of ``points`` (N, 3; world, z up): its horizontal axes the
    principal axes of the hull's footprint and its semi-axes half the hull's extents along them, made a sphere
    of the smallest (no wider and no taller than the hull) where they agree within ``BALL_SPHERE_SPREAD`` or
    where it is round across and at most ``BALL_TALL_SPREAD`` taller (:func:`_round_across_tall`); its lowest
    point the hull's lowest, straight under ``com`` (the body's centre of mass; None: the box's centre), so
    that it starts at rest where the mesh stands."""
    import trimesh

    hull = trimesh.convex.convex_hull(points)
    v = np.asarray(hull.vertices, float)
    xy = v[:, :2] - v[:, :2].mean(axis=0)
    _, vecs = np.linalg.eigh(xy.T @ xy)
    axes = np.eye(3)
    axes[:2, 0], axes[:2, 1] = vecs[:, 1], vecs[:, 0]
    axes[:2, 1] *= 1.0 if np.linalg.det(axes[:2, :2]) > 0 else -1.0  # right-handed: a rotation
    local = v @ axes
    lo, hi = local.min(axis=0), local.max(axis=0)
    semi = 0.5 * (hi - lo)
    fill = float(4.0 / 3.0 * np.pi * np.prod(semi) / max(hull.volume, 1e-18))
    if semi.max() <= (1.0 + BALL_SPHERE_SPREAD) * semi.min() or _round_across_tall(semi):
        semi[:] = semi.min()  # no wider than the hull: a wider one starts inside the fruit beside it
    centre = 0.5 * (lo + hi)
    centre[2] = lo[2] + semi[2]
    if com is not None:
        centre[:2] = (np.asarray(com, float) @ axes)[:2]
    centre = axes @ centre
    surface = centre + (_sphere_points(_SAMPLES) * semi) @ axes.T
    normals = np.asarray(hull.face_normals, float)
    offsets = np.einsum("ij,ij->i", np.asarray(hull.triangles[:, 0], float), normals)
    poke = (surface @ normals.T - offsets).max(axis=1).max()
    return BallFit(centre, axes, semi, fill, float(max(poke, 0.0) / max(semi.min(), 1e-12)))


def _round_across_tall(semi: np.ndarray) -> bool:
    """Whether semi-axes ``semi`` (two level, then upright) are a ball round across whose upright one is the
    longest by at most ``BALL_TALL_SPREAD`` (a footprint's height, from its outline's tangent cone, that
    uncertain): it collides as the sphere of its level radius."""
    across = semi[:2]
    return bool(across.max() <= (1.0 + BALL_SPHERE_SPREAD) * across.min()
                and across.max() <= semi[2] <= (1.0 + BALL_TALL_SPREAD) * across.min())


def _sphere_mass(builder, b: int, centre: np.ndarray, radius: float, wp) -> None:
    """Give body ``b`` (``builder`` before ``finalize``) the mass properties of the sphere it collides as: its
    centre of mass at the sphere's ``centre`` (the body's frame) and a solid sphere's inertia about it, its mass
    kept. A ball a little taller than wide kept its mesh's centre of mass 1-3 mm over the sphere's centre,
    balanced on a round bottom, and a 2 cm/s push rolled it 4-17 cm where a round one rolled 4 mm."""
    builder.body_com[b] = wp.vec3(*map(float, centre))
    mass = float(builder.body_mass[b])
    moment = 0.4 * mass * radius * radius
    builder.body_inertia[b] = wp.mat33(moment, 0.0, 0.0, 0.0, moment, 0.0, 0.0, 0.0, moment)
    inverse = 1.0 / moment if moment > 0.0 else 0.0
    builder.body_inv_inertia[b] = wp.mat33(inverse, 0.0, 0.0, 0.0, inverse, 0.0, 0.0, 0.0, inverse)


def _load(ball: np.ndarray, others) -> str | None:
    """The name of the first of ``others`` (objects with world ``points``) resting on ``ball`` (N, 3; world
    points): its lowest point above the ball's middle, at most ``BALL_LOAD_GAP`` over its top, and within the
    ball's footprint; None where nothing rests on it."""
    lo, hi = ball.min(axis=0), ball.max(axis=0)
    mid = 0.5 * (lo + hi)
    for o in others:
        p = np.asarray(o.points, float)
        if not len(p):
            continue
        bottom = p[:, 2].min()
        if not mid[2] < bottom <= hi[2] + BALL_LOAD_GAP:
            continue
        foot = p[p[:, 2] <= bottom + BALL_LOAD_GAP, :2]
        if (np.all(foot >= lo[:2], axis=1) & np.all(foot <= hi[:2], axis=1)).any():
            return o.name
    return None


@dataclass
class Rounded:
    """What ``round_balls`` did: ``spheres`` (object name → its fit, for those that collide as a sphere) and
    ``hulls`` (name → its fit, for balls whose hull stays because they are not round, the sphere is not
    the hull's shape, or something rests on them: ``holds``, its name)."""

    spheres: dict
    hulls: dict

    def report(self) -> dict:
        """Each ball's collider for ``report.json``: name → ``collides_as`` (``sphere`` or ``hull``) and its fit."""
        return {**{n: {"collides_as": "sphere", **f} for n, f in self.spheres.items()},
                **{n: {"collides_as": "hull", **f} for n, f in self.hulls.items()}}


def round_balls(builder, objects, path_body: dict, newton, wp) -> Rounded:
    """Make the one collision shape of each rigid object of ``objects`` lifted as a ball the sphere of
    :func:`fit_ball` where it fits (``builder`` before ``finalize``), with the sphere's centre of mass and
    inertia (its mass kept)."""
    done = Rounded({}, {})
    for o in objects:
        b = path_body.get(o.path)
        if b is None or o.family != "rigid" or o.prim.GetCustomDataByKey("physomni:liftedShape") not in BALLS:
            continue
        shapes = builder.body_shapes.get(b) or []
        if len(shapes) != 1 or builder.shape_type[shapes[0]] != newton.GeoType.CONVEX_MESH:
            continue  # a second shape (a hidden support) means the lift's ball is not what holds it
        s = shapes[0]
        t, rot = body_frame(builder, b, wp)
        fit = fit_ball(np.asarray(o.points, float), rot @ np.array(builder.body_com[b], float) + t)
        held = _load(np.asarray(o.points, float), [k for k in objects if k is not o])
        if not fit.fits or held is not None:
            done.hulls[o.name] = {**fit.as_dict(), **({"holds": held} if held is not None else {})}
            continue
        centre = rot.T @ (fit.centre - t)  # world → the body's frame
        builder.shape_type[s] = newton.GeoType.SPHERE
        builder.shape_source[s] = None
        builder.shape_scale[s] = (float(fit.semi[0]), 0.0, 0.0)
        builder.shape_transform[s] = wp.transform(wp.vec3(*map(float, centre)), wp.quat_identity())
        builder.shape_collision_radius[s] = float(fit.semi[0])
        _sphere_mass(builder, b, centre, float(fit.semi[0]), wp)
        done.spheres[o.name] = fit.as_dict()
    return done
