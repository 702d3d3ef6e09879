"""Open containers seen from above their rim (bowls, basins, pots, buckets, pans): a hollow surface of revolution.

Seen from above, a vessel's outline is its rim at the top and sides — the
circle it is widest at, at its full height H — and the front of its base
below. Cast onto the horizontal plane at any height, the outline's far half
(the back of the rim) is a circle (planes parallel to each other are
scaled copies of each other through the camera), so the outline alone
gives the rim's centre and radius *for* a height, not the height; the
rim's image is the same at every height. What fixes it is the ground: the
vessel's axis is vertical, and the front of its base (``BASE_RATIO`` of the
rim's radius in front of the axis) stands where the outline's lowest pixel
meets the ground (:func:`rim_from_outline`). Where that pixel is the rim's
front itself (seen so steeply that the rim hides the base), the outline is
not lifted as a vessel.

The vessel is the profile (floor, straight wall from the base out to the
rim, the same wall inside) turned about the vertical through the rim's
centre (:func:`vessel_mesh`): its interior is open, so what lies in it rests
on its inner floor and the camera sees into it. Walls and floor are
``WALL_RATIO`` of the rim's diameter thick (a 24 cm bowl has ~1 cm walls).
Physics collides it as convex pieces, not its hull (``physics.assembly``).

What stands in a vessel's mouth and is wider than it (a plant's foliage over
its pot) rests on its rim (``rim.py``).
"""

from __future__ import annotations

import math

import numpy as np
import trimesh

from .footprint import height_where_it_ends, on_plane

#: Wall and floor thickness, as a fraction of the rim's diameter.
WALL_RATIO = 0.04
#: Sections around the axis.
SECTIONS = 48


def _circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """(centre (2,), radius) of the least-squares circle through ``points`` (n, 2) (Kåsa's fit)."""
    a = np.c_[2 * points, np.ones(len(points))]
    b = (points ** 2).sum(1)
    (cx, cy, c), *_ = np.linalg.lstsq(a, b, rcond=None)
    return np.array([cx, cy]), math.sqrt(max(c + cx * cx + cy * cy, 0.0))


def _frame(camera) -> tuple[np.ndarray, np.ndarray]:
    """The camera's horizontal forward (away) and right (side) unit vectors (2,)."""
    away = np.asarray(camera.world_from_camera[:2, 2], float)
    away = away / max(np.linalg.norm(away), 1e-12)
    return away, np.array([away[1], -away[0]])


#: The base's radius as a fraction of the rim's (a bowl's foot, a pot's bottom): the photo shows the base's front
#: but not its sides, so this ratio stands for them.
BASE_RATIO = 0.75
#: A vessel is between these fractions of its rim's diameter tall. A flowerpot is about as tall as it is wide,
#: and a pitch read a few degrees too steep makes it up to a third taller: at 1.2 such a pot under its plant
#: came out a solid cylinder, with nothing for the plant to stand in.
HEIGHT_RANGE = (0.1, 1.5)


def rim_at(poly_uv, camera, z: float):
    """(centre (2,), radius) of the circle that the outline's far half (``poly_uv`` (n, 2) pixel edges of its
    convex hull) makes on the horizontal plane at height ``z``; None where the outline misses that plane."""
    p = on_plane(camera, poly_uv, z)[:, :2]
    if not np.all(np.isfinite(p)):
        return None
    away, side = _frame(camera)
    far = p[p @ away >= np.median(p @ away)]
    if len(far) < 5:
        return None
    centre, radius = _circle(far)
    return centre, 0.5 * (radius + 0.5 * float(np.ptp(p @ side)))


def rim_from_outline(mask: np.ndarray, poly_uv: np.ndarray, camera, base_z: float = 0.0):
    """(centre (2,) m, rim radius m, base radius m, height m above ``base_z``) of the vessel whose outline is
    ``mask`` (H, W) bool (``poly_uv`` (n, 2) its convex hull's pixel edges), or None where its lowest pixel is
    the rim's front (the base does not show) or no height between ``HEIGHT_RANGE`` of its diameter fits.

    The rim's circle is known up to its height (see the module); the base's front, ``BASE_RATIO`` of the
    rim's radius in front of its axis, stands where the outline's lowest pixel meets the ground, and the
    height where both hold is found by bisection."""
    away, _ = _frame(camera)
    ys, xs = np.nonzero(mask)
    bottom = ys.max()
    u = float(np.median(xs[ys == bottom])) + 0.5
    front = on_plane(camera, np.array([[u, bottom + 1.0]]), base_z)[0, :2]
    if not np.all(np.isfinite(front)):
        return None

    def gap(h):  # > 0: the base's front lies behind the foot's ground point (the height is too low)
        rim = rim_at(poly_uv, camera, base_z + h)
        return None if rim is None else float((rim[0] - BASE_RATIO * rim[1] * away - front) @ away)

    def too_low(h):
        g = gap(h)
        return g is not None and g > 0.0

    cam_h = camera.origin[2] - base_z
    height = height_where_it_ends(too_low, 1e-3 * cam_h, 0.95 * cam_h, scans=60, halvings=40)
    if height is None:
        return None
    centre, radius = rim_at(poly_uv, camera, base_z + height)
    if not HEIGHT_RANGE[0] <= height / (2 * radius) <= HEIGHT_RANGE[1]:
        return None
    uv, depth = camera.project(np.r_[centre - radius * away, base_z + height][None])
    if depth[0] <= 0 or float(uv[0, 1]) >= bottom + 1.0 - 1.0:
        return None  # the front rim is the outline's foot: the base does not show
    return centre, radius, BASE_RATIO * radius, height


def vessel_mesh(centre: np.ndarray, base_radius_m: float, rim_radius: float, height: float,
                base_z: float = 0.0, wall: float | None = None, sections: int = SECTIONS,
                fill: float | None = None) -> trimesh.Trimesh:
    """The watertight hollow vessel: a floor of radius ``base_radius_m`` on z = ``base_z``, a straight wall
    out to the rim (``rim_radius``, ``height`` above the floor's underside), open at the top; walls and floor
    ``wall`` thick (default ``WALL_RATIO`` of the rim's diameter). ``centre`` (2,) the axis; metres.
    ``fill``: the inside is solid up to this height above the floor's underside (a pot's soil), not ``wall``."""
    t = WALL_RATIO * 2 * rim_radius if wall is None else wall
    t = min(t, 0.4 * height, 0.4 * base_radius_m)
    slope = (rim_radius - base_radius_m) / height  # outward run per unit rise
    floor = t if fill is None else float(np.clip(fill, t, height - 0.1 * t))
    inner_floor = base_radius_m + slope * floor - t  # the inner wall's radius at the floor's top
    profile = np.array([[0.0, 0.0], [base_radius_m, 0.0], [rim_radius, height], [rim_radius - t, height],
                        [inner_floor, floor], [0.0, floor]])
    mesh = trimesh.creation.revolve(profile, sections=sections)
    mesh.apply_translation([centre[0], centre[1], base_z])
    return mesh


def lift_vessel(mask: np.ndarray, poly_uv: np.ndarray, camera, base_z: float = 0.0):
    """(mesh, info) of the vessel whose outline is ``mask`` (H, W) bool / ``poly_uv`` (its convex hull), or
    None where its outline does not show a rim above a base (:func:`rim_from_outline`)."""
    rim = rim_from_outline(mask, poly_uv, camera, base_z)
    if rim is None:
        return None
    centre, radius, base, height = rim
    mesh = vessel_mesh(centre, base, radius, height, base_z)
    return mesh, {"rim_radius_m": round(radius, 5), "base_radius_m": round(base, 5), "height_m": round(height, 5),
                  "wall_m": round(float(WALL_RATIO * 2 * radius), 5), "height_source": "the rim's circle over the base's front"}
