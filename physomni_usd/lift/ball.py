"""Round things lifted as centred balls from the part of their outline the photo shows.

A fruit or a ball rests under its own middle whatever the view. Lifted by the outline's shape instead, a
fruit seen low (the camera's pitch read under ``FOOTPRINT_MIN_DEG``), half hidden (its outline completed as a
convex hull or an ellipse, which then fails ``is_ball``) or a little flatter than a ball became a slab, an
inflated blob or a loft anchored at its front: a foot on one side or two points, its centre of mass outside
it, and it rolled off at once. So a thing whose label the size table calls a ball (``sizes``: fruit, balls), or whose visible arc
is itself a circle, is lifted here as a sphere in any view:

1. a circle is fitted to the outline's visible boundary: the completed outline's pixels the photo shows
   against the background, not those beside another object or a hidden part (nor the image's border), so an
   occluder's straight edge or the completion's guess does not bend it (:func:`visible_arc`,
   :func:`fit_circle`); a fit worse than ``BALL_LABEL_ARC_RMS`` is no ball's;
2. the rays through that circle are the cone tangent to the ball, whose axis points at its centre and whose
   half-angle gives its radius over its distance; resting on ``base_z`` fixes both
   (``footprint.sphere_from_outline``), so neither the pitch nor a height prior enters; a ball larger than the
   camera's height over it allows, or outside ``BALL_SIZE_BAND`` of its label's typical size, is refused;
3. where its outline is an upright ellipse a little wider than tall (a lemon, a mandarin), it is the upright
   oblate spheroid that outline shows (:func:`spheroid_from_outline`), which rests as stably as a ball;
4. it rests on a small round sole (``settings.BALL_SOLE`` of its radius cut flat under its centre),
   where its hull does not rock on the pole's facets.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..settings import (BALL_ARC_BINS, BALL_ARC_MIN, BALL_ARC_RMS, BALL_EDGE_PX, BALL_ELLIPSE_ARC, BALL_ELLIPSE_GAIN,
                        BALL_FLAT_MIN, BALL_LABEL_ARC_RMS, BALL_SIZE_BAND, BALL_SOLE)


def boundary_points(solid: np.ndarray) -> np.ndarray:
    """(n, 2) pixel centres (u, v) of the outer boundary of ``solid`` (H, W) bool."""
    contours, _ = cv2.findContours(solid.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return np.zeros((0, 2))
    return np.vstack(contours)[:, 0, :].astype(float)


def visible_arc(solid: np.ndarray, visible: np.ndarray | None, occluders: np.ndarray | None = None) -> np.ndarray:
    """(n, 2) boundary pixels of the completed outline ``solid`` that the photo shows as its edge: on the
    ``visible`` mask (where the completed outline runs through hidden pixels, it is a guess), off the image's
    border (a thing cut by the frame ends there, not at its edge), and with only background within
    ``BALL_EDGE_PX`` outside them: where ``occluders`` (the visible masks of what may be in front) or a hidden part of the
    outline lie next to it, the edge is where something else begins (a convex completion runs along an
    occluder's straight cut), not the thing's own."""
    pts = boundary_points(solid)
    if len(pts) == 0:
        return pts
    h, w = solid.shape
    u, v = pts[:, 0].astype(int), pts[:, 1].astype(int)
    keep = (u > 0) & (v > 0) & (u < w - 1) & (v < h - 1)
    other = np.zeros_like(solid, dtype=bool)
    if visible is not None and visible.shape == solid.shape:
        keep &= visible[v, u]
        other |= solid & ~visible
    if occluders is not None and occluders.shape == solid.shape:
        other |= occluders & ~(visible if visible is not None and visible.shape == solid.shape else solid)
    if other.any():
        k = 2 * BALL_EDGE_PX + 1
        near = cv2.dilate(other.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) > 0
        keep &= ~near[v, u]
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
    bins = np.unique(np.floor((angle + np.pi) / (2 * np.pi) * BALL_ARC_BINS).astype(int) % BALL_ARC_BINS)
    return float(u0), float(v0), r + 0.5, rms / r, len(bins) / BALL_ARC_BINS


def fit_ellipse(pts: np.ndarray) -> tuple[float, float, float, float, float] | None:
    """(u0, v0, half-width px, half-height px, rms / mean half-axis) of the least-squares ellipse with upright axes
    through boundary pixels ``pts`` (an upright round thing a little flat, seen with the camera level), the
    half-axes reaching the pixels' outer edges; None under six points or where the conic is no ellipse."""
    if len(pts) < 6:
        return None
    mid, span = pts.mean(0), max(float(np.ptp(pts)), 1.0)
    q = (pts - mid) / span  # conditioning
    a = np.c_[q[:, 0] ** 2, q[:, 1] ** 2, q[:, 0], q[:, 1]]
    try:
        (pa, pb, pc, pd), *_ = np.linalg.lstsq(a, np.ones(len(q)), rcond=None)
    except np.linalg.LinAlgError:
        return None
    if pa <= 0 or pb <= 0:
        return None
    cu, cv = -pc / (2 * pa), -pd / (2 * pb)
    g = 1.0 + pa * cu * cu + pb * cv * cv
    if g <= 0:
        return None
    ru, rv = math.sqrt(g / pa) * span, math.sqrt(g / pb) * span
    u0, v0 = cu * span + mid[0], cv * span + mid[1]
    rho = np.hypot((pts[:, 0] - u0) / ru, (pts[:, 1] - v0) / rv)
    return float(u0), float(v0), ru + 0.5, rv + 0.5, float(np.sqrt(np.mean((rho - 1.0) ** 2)))


def round_outline(solid: np.ndarray, visible: np.ndarray | None, ball_label: bool, by_outline: bool = True,
                  occluders: np.ndarray | None = None):
    """(u0, v0, half-width px, half-height px, how) of the round outline a round thing shows, or None where it is
    no ball's.

    A ball's label takes the circle of its visible arc where that arc is long enough to measure
    (``BALL_ARC_MIN`` of the circle), else of its whole outline off the image's border, either only where it fits
    that circle to ``BALL_LABEL_ARC_RMS`` of the radius; where the arc covers ``BALL_ELLIPSE_ARC`` of it and an
    upright ellipse fits it that well and clearly better than the circle (``BALL_ELLIPSE_GAIN``), that ellipse
    (a fruit a little flat).
    Any other outline is a ball's only where its visible arc is that long and fits its circle to
    ``BALL_ARC_RMS``, and only where ``by_outline`` (seen from the side: from above a cylinder's top is such a
    circle too)."""
    for pts, how in ((visible_arc(solid, visible, occluders), "its visible arc"),
                     (visible_arc(solid, None), "its outline")):
        arc = fit_circle(pts)
        if arc is None or arc[4] < BALL_ARC_MIN:
            if not ball_label:
                return None
            continue
        if arc[3] <= BALL_ARC_RMS and (ball_label or by_outline):
            return (*arc[:3], arc[2], f"the circle of {how}")
        if not ball_label:
            return None
        oval = fit_ellipse(pts) if arc[4] >= BALL_ELLIPSE_ARC else None
        if oval is not None and oval[4] <= min(BALL_LABEL_ARC_RMS, BALL_ELLIPSE_GAIN * arc[3]):
            return (*oval[:4], f"the upright ellipse of {how}")
        if arc[3] <= BALL_LABEL_ARC_RMS:
            return (*arc[:3], arc[2], f"the circle of {how}")
    return None


def spheroid_from_outline(u0: float, v0: float, ru: float, rv: float, camera, base_z: float, flat_min: float):
    """(centre (3,), horizontal semi-axis a, vertical semi-axis c) of the upright spheroid resting on z = ``base_z``
    whose outline is the ellipse (``u0``, ``v0``, ``ru``, ``rv``) px, or None (its bottom at or above the horizon).

    Its outline's rays form a cone whose axis points at its centre: at distance t the half-width's half-angle
    α_h gives a = t·sin α_h, and the half-height's α_v, seen ``θ`` below level, gives
    (t·sin α_v)² = a²·sin²θ + c²·cos²θ. Resting on its pole puts the centre c above ``base_z``, which fixes t.
    c is kept within [``flat_min``·a, a]: a taller upright spheroid would stand on its tip, unstable."""
    axis = camera.rays(u0, v0)
    axis = axis / np.linalg.norm(axis)
    side = camera.rays(np.array([u0 - ru, u0 + ru, u0, u0]), np.array([v0, v0, v0 - rv, v0 + rv]))
    ang = np.arccos(np.clip(side @ axis, -1.0, 1.0))
    sh, sv = math.sin(0.5 * (ang[0] + ang[1])), math.sin(0.5 * (ang[2] + ang[3]))
    sin_t = min(max(-float(axis[2]), 0.0), 0.999)
    cos2 = 1.0 - sin_t * sin_t
    k = math.sqrt(max(sv * sv - sh * sh * sin_t * sin_t, 0.0) / cos2)
    k = min(max(k, flat_min * sh), sh)
    if sh <= 1e-6 or k - axis[2] <= 1e-9:
        return None
    t = (camera.origin[2] - base_z) / (k - axis[2])  # centre z = base_z + t·k, on the axis
    if t <= 0:
        return None
    centre = camera.origin + t * axis
    return centre, float(t * sh), float(t * k)


def lift_ball(solid: np.ndarray, camera, base_z: float, visible: np.ndarray | None = None,
              ball_label: bool = False, by_outline: bool = True, occluders: np.ndarray | None = None,
              size_hint: float | None = None):
    """(vertices, faces, contact (3,), info) of the round thing (a ball, or an upright spheroid a little flat)
    resting on z = ``base_z`` whose outline ``solid`` (H, W) bool shows, or None where it shows none
    (:func:`round_outline`), the tangent cone meets none resting there (:func:`spheroid_from_outline`), or the
    one it meets is implausible: its width outside ``BALL_SIZE_BAND`` of ``size_hint`` (the label's typical size,
    camera units) or, with no size known, at least 0.9 of the camera's height above ``base_z`` (as
    ``footprint``'s ball): the arc or its support was wrong."""
    found = round_outline(solid, visible, ball_label, by_outline, occluders)
    if found is None:
        return None
    u0, v0, ru, rv, how = found
    body = spheroid_from_outline(u0, v0, ru, rv, camera, base_z, BALL_FLAT_MIN)
    if body is None:
        return None
    centre, radius, half_height = body
    if not (radius > 0.0 and np.all(np.isfinite(centre))):
        return None
    # a label's typical size bounds it; without one, the camera's height (a camera level with a fruit on a table
    # sees a true ball as tall as its height over the table, so this bound only serves where no size is known)
    if size_hint and not size_hint / BALL_SIZE_BAND <= 2 * radius <= size_hint * BALL_SIZE_BAND:
        return None
    if not size_hint and 2 * radius >= 0.9 * (camera.origin[2] - base_z):
        return None
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    verts = np.asarray(mesh.vertices, float) * [radius, radius, half_height]
    # the sole: what lies under the cut rises onto it, and the ball comes down onto its support
    cut = -half_height + BALL_SOLE * half_height
    verts[:, 2] = np.maximum(verts[:, 2], cut)
    verts += [centre[0], centre[1], base_z - cut]
    contact = np.array([centre[0], centre[1], base_z])
    info = {"shape": "sphere", "axis": "ball", "height_source": f"the ball's tangent cone through {how}",
            "ball_radius_m": round(float(radius), 5), "ball_half_height_m": round(float(half_height), 5),
            "ball_outline_px": [round(u0, 1), round(v0, 1), round(ru, 1), round(rv, 1)]}
    return verts, np.asarray(mesh.faces, np.int32), contact, info
