"""What rests on an open vessel's rim (a plant's foliage over its pot): round about the vessel's axis, narrowed
inside the mouth, its convex hull on the rim's inner edge.

A plant's foot ray goes through its pot's mouth and meets the empty vessel's
inner back wall; stood there, a slab of foliage rests on the back rim and
falls. What shows in a vessel's mouth (:func:`foot_in_mouth`) and is wider
than it is lifted here instead (:func:`rests_on_rim`): each image row a circle
about the vessel's axis (:func:`vessel_frame`), the rows below the rim
narrowed into the mouth, a ring at rim height, the body raised until its hull
rests on the rim, and what rises above the rim lowered by the factor whose
silhouette matches the outline best.
"""

from __future__ import annotations

import numpy as np

from .silhouette import fill_holes, foot_pixel, row_spans
from .vessel import SECTIONS, _frame, vessel_mesh

#: What rests on a vessel's rim (a plant's foliage over its pot) keeps this fraction of the wall's thickness
#: clear of the wall inside the mouth, and leans on the rim this far past its inner edge.
RIM_CLEARANCE = 0.5
#: ... and what of it rises above the rim is lowered by the one of these factors whose silhouette matches its
#: outline best (:func:`rests_on_rim`).
RIM_HEIGHT_FACTORS = (1.0, 0.85, 0.7, 0.55, 0.4)
#: A foot this many pixels outside the rim, on the rim's plane, is still in the mouth: the outline's lowest
#: pixel row is drawn where the rim's front crosses it.
MOUTH_MARGIN_PX = 1.0


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
    """Whether the object of ``mask`` (H, W) bool has its foot in the mouth of the vessel ``vertices``: the ray
    through its foot crosses the rim's height within the rim (give or take :data:`MOUTH_MARGIN_PX`), or meets
    the vessel's outer wall in front below it.

    The second is foliage hanging over a pot's front: its lowest pixel shows over the pot's wall, so it is in
    front of that wall and above the ground there (the ground under that pixel lies behind the wall's foot);
    nothing but the pot can hold it. A foot hidden by the vessel (a thing on the ground behind it) shows at
    the rim's back, never over its wall."""

    u, v = foot_pixel(fill_holes(mask))
    f = vessel_frame(vertices)
    d = camera.rays(u, v)
    if d[2] >= -1e-9 or camera.origin[2] <= f["rim_z"]:
        return False
    at = camera.origin + (f["rim_z"] - camera.origin[2]) / d[2] * d
    # a pixel's width on the rim's plane at that distance: a foot drawn just in front of the rim is in it
    margin = MOUTH_MARGIN_PX * float(np.linalg.norm(at - camera.origin)) / camera.focal_px
    if float(np.linalg.norm(at[:2] - f["centre"])) <= f["outer"] + margin:
        return True
    # down the ray from the rim's height to the base's: inside the revolved outer wall anywhere?
    low = f["floor_z"] - f["wall"]
    z = np.linspace(f["rim_z"], low, 64)
    points = camera.origin + ((z - camera.origin[2]) / d[2])[:, None] * d
    reach = f["outer"] - f["slope"] * (f["rim_z"] - z)
    return bool((np.linalg.norm(points[:, :2] - f["centre"], axis=1) <= reach).any())


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
