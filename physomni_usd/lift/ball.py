"""Round things lifted as centred balls from the part of their outline the photo shows.

A fruit or a ball rests under its own middle whatever the view. Lifted by the outline's shape instead, a
fruit seen low (the camera's pitch read under ``FOOTPRINT_MIN_DEG``), half hidden (its outline completed as a
convex hull or an ellipse, which then fails ``is_ball``) or a little flatter than a ball became a slab, an
inflated blob or a loft anchored at its front: a foot on one side or two points, its centre of mass outside
it, and it rolled off at once (on one generated seed, 8 of 11 such fruits moved in 2 s where 0 of 70 footprint
balls did). So a thing whose label the size table calls a ball (``sizes``: fruit, balls), or whose visible arc
is itself a circle, is lifted here as a sphere in any view:

1. a circle is fitted to the outline's visible boundary: the completed outline's pixels the photo shows,
   not the edges where something hides it (nor the image's border), so an occluder's straight edge or the
   completion's guess does not bend it (:func:`visible_arc`, :func:`fit_circle`);
2. the rays through that circle are the cone tangent to the ball, whose axis points at its centre and whose
   half-angle gives its radius over its distance; resting on ``base_z`` fixes both
   (``footprint.sphere_from_outline``), so neither the pitch nor a height prior enters;
3. the sphere rests on a small round sole (``settings.BALL_SOLE`` of its radius cut flat under its centre),
   where its hull does not rock on the pole's facets.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..settings import BALL_ARC_MIN, BALL_ARC_RMS, BALL_SOLE

#: Angular bins over which the visible arc's coverage of its circle is counted (:func:`fit_circle`).
ARC_BINS = 36


def boundary_points(solid: np.ndarray) -> np.ndarray:
    """(n, 2) pixel centres (u, v) of the outer boundary of ``solid`` (H, W) bool."""
    contours, _ = cv2.findContours(solid.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return np.zeros((0, 2))
    return np.vstack(contours)[:, 0, :].astype(float)


def visible_arc(solid: np.ndarray, visible: np.ndarray | None) -> np.ndarray:
    """(n, 2) boundary pixels of the completed outline ``solid`` that the photo shows as its edge: on the
    ``visible`` mask (where the completed outline runs through hidden pixels, it is a guess) and off the image's
    border (a thing cut by the frame ends there, not at its edge)."""
    pts = boundary_points(solid)
    if len(pts) == 0:
        return pts
    h, w = solid.shape
    u, v = pts[:, 0].astype(int), pts[:, 1].astype(int)
    keep = (u > 0) & (v > 0) & (u < w - 1) & (v < h - 1)
    if visible is not None and visible.shape == solid.shape:
        keep &= visible[v, u]
    return pts[keep]


def fit_circle(pts: np.ndarray) -> tuple[float, float, float, float, float] | None:
    """(u0, v0, radius px, rms / radius, arc) of the least-squares circle through boundary pixels ``pts``, refitted
    once without the points farther off it than three times the median (a stray notch); ``rms`` over every point
    (a notch counts against a circle), ``arc`` the fraction of the circle's angle the points kept cover. The radius reaches the pixels' outer edges (half a pixel beyond their
    centres). None under six points or for a line."""
    if len(pts) < 6:
        return None
    keep = np.ones(len(pts), bool)
    for _ in range(2):
        p = pts[keep]
        a = np.c_[2.0 * p, np.ones(len(p))]
        b = (p ** 2).sum(axis=1)
        try:
            (u0, v0, c), *_ = np.linalg.lstsq(a, b, rcond=None)
        except np.linalg.LinAlgError:
            return None
        r2 = c + u0 * u0 + v0 * v0
        if not np.isfinite(r2) or r2 <= 1.0:
            return None
        r = math.sqrt(r2)
        off = np.abs(np.linalg.norm(pts - [u0, v0], axis=1) - r)
        keep = off <= max(3.0 * float(np.median(off)), 1.0)
        if keep.sum() < 6:
            return None
    rms = float(np.sqrt(np.mean((np.linalg.norm(pts - [u0, v0], axis=1) - r) ** 2)))  # over every point
    p = pts[keep]
    angle = np.arctan2(p[:, 1] - v0, p[:, 0] - u0)
    bins = np.unique(np.floor((angle + np.pi) / (2 * np.pi) * ARC_BINS).astype(int) % ARC_BINS)
    return float(u0), float(v0), r + 0.5, rms / r, len(bins) / ARC_BINS


def round_outline(solid: np.ndarray, visible: np.ndarray | None, ball_label: bool, by_outline: bool = True):
    """(u0, v0, radius px, how) of the circle a round thing's outline shows, or None where it is no ball's.

    A ball's label takes the circle of its visible arc where that arc is long enough to measure
    (``BALL_ARC_MIN`` of the circle), else of its whole outline; any other outline is a ball's only where its
    visible arc is that long and fits its circle to ``BALL_ARC_RMS`` of the radius, and only where ``by_outline``
    (seen from the side: from above a cylinder's top is such a circle too)."""
    arc = fit_circle(visible_arc(solid, visible))
    if arc is not None and arc[4] >= BALL_ARC_MIN and (ball_label or by_outline and arc[3] <= BALL_ARC_RMS):
        return (*arc[:3], "the circle of its visible arc")
    if not ball_label:
        return None
    whole = fit_circle(boundary_points(solid))
    return None if whole is None else (*whole[:3], "the circle of its outline")


def lift_ball(solid: np.ndarray, camera, base_z: float, visible: np.ndarray | None = None,
              ball_label: bool = False, by_outline: bool = True, sections: int = 48):
    """(vertices, faces, contact (3,), info) of the ball resting on z = ``base_z`` whose outline ``solid``
    (H, W) bool shows, or None where it shows none (:func:`round_outline`) or the tangent cone meets no ball
    resting there (its bottom at or above the horizon)."""
    from .footprint import sphere_from_outline

    found = round_outline(solid, visible, ball_label, by_outline)
    if found is None:
        return None
    u0, v0, r_px, how = found
    t = np.linspace(0.0, 2.0 * np.pi, sections, endpoint=False)
    ring = np.c_[u0 + r_px * np.cos(t), v0 + r_px * np.sin(t)]
    ball = sphere_from_outline(ring, camera, base_z)
    if ball is None:
        return None
    centre, radius = ball
    if not (radius > 0.0 and np.all(np.isfinite(centre))):
        return None
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    verts = np.asarray(mesh.vertices, float)
    # the sole: what lies under the cut rises onto it, and the ball comes down onto its support
    cut = -radius + BALL_SOLE * radius
    verts[:, 2] = np.maximum(verts[:, 2], cut)
    verts += [centre[0], centre[1], base_z - cut]
    contact = np.array([centre[0], centre[1], base_z])
    info = {"shape": "sphere", "axis": "ball", "height_source": f"the ball's tangent cone through {how}",
            "ball_radius_m": round(float(radius), 5), "ball_circle_px": [round(u0, 1), round(v0, 1), round(r_px, 1)]}
    return verts, np.asarray(mesh.faces, np.int32), contact, info
