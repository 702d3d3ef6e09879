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
its pot) rests on its rim: round about the vessel's axis, narrowed inside the
mouth, its convex hull on the rim's inner edge (:func:`rests_on_rim`).
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
#: A vessel is between these fractions of its rim's diameter tall.
HEIGHT_RANGE = (0.1, 1.2)


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
                base_z: float = 0.0, wall: float | None = None, sections: int = SECTIONS) -> trimesh.Trimesh:
    """The watertight hollow vessel: a floor of radius ``base_radius_m`` on z = ``base_z``, a straight wall
    out to the rim (``rim_radius``, ``height`` above the floor's underside), open at the top; walls and floor
    ``wall`` thick (default ``WALL_RATIO`` of the rim's diameter). ``centre`` (2,) the axis; metres."""
    t = WALL_RATIO * 2 * rim_radius if wall is None else wall
    t = min(t, 0.4 * height, 0.4 * base_radius_m)
    slope = (rim_radius - base_radius_m) / height  # outward run per unit rise
    inner_base = base_radius_m + slope * t - t
    profile = np.array([[0.0, 0.0], [base_radius_m, 0.0], [rim_radius, height], [rim_radius - t, height],
                        [inner_base, t], [0.0, t]])
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



#: What rests on a vessel's rim (a plant's foliage over its pot) keeps this fraction of the wall's thickness
#: clear of the wall inside the mouth, and leans on the rim this far past its inner edge.
RIM_CLEARANCE = 0.5
#: ... and what of it rises above the rim is lowered by the one of these factors whose silhouette matches its
#: outline best (:func:`rests_on_rim`).
RIM_HEIGHT_FACTORS = (1.0, 0.85, 0.7, 0.55, 0.4)


def vessel_frame(vertices: np.ndarray) -> dict:
    """The axis (2,), rim height, outer and inner rim radii, wall thickness, floor height (its top) and
    outward slope of the lifted vessel ``vertices`` (n, 3) (:func:`vessel_mesh`, moved or deepened whole)."""
    v = np.asarray(vertices, float)
    z = v[:, 2]
    top, low = float(z.max()), float(z.min())
    tol = 1e-6 * max(top - low, 1e-9)
    ring = v[z >= top - tol, :2]
    centre = 0.5 * (ring.min(0) + ring.max(0))
    r = np.linalg.norm(ring - centre, axis=1)
    outer, inner = float(r.max()), float(r.min())
    base = float(np.linalg.norm(v[z <= low + tol, :2] - centre, axis=1).max())
    wall = outer - inner
    return {"centre": centre, "rim_z": top, "outer": outer, "inner": inner, "wall": wall, "floor_z": low + wall,
            "slope": (outer - base) / max(top - low, 1e-9)}


def foot_in_mouth(vertices: np.ndarray, mask: np.ndarray, camera) -> bool:
    """Whether the ray through the foot of the object of ``mask`` (H, W) bool crosses the rim's height within the
    rim of the vessel ``vertices``: its foot shows in the vessel's mouth (or the front rim hides it there), not
    beside the vessel."""
    from .silhouette import fill_holes, foot_pixel

    u, v = foot_pixel(fill_holes(mask))
    f = vessel_frame(vertices)
    d = camera.rays(u, v)
    if d[2] >= -1e-9 or camera.origin[2] <= f["rim_z"]:
        return False
    at = camera.origin + (f["rim_z"] - camera.origin[2]) / d[2] * d
    return float(np.linalg.norm(at[:2] - f["centre"])) <= f["outer"]


def rests_on_rim(vertices: np.ndarray, mask: np.ndarray, camera, rows: int, sections: int, fits=None):
    """(vertices, faces, contact (3,)) of the object of ``mask`` (H, W) bool that rests on the rim of the vessel
    ``vertices`` (n, 3), or None where it is no wider than the vessel's mouth (it would fall in).

    What the photo shows of it above the rim is round about the vessel's axis (a plant's foliage over its pot is
    as deep as it is wide, and centred on it): each image row cast onto the vertical plane through the axis
    facing the camera is a circle about the axis. What shows below the rim, inside the mouth, is narrowed to the
    mouth, clear of the wall by :data:`RIM_CLEARANCE` of it; a ring at the rim's height spans the mouth onto the
    rim's top, and the body is raised until its convex hull (what physics collides) clears the rim's inner edge,
    so it rests there; what rises above the rim is lowered where that matches the outline better (the rings'
    backs rise above it): ``fits(vertices, faces)`` says how well a body matches it (higher is better)."""
    from .sections import loft, round_rings
    from .silhouette import fill_holes, row_spans

    f = vessel_frame(vertices)
    solid = fill_holes(mask)
    ys = np.nonzero(solid.any(axis=1))[0]
    k = int(min(rows, max(4, ys[-1] - ys[0] + 2)))
    edges = np.linspace(float(ys[0]), float(ys[-1] + 1), k)
    spans = row_spans(solid, edges)
    away, side = _frame(camera)
    normal = np.r_[away, 0.0]
    axis = np.r_[f["centre"], f["rim_z"]]

    def cast(u):  # where the rays through (u, edges) meet the vertical plane through the axis
        d = camera.rays(u, edges)
        s = ((axis - camera.origin) @ normal) / (d @ normal)
        return camera.origin + s[:, None] * d

    left, right = cast(spans[:, 0]), cast(spans[:, 1])
    z = 0.5 * (left[:, 2] + right[:, 2])
    # a ring's corners lie 1/cos(π/n) out (``sections.round_rings``): radii are kept as their corners reach
    corner = 1.0 / np.cos(np.pi / sections)
    radius = 0.5 * np.linalg.norm(right - left, axis=1)
    clear = RIM_CLEARANCE * f["wall"]
    mouth = f["inner"] - clear
    if not radius[z >= f["rim_z"]].size or radius[z >= f["rim_z"]].max() * corner <= mouth:
        return None
    keep = z >= f["floor_z"] + clear
    z, radius = z[keep], radius[keep]
    inside = z < f["rim_z"]
    wall_at = f["inner"] * np.cos(np.pi / SECTIONS) - f["slope"] * (f["rim_z"] - z)  # the revolved wall's flat sides
    radius[inside] = np.minimum(radius[inside], (wall_at[inside] - clear) / corner)
    radius = np.maximum(radius, 1e-4)
    # the ring that spans the mouth onto the rim's top
    z = np.r_[z, f["rim_z"]]
    radius = np.r_[radius, max((f["inner"] + clear) / corner, float(np.interp(f["rim_z"], z[:-1][::-1], radius[::-1])))]
    order = np.argsort(-z, kind="stable")
    z, radius = z[order], radius[order]
    # raise it until its profile's hull (the radius reached at each height, both sides) clears the rim's inner edge
    prof = np.c_[np.r_[radius, -radius] * corner, np.r_[z, z]]
    from scipy.spatial import ConvexHull

    hull = prof[ConvexHull(prof).vertices]
    edge_r = f["inner"]
    lows = []
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        if (a[0] - edge_r) * (b[0] - edge_r) <= 0 and a[0] != b[0]:
            lows.append(a[1] + (edge_r - a[0]) * (b[1] - a[1]) / (b[0] - a[0]))
    lift = max(0.0, f["rim_z"] - min(lows)) if lows else 0.0
    z = z + lift + 1e-6 * max(float(np.ptp(z)), 1e-9)
    # each row was cast where the axis crosses it, but a circle's back stands higher in the photo than its
    # middle: what rises above the rim is lowered as far as makes its silhouette match the outline best
    above = z > f["rim_z"]
    if above.any() and fits is not None:
        def body(k):
            zz = np.where(above, f["rim_z"] + k * (z - f["rim_z"]), z)
            centres = np.c_[np.broadcast_to(f["centre"], (len(z), 2)), zz]
            return loft(round_rings(centres, radius, np.r_[side, 0.0], normal, sections))

        best = max(RIM_HEIGHT_FACTORS, key=lambda k: fits(*body(k)))
        z = np.where(above, f["rim_z"] + best * (z - f["rim_z"]), z)
    centres = np.c_[np.broadcast_to(f["centre"], (len(z), 2)), z]
    verts, faces = loft(round_rings(centres, radius, np.r_[side, 0.0], normal, sections))
    return verts, faces, np.r_[f["centre"], float(z.min())]
