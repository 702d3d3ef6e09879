"""What stands in an open vessel's mouth and is wider than it (a plant's foliage over its pot): round about the
vessel's axis, narrowed inside the mouth, its convex hull just over the rim's inner edge, held by what fills
the vessel (:func:`filled`).

A plant's foot ray goes through its pot's mouth and meets the empty vessel's
inner back wall; stood there, a slab of foliage rests on the back rim and
falls. What shows in a vessel's mouth (:func:`foot_in_mouth`) and is wider
than it is lifted here instead (:func:`rests_on_rim`): each image row a circle
about the vessel's axis (:func:`vessel_frame`), the rows below the rim
narrowed into the mouth, a ring at rim height, what rises above the rim
lowered by the factor whose silhouette matches the outline best, and the
body raised until its hull clears the rim's inner edge. The vessel is then
filled up to its foot (a pot's soil, :func:`filled`): it stands on that, not
on the rim, and weighs the vessel down.
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
#: ... and stands this fraction of the wall's thickness clear of the rim, on what fills the vessel under it
#: (``align.photo_scene.on_rim`` fills it): resting on the rim, it touched each of the wall's convex pieces,
#: and so many contacts let it and the vessel sink under XPBD's few iterations (a pot 6 mm into the ground).
RIM_GAP = 0.25
#: A vessel is filled to its brim where what stands in it reaches less than this fraction of its height into its
#: mouth (:func:`soil_level`).
BRIM = 0.1
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
    # the floor's top: the highest point about the axis (a filled pot's soil stands higher than its floor)
    floor = float(z[np.linalg.norm(v[:, :2] - centre, axis=1) <= 0.5 * inner].max(initial=low + wall))
    return {"centre": centre, "rim_z": top, "outer": outer, "inner": inner, "wall": wall, "floor_z": floor,
            "low_z": low, "base": base, "slope": (outer - base) / max(top - low, 1e-9)}


def soil_level(vertices: np.ndarray, foot_z: float) -> float:
    """Where the vessel ``vertices`` is filled to under a foot at ``foot_z`` in its mouth: the foot's height, or
    its rim where the foot is within :data:`BRIM` of the vessel's height under it (the foot is raised onto it).
    Filled so near its rim, a vessel collides as its hull (``geometry.overlap.convex_pieces``), whose top is
    the rim's: a foot just under it would start inside that hull."""
    f = vessel_frame(vertices)
    return f["rim_z"] if f["rim_z"] - foot_z < BRIM * (f["rim_z"] - f["low_z"]) else max(foot_z, f["floor_z"])


def filled(vertices: np.ndarray, level_z: float):
    """(vertices, faces) of the vessel ``vertices`` (:func:`vessel_frame`) with its inside solid up to
    ``level_z`` (at least its floor, at most a tenth of a wall's thickness under the rim): the soil that holds a
    plant."""
    f = vessel_frame(vertices)
    height = f["rim_z"] - f["low_z"]
    mesh = vessel_mesh(f["centre"], f["base"], f["outer"], height, f["low_z"], wall=f["wall"],
                       fill=max(level_z, f["floor_z"]) - f["low_z"])
    return np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)


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
    from scipy.spatial import ConvexHull

    def rise(zz):  # how far it must rise for its profile's hull (both sides) to clear the rim's inner edge
        prof = np.c_[np.r_[radius, -radius] * corner, np.r_[zz, zz]]
        hull = prof[ConvexHull(prof).vertices]
        edge_r = f["inner"]
        lows = [a[1] + (edge_r - a[0]) * (b[1] - a[1]) / (b[0] - a[0])
                for a, b in zip(hull, np.roll(hull, -1, axis=0))
                if (a[0] - edge_r) * (b[0] - edge_r) <= 0 and a[0] != b[0]]
        return max(0.0, f["rim_z"] - min(lows)) + RIM_GAP * f["wall"] if lows else 0.0

    # each row was cast where the axis crosses it, but a circle's back stands higher in the photo than its
    # middle: what rises above the rim is lowered as far as makes its silhouette match the outline best; each
    # height is raised clear of the rim (it stands on what fills the vessel: see the module)
    above = z > f["rim_z"]

    def seated(k):
        zz = np.where(above, f["rim_z"] + k * (z - f["rim_z"]), z)
        return zz + rise(zz)

    def body(zz):
        centres = np.c_[np.broadcast_to(f["centre"], (len(zz), 2)), zz]
        return loft(round_rings(centres, radius, np.r_[side, 0.0], normal, sections))

    best = max(RIM_HEIGHT_FACTORS, key=lambda k: fits(*body(seated(k)))) if above.any() and fits else 1.0
    z = seated(best)
    verts, faces = body(z)
    return verts, faces, np.r_[f["centre"], float(z.min())]
