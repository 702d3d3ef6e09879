"""Lifting an object seen from above: its silhouette is mostly its footprint.

Seen from above, a prism of footprint F and height H projects onto the
ground as F stretched away from the camera by its top's parallax. The mask
cast onto the ground plane (A₀) and cast onto the plane at height H and
dropped (A_H) both contain F, and for a convex prism their intersection is F
(up to slivers at the sides): so F = A₀ ∩ A_H, rasterised on a ground grid.

The height comes from the visible sides where the photo shows them: a round
outline (the footprint's outline close to its fitted circle) is a cylinder,
whose footprint is as deep as it is wide, and the H that makes it so is the
height; other outlines take it from the edge between their front side and
their top, where the photo shows one consistently across the object. Where the sides hardly show (rays steeper than ``SIDES_VISIBLE_DEG``
from the horizontal) or the outline is not round, the height is the label's
typical height (``physomni_usd/sizes.py``), and without one half the
footprint's width. Round footprints become cylinders (a disc when flat), or
spheres where the label is a ball's; organic things (``sizes.body_kind``:
fruit, toys, bags) that are not balls an inflated dome of their footprint
(√(2Rd − d²) of the distance d to its outline, up to the height); others the
prism of their convex hull, called a plate when it is thinner than
``PLATE_RATIO`` of its footprint (coins, cards, parts). A flat thing whose
label's typical height would stand it on its edge lies on its broadest face
instead (:func:`lying_height`). Open containers
(``sizes.body_kind`` 'vessel': bowls, pots, …) whose outline shows a rim
above a base never get here: ``silhouette.py`` lifts them hollow first
(``vessel.py``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import trimesh

from ..settings import HELD_SHARE
from .sections import bulge, inflated_rings, loft, span_samples

#: Cells across the footprint's ground-grid raster.
GRID_CELLS = 256
#: A footprint whose IoU with its fitted circle reaches this is round.
ROUND_IOU = 0.85
#: Rays steeper than this (degrees below the horizontal) hardly show an object's sides.
SIDES_VISIBLE_DEG = 80.0
#: A height read from the sides further than this factor from the label's typical height is not trusted.
SIDES_PRIOR_FACTOR = 3.0
#: Height of an object without a typical height, as a fraction of its footprint's width.
DEFAULT_HEIGHT_RATIO = 0.5
#: A prism at most this tall for the smaller side of its footprint is a plate.
PLATE_RATIO = 0.15
#: A held plate stands upright where its outline on the upright plane fills its rectangle by this much more
#: than lying (:func:`upright_plate`); a mask's pixel steps move either by about 0.01–0.02.
UPRIGHT_MARGIN = 0.04
#: ... and fills at least this much of its rectangle standing (a mask tens of pixels across, of a rectangle,
#: fills 0.92–0.98 of it).
UPRIGHT_FILL = 0.9
#: How far from facing the camera a held plate's upright plane may turn about the vertical, in steps of this.
UPRIGHT_TURN_DEG = 60.0
UPRIGHT_TURN_STEP_DEG = 5.0
#: Turns whose fill is within this of the best are told apart by the mask's pixel steps alone (a card's
#: scores spread 0.907–0.917 over every turn): the middle one of them is taken (of cards hung turned 20–30°,
#: the best fill's turn was a median 10° and up to 50° off; the middle's 7° and up to 30°; the least turn's
#: leaned to facing the camera, up to 38° off).
UPRIGHT_TURN_TIE = 0.01
#: A plane that some ray meets more than this far from its normal casts the outline grazing it, stretched
#: and unsure; nor is a cast kept whose longest side is more than :data:`UPRIGHT_MAX_GROW` times the lying
#: plate's (a 20 cm board turned 60° came out 1.04 m deep).
UPRIGHT_MAX_GRAZE_DEG = 65.0
UPRIGHT_MAX_GROW = 1.5
#: Seen less steeply than this below the horizontal, a lying plate's outline cast on the ground is stretched
#: along the ray by 1/sin of that angle, and so is every pixel step of its mask: how well it fills its
#: rectangle lying says nothing, and it is left lying (boards lying at 3–6° stood in 1–7 of 54 poses).
UPRIGHT_MIN_DEPRESSION_DEG = 8.0
#: ... and so is one whose mask is fewer pixels tall than this: a few rows' steps decide either fill.
UPRIGHT_MIN_ROWS = 6.0
#: Cells across an inflated footprint's raster, and the sections it is cut into.
INFLATE_CELLS = 96
INFLATE_SECTIONS = 24


def outline(mask: np.ndarray) -> np.ndarray:
    """(n, 2) pixel-edge coordinates of the convex hull of the mask: parts that another object cuts apart
    belong to one object, and the lifted shapes are convex anyway."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    c = cv2.convexHull(np.vstack(contours))[:, 0, :].astype(float)
    # contour pixels' centres pushed half a pixel outwards from the centroid: the outline's pixel edges
    mid = c.mean(0)
    d = c - mid
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return c + 0.5 + 0.5 * d / np.maximum(n, 1e-9)


def on_plane(camera, uv: np.ndarray, z: float) -> np.ndarray:
    """(n, 3) where the rays through pixels ``uv`` meet the plane at height ``z``; NaN where they do not."""
    d = camera.rays(uv[:, 0], uv[:, 1])
    t = (z - camera.origin[2]) / np.where(d[:, 2] < -1e-9, d[:, 2], np.nan)
    t = np.where(t > 0, t, np.nan)
    return camera.origin + t[:, None] * d


def footprint(poly_uv: np.ndarray, camera, base_z: float, height: float) -> np.ndarray | None:
    """(m, 2) outline of F = A₀ ∩ A_H on the ground, or None if the outline does not reach the ground."""
    a0 = on_plane(camera, poly_uv, base_z)[:, :2]
    ah = on_plane(camera, poly_uv, base_z + height)[:, :2] if height > 0 else a0
    if not (np.all(np.isfinite(a0)) and np.all(np.isfinite(ah))):
        return None
    lo = np.minimum(a0.min(0), ah.min(0))
    hi = np.maximum(a0.max(0), ah.max(0))
    cell = float(max(hi - lo)) / GRID_CELLS
    if cell <= 0:
        return None
    shape = (int(math.ceil((hi[1] - lo[1]) / cell)) + 3, int(math.ceil((hi[0] - lo[0]) / cell)) + 3)
    grid = lambda p: np.round((p - lo) / cell * 16 + 16).astype(np.int32)  # noqa: E731 (1-cell margin, 4 bits)
    r0 = np.zeros(shape, np.uint8)
    rh = np.zeros(shape, np.uint8)
    cv2.fillPoly(r0, [grid(a0)], 1, shift=4)
    cv2.fillPoly(rh, [grid(ah)], 1, shift=4)
    both = (r0 & rh).astype(np.uint8)
    contours, _ = cv2.findContours(both, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return None
    c = max(contours, key=cv2.contourArea)[:, 0, :].astype(float)
    return (c - 1.0 + 0.5) * cell + lo


def held_height(poly_uv: np.ndarray, camera, base_z: float, height: float, flat: np.ndarray):
    """(height, footprint): ``height`` and its footprint (:func:`footprint`) where that footprint keeps
    :data:`settings.HELD_SHARE` of ``flat`` (the outline's cast at ``base_z``), else the greatest height under
    it whose footprint does (found by halving), else ``height`` and its footprint unchanged (None or a sliver)
    where even a sheet's does not. Not the tallest height the outline holds a footprint for: the one where the
    footprint is still about the thing's own. A label's typical size is a guess; a height just under the one
    that leaves no footprint leaves a sliver, and a prism on it stands as a fin."""
    need = HELD_SHARE * abs(cv2.contourArea(np.asarray(flat, np.float32)))

    def held(h: float):
        fp = footprint(poly_uv, camera, base_z, h)
        ok = fp is not None and len(fp) >= 3 and abs(cv2.contourArea(fp.astype(np.float32))) >= need
        return fp if ok else None

    kept = held(float(height))
    if kept is not None:
        return height, kept
    lo, hi = 0.0, float(height)
    if need <= 0 or held(1e-3 * hi) is None:
        return height, footprint(poly_uv, camera, base_z, height)
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if held(mid) is not None else (lo, mid)
    return lo, held(lo)


def circle_fit(poly: np.ndarray) -> tuple[np.ndarray, float, float]:
    """(centre (2,), radius, IoU of the polygon with that circle); the circle has the polygon's area.

    A polygon with fewer than three finite corners, or none of any size (a footprint cast from rays at the
    horizon), is no circle: (the mean of its finite corners, 0, 0)."""
    poly = np.asarray(poly, float)
    poly = poly[np.all(np.isfinite(poly), axis=1)]
    if len(poly) < 3 or not np.ptp(poly, axis=0).max() > 0:
        return (poly.mean(0) if len(poly) else np.zeros(2)), 0.0, 0.0
    area = abs(cv2.contourArea(poly.astype(np.float32)))
    m = cv2.moments(poly.astype(np.float32))
    centre = np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]) if m["m00"] else poly.mean(0)
    r = math.sqrt(area / math.pi)
    # IoU by rasterising both on a small grid
    span = max(np.ptp(poly, axis=0).max(), 2 * r)
    cell = span / 128
    lo = np.minimum(poly.min(0), centre - r) - cell
    shape = (int(span / cell) + 4, int(span / cell) + 4)
    a = np.zeros(shape, np.uint8)
    b = np.zeros(shape, np.uint8)
    cv2.fillPoly(a, [np.round((poly - lo) / cell * 16).astype(np.int32)], 1, shift=4)
    cv2.circle(b, tuple(int(x) for x in np.round((centre - lo) / cell * 16)), int(round(r / cell * 16)), 1, -1,
               shift=4)
    iou = float((a & b).sum() / max((a | b).sum(), 1))
    return centre, r, iou


def view_depression_deg(camera, point: np.ndarray) -> float:
    d = np.asarray(point, float) - camera.origin
    return math.degrees(math.atan2(-d[2], math.hypot(d[0], d[1])))


def height_from_sides(poly_uv, camera, base_z: float) -> float | None:
    """The height that makes the footprint as deep (away from the camera) as it is wide, if one does."""
    top = 0.95 * (camera.origin[2] - base_z)

    def aspect(h):
        fp = footprint(poly_uv, camera, base_z, h)
        if fp is None or len(fp) < 3:
            return None
        centre = fp.mean(0)
        away = centre - camera.origin[:2]
        away /= max(np.linalg.norm(away), 1e-12)
        side = np.array([-away[1], away[0]])
        return float(np.ptp(fp @ away) / max(np.ptp(fp @ side), 1e-12))

    def deeper_than_wide(h):
        a = aspect(h)
        return a is not None and a > 1.0

    return height_where_it_ends(deeper_than_wide, 1e-3 * top, top, scans=40, halvings=20)


def height_where_it_ends(holds, first: float, last: float, scans: int, halvings: int) -> float | None:
    """The height (m above the base) at which ``holds(h)`` stops being true: ``scans`` heights spaced
    geometrically from ``first`` to ``last`` find the first that fails, then ``halvings`` bisections between it
    and the last that held. None when it fails already at 0 or holds at every scanned height."""
    if not holds(0.0):
        return None
    lo, hi = 0.0, None
    for h in np.geomspace(first, last, scans):
        if not holds(float(h)):
            hi = float(h)
            break
        lo = float(h)
    if hi is None:
        return None
    for _ in range(halvings):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if holds(mid) else (lo, mid)
    return 0.5 * (lo + hi)


#: Columns whose side edges agree within ±0.4 × this (fraction of the height) form a group.
EDGE_AGREEMENT = 0.25


def height_from_edge(photo: np.ndarray, mask: np.ndarray, camera, base_z: float) -> float | None:
    """The height at which the photo shows the edge between an object's front side and its top.

    In each column of the middle 60 % of the mask, the strongest vertical brightness change above the
    mask's bottom (and off its border) is taken for the top of the front side; the height whose vertical
    edge, standing on the ground where the column's bottom pixel looks, reaches that row is that column's
    height. The answer is the median of the largest group of columns agreeing within ±10 %, when that
    group holds 40 % of the columns.
    """
    gray = cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY).astype(np.float32) if photo.ndim == 3 else photo.astype(np.float32)
    grad = np.abs(cv2.Sobel(cv2.GaussianBlur(gray, (3, 3), 0), cv2.CV_32F, 0, 1, ksize=3))
    inner = cv2.erode(mask.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    ys, xs = np.nonzero(mask)
    x0, x1 = np.percentile(xs, [20, 80])
    heights, strengths = [], []
    contrast = float(np.percentile(grad[inner], 50)) if inner.any() else 0.0
    for u in range(int(x0), int(x1) + 1):
        col = np.nonzero(mask[:, u])[0]
        if len(col) < 8:
            continue
        bottom = col.max() + 1
        cand = np.nonzero(inner[:, u])[0]
        cand = cand[cand < bottom - 3]
        if not len(cand):
            continue
        g = grad[cand, u]
        k = int(np.argmax(g))
        if g[k] < max(8.0, 4.0 * contrast):
            continue
        v_top = float(cand[k])
        foot = on_plane(camera, np.array([[u + 0.5, float(bottom)]]), base_z)[0]
        if not np.all(np.isfinite(foot)):
            continue
        # the ray through (u, v_top) and the vertical line through the foot: their closest approach's height
        d = camera.rays(u + 0.5, v_top)
        o = camera.origin
        w0 = o - foot
        a, b, c = d @ d, d[2], 1.0
        dd, e = d @ w0, w0[2]
        den = a * c - b * b
        if abs(den) < 1e-12:
            continue
        t_vert = (a * e - b * dd) / den
        if t_vert > 0:
            heights.append(t_vert)
            strengths.append(float(g[k]))
    if len(heights) < 5:
        return None
    h = np.asarray(heights)
    # columns whose bottom is another object's outline, or whose strongest edge is a texture, disagree:
    # the answer is the largest group of columns within ±10 % of each other, if it holds 40 % of them
    near = np.abs(h[:, None] - h[None, :]) <= EDGE_AGREEMENT * 0.4 * h[:, None]
    best = int(np.argmax(near.sum(1)))
    group = h[near[best]]
    return float(np.median(group)) if len(group) >= 0.4 * len(h) else None


def sphere_from_outline(poly_uv: np.ndarray, camera, base_z: float) -> tuple[np.ndarray, float] | None:
    """(centre (3,), radius) of the ball resting on z = ``base_z`` whose silhouette is the outline, or None.

    A sphere's silhouette is the cone of rays tangent to it: its axis points at the centre and its half
    angle α gives distance = radius / sin α. With the centre one radius above the ground, the distance
    along the axis follows from the camera's height alone, so no height prior enters.
    """
    d = camera.rays(poly_uv[:, 0], poly_uv[:, 1])
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    axis = d.mean(0)
    axis /= np.linalg.norm(axis)
    alpha = float(np.mean(np.arccos(np.clip(d @ axis, -1.0, 1.0))))
    s = math.sin(alpha)
    if s <= 1e-6 or s - axis[2] <= 1e-9:
        return None
    t = (camera.origin[2] - base_z) / (s - axis[2])  # centre z = base_z + t·s, on the axis
    if t <= 0:
        return None
    centre = camera.origin + t * axis
    radius = t * s
    if centre[2] - base_z <= 0:
        return None
    return centre, float(radius)


#: Most pixels by which a face's texture may stray from the photo (see :func:`fine_faces`).
TEXTURE_ERROR_PX = 0.5


def fine_faces(verts: np.ndarray, faces: np.ndarray, camera) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces int32) split until the photo's texture stays on the photo across each face.

    Texture coordinates are the photo's projection of the vertices, interpolated linearly over each face;
    over an edge of length L at distance D that is off by about f·(L/D)²/4 pixels (f the focal length), so
    a cylinder's cap or a prism's top — a few triangles across a saucer seen from 25 cm — put its texture,
    and frame 0, pixels off the photo. Edges are kept under D·√(4·TEXTURE_ERROR_PX / f): a few per side
    for objects far away, more for close ones.
    """
    dist = float(np.linalg.norm(verts.mean(0) - camera.origin))
    max_edge = dist * math.sqrt(4.0 * TEXTURE_ERROR_PX / camera.focal_px)
    if float(np.ptp(verts, axis=0).max()) <= max_edge:
        return verts, np.asarray(faces, np.int32)
    v, f = trimesh.remesh.subdivide_to_size(verts, faces, max_edge=max_edge, max_iter=10)
    return np.asarray(v, float), np.asarray(f, np.int32)


def inflated_footprint(fp: np.ndarray, base_z: float, height: float, sections: int = 16):
    """(vertices, faces) of a dome over the ground outline ``fp`` (m, 2): flat below, √(2Rd − d²)-shaped above,
    ``height`` at its thickest, cut into ``INFLATE_SECTIONS`` sections along y and lofted (closed); None for an
    outline too thin to cut into two sections."""

    lo = fp.min(0)
    cell = float(np.ptp(fp, axis=0).max()) / INFLATE_CELLS
    shape = (int(math.ceil(np.ptp(fp[:, 1]) / cell)) + 3, int(math.ceil(np.ptp(fp[:, 0]) / cell)) + 3)
    raster = np.zeros(shape, np.uint8)
    cv2.fillPoly(raster, [np.round((fp - lo) / cell * 16 + 16).astype(np.int32)], 1, shift=4)
    dist = cv2.distanceTransform(raster, cv2.DIST_L2, 5)
    big = float(dist.max())
    rows = np.nonzero(raster.any(axis=1))[0]
    if len(rows) < 2 or big <= 0:
        return None
    pick = np.unique(np.round(np.linspace(rows[0], rows[-1], INFLATE_SECTIONS)).astype(int))
    left = np.array([np.argmax(raster[r]) for r in pick], float)
    right = np.array([raster.shape[1] - np.argmax(raster[r, ::-1]) for r in pick], float)
    cols = span_samples(left, right, sections // 2 + 1)
    inside = dist[pick[:, None], np.clip(cols.astype(int), 0, raster.shape[1] - 1)]
    # cell centres back to metres (the raster has a one-cell margin)
    x = (cols - 1.0) * cell + lo[0]
    y = np.broadcast_to(((pick + 0.5 - 1.0) * cell + lo[1])[:, None], cols.shape)
    half = 0.5 * height * bulge(inside, big)
    middle = np.stack([x, y, base_z + half], axis=-1)
    rings = inflated_rings(middle, half, np.array([0.0, 0.0, 1.0]))
    return loft(rings)


#: The thinnest a flat thing may come out, as a fraction of its label's typical height (:func:`lying_height`).
LYING_RANGE = 16.0
#: Heights tried between that and the typical height, evenly on a log scale.
LYING_STEPS = 17
#: Heights whose prisms cover the outline within this IoU of the best fit it equally well.
LYING_IOU_TIE = 0.01


def _narrow_side(poly_uv: np.ndarray, camera, base_z: float, height: float) -> tuple[float, np.ndarray | None]:
    """(the narrow side of the footprint's least rectangle, metres; the footprint) at ``height``."""
    fp = footprint(poly_uv, camera, base_z, height)
    if fp is None or len(fp) < 3:
        return 0.0, None
    (_, _), (a, b), _ = cv2.minAreaRect(fp.astype(np.float32))
    return float(min(a, b)), fp


def prism_iou(poly_uv: np.ndarray, fp: np.ndarray, camera, base_z: float, height: float) -> float:
    """IoU, in the photo, of the outline ``poly_uv`` (n, 2 px) with the prism of ground outline ``fp`` (m, 2)
    from ``base_z`` up ``height``: both convex, so each is the filled hull of its points (1/16 px)."""
    hull = cv2.convexHull(fp.astype(np.float32))[:, 0, :].astype(float)
    corners = np.vstack([np.c_[hull, np.full(len(hull), base_z)], np.c_[hull, np.full(len(hull), base_z + height)]])
    uv, depth = camera.project(corners)
    if (depth <= 0).any():
        return 0.0
    lo = np.floor(np.minimum(uv.min(0), poly_uv.min(0))) - 2
    size = (np.ceil(np.maximum(uv.max(0), poly_uv.max(0)) - lo) + 3).astype(int)
    fill = lambda p: cv2.fillConvexPoly(np.zeros((size[1], size[0]), np.uint8),  # noqa: E731
                                        np.round((cv2.convexHull(p.astype(np.float32))[:, 0, :] - lo) * 16)
                                        .astype(np.int32), 1, shift=4) > 0
    a, b = fill(uv), fill(poly_uv)
    return float((a & b).sum() / max((a | b).sum(), 1))


def lying_height(poly_uv: np.ndarray, camera, base_z: float, height: float) -> float | None:
    """The height of a flat thing (a spoon, a key) that its label's typical ``height`` would stand on its edge,
    or None when that height already lies flat.

    A flat thing's typical height counts what it spans when it lies (a spoon's curved bowl), not how thick
    it is; as a prism's thickness it shrinks the footprint A₀ ∩ A_H to a sliver narrower than it is tall, a
    fin on its edge (a 9 × 1.4 × 0.5 cm bar came out 8 × 0.3 × 2 cm). Lying, the thing rests on its broadest
    face, so its height is at most its footprint's narrow side. Of the heights down to 1/``LYING_RANGE`` of
    the typical one that lie so, those whose prisms cover the outline in the photo (:func:`prism_iou`) within
    ``LYING_IOU_TIE`` of the best fit it equally well (a thinner prism casts a wider footprint, and the
    outline's pixels cannot tell them apart): their geometric middle is taken. A choice among shapes that
    all fit, not a measurement.
    """
    narrow, _ = _narrow_side(poly_uv, camera, base_z, height)
    if narrow >= height:
        return None
    fits = []
    for h in np.geomspace(height / LYING_RANGE, height, LYING_STEPS):
        narrow, fp = _narrow_side(poly_uv, camera, base_z, float(h))
        if fp is not None and narrow >= h:
            fits.append((float(h), prism_iou(poly_uv, fp, camera, base_z, float(h))))
    if not fits:
        return None
    best = max(iou for _, iou in fits)
    return float(np.exp(np.mean([np.log(h) for h, iou in fits if iou >= best - LYING_IOU_TIE])))


def lift_footprint(mask: np.ndarray, camera, height_hint: float | None, prior_shape: str | None,
                   base_z: float = 0.0, sections: int = 32, photo: np.ndarray | None = None,
                   flat_prior: bool = False, kind: str | None = None):
    """(vertices, faces, shape, contact (3,), info) of the object seen from above, or None if its outline does
    not meet the ground."""
    poly_uv = outline(mask)
    flat = footprint(poly_uv, camera, base_z, 0.0)
    if flat is None:
        return None
    steep = view_depression_deg(camera, np.r_[flat.mean(0), base_z])
    if prior_shape == "ball":
        # a ball's outline is its own measure: the tangent cone fixes it, before any height is looked for
        ball = sphere_from_outline(poly_uv, camera, base_z)
        if ball is not None and 2 * ball[1] < 0.9 * (camera.origin[2] - base_z):
            centre, radius = ball
            mesh = trimesh.creation.icosphere(subdivisions=3, radius=radius)
            mesh.apply_translation([centre[0], centre[1], base_z + radius])
            contact = np.array([centre[0], centre[1], base_z])
            info = {"mode": "footprint", "shape": "sphere", "height_source": "the ball's outline (tangent cone)",
                    "circle_iou": round(circle_fit(flat)[2], 3), "view_depression_deg": round(steep, 2)}
            return (np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int32), "sphere", contact, info)
    height, source = None, None
    read = False  # whether the height was read from the photo (the sides seen), not guessed
    if flat_prior and height_hint:  # a coin's or a plate's rim hardly shows: its typical height is better
        height, source = float(height_hint), "typical size of the label (a flat thing)"
    if height is None and prior_shape in (None, "round", "any") and steep < SIDES_VISIBLE_DEG:
        height = height_from_sides(poly_uv, camera, base_z)
        if height is not None:
            fp = footprint(poly_uv, camera, base_z, height)
            if fp is None or circle_fit(fp)[2] < ROUND_IOU:  # not a cylinder after all
                height = None
        if height is not None and height_hint and not (
                1 / SIDES_PRIOR_FACTOR <= height / height_hint <= SIDES_PRIOR_FACTOR):
            # from steeply above a nearly round outline says little about the sides: a reading this far
            # from the label's typical height is the outline's noise (a sweet read as a 0.3 mm disc)
            height = None
        source = "visible sides (round outline)" if height is not None else None
        read = height is not None
    if height is None and photo is not None and steep < SIDES_VISIBLE_DEG and prior_shape not in ("round", "ball"):
        height = height_from_edge(photo, mask, camera, base_z)
        source = "visible sides (edge of the top)" if height is not None else None
        read = height is not None
    if height is None and height_hint:
        height, source = float(height_hint), "typical size of the label"
    if height is None:
        width = float(np.ptp(flat, axis=0).max())
        height, source = DEFAULT_HEIGHT_RATIO * width, f"{DEFAULT_HEIGHT_RATIO:g} × the footprint's width"
    height = min(height, 0.9 * (camera.origin[2] - base_z))
    if flat_prior and source and source.startswith("typical") and prior_shape not in ("round", "ball") \
            and kind != "organic" and steep < SIDES_VISIBLE_DEG:
        lying = lying_height(poly_uv, camera, base_z, height)
        if lying is not None:
            height, source = lying, "the outline (the flat thing lies on its broadest face)"
    fp = footprint(poly_uv, camera, base_z, height)
    cut = False
    if not read and base_z > 0:
        # On another's top only, an open trade-off: on the ground a guess the outline cannot hold falls back to
        # the outline's slab, which reaches its foot back to its corners and stands. Measured on one box seen
        # from 44° on the ground (587774/038 box_0), the slab against the cut: photo IoU on the cut masks 1.00
        # against 0.69, but the bare mesh's IoU with the true one 0.35 against 0.46 and its shape seen from
        # ±45° 0.57 against 0.82. The slab keeps the photo and loses the shape; one scene does not settle it.
        kept, kept_fp = held_height(poly_uv, camera, base_z, height, flat)
        if kept < height:
            height, fp, cut = kept, kept_fp, True
            source = f"{source}, cut to where its footprint keeps {HELD_SHARE:g} of the outline's cast"
    if fp is None or len(fp) < 3:
        return None
    centre, radius, iou = circle_fit(fp)
    # a box's label or a cut height keeps a prism: a turned rectangle's footprint cut from its cast is a hexagon
    # or an octagon, round enough to pass for a cylinder
    round_ok = iou >= ROUND_IOU and kind != "boxy" and not cut
    if prior_shape == "ball" or (prior_shape in (None, "any") and round_ok
                                 and abs(height - 2 * radius) < 0.25 * 2 * radius):
        shape = "sphere"
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=radius)
        mesh.apply_translation([centre[0], centre[1], base_z + radius])
        height = 2 * radius
    elif round_ok or prior_shape == "round":
        shape = "disc" if height < 0.5 * radius else "cylinder"
        mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
        mesh.apply_translation([centre[0], centre[1], base_z + 0.5 * height])
    elif kind == "organic" and not flat_prior and (dome := inflated_footprint(fp, base_z, height)) is not None:
        shape = "inflated"
        mesh = trimesh.Trimesh(*dome, process=False)
    else:
        (_, _), (a, b), _ = cv2.minAreaRect(fp.astype(np.float32))
        shape = "plate" if height <= PLATE_RATIO * min(a, b) else "prism"
        hull = cv2.convexHull(fp.astype(np.float32))[:, 0, :].astype(float)
        pts = np.vstack([np.c_[hull, np.full(len(hull), base_z)], np.c_[hull, np.full(len(hull), base_z + height)]])
        mesh = trimesh.convex.convex_hull(pts)
    verts, faces = fine_faces(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64), camera)
    # the contact: the footprint's point nearest the camera
    near = fp[np.argmin(np.linalg.norm(fp - camera.origin[:2], axis=1))]
    contact = np.array([near[0], near[1], base_z])
    info = {"mode": "footprint", "shape": shape, "height_source": source, "circle_iou": round(iou, 3),
            "view_depression_deg": round(steep, 2)}
    return verts, faces, shape, contact, info


def rectangularity(points: np.ndarray) -> float:
    """How well the convex hull of ``points`` (n, 2) fills its smallest enclosing rectangle (1 for a
    rectangle, 0.5 for a triangle)."""
    p = np.asarray(points, np.float32).reshape(-1, 1, 2)
    (_, _), (a, b), _ = cv2.minAreaRect(p)
    return float(cv2.contourArea(cv2.convexHull(p))) / max(float(a * b), 1e-18)


def upright_plate(vertices: np.ndarray, camera, plane=None, thickness: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """A plate lifted lying (``vertices``, held in the air by nothing the masks show) stood upright instead,
    or None where lying reads its outline as well.

    A card pinned to a wall, a photo or a sign held up is a rectangle standing in a vertical plane: its
    outline cast onto the ground is a trapezoid (its sides, upright, fan out from below the camera), cast onto
    its own plane a rectangle; one lying on a shelf the other way round. Cast onto any vertical plane its
    upright sides stay upright, and turning the plane about the vertical through it brings its top and
    bottom parallel: so the outline is read on the vertical planes through the lying plate's middle turned up
    to :data:`UPRIGHT_TURN_DEG` from facing the camera, and it stands on the best when that is more nearly a
    rectangle, by :data:`UPRIGHT_MARGIN`, than lying, and a rectangle to :data:`UPRIGHT_FILL`; its thickness
    is kept. Seen nearly edge-on (less than :data:`UPRIGHT_MIN_DEPRESSION_DEG` below the horizontal) or
    fewer than :data:`UPRIGHT_MIN_ROWS` pixels tall, the lying fill is too coarse to doubt, and it lies.
    Casting along the rays, the outline's shape on a plane does not depend on the plane's distance: whether
    it stands is decided before how far it is.

    With ``plane`` (point, normal: a wall found behind it) the outline is cast onto that plane whatever it
    reads, its back on the wall, ``thickness`` thick (the lying plate's, where ``vertices`` already stand)."""
    v = np.asarray(vertices, float)
    thickness = float(np.ptp(v[:, 2])) if thickness is None else float(thickness)
    uv, depth = camera.project(v)
    if np.any(depth <= 0):
        return None
    hull = cv2.convexHull(uv.astype(np.float32))[:, 0, :].astype(float)
    d = camera.rays(hull[:, 0], hull[:, 1])
    if plane is not None:
        point, normal = np.asarray(plane[0], float), np.r_[np.asarray(plane[1], float)[:2], 0.0]
        if np.linalg.norm(normal) < 1e-9:
            return None
        normal = normal / np.linalg.norm(normal)
        along = d @ normal
        if np.any(along <= 1e-6):
            return None
        return _slab(_on_plane(camera, d, along, point, normal), normal, thickness, camera)
    lying = rectangularity(v[:, :2])
    point = 0.5 * (v.min(0) + v.max(0))
    facing = point - camera.origin
    facing[2] = 0.0
    if np.linalg.norm(facing) < 1e-9:  # straight down on it: no plane stands facing the camera
        return None
    # how steeply the photo sees it: the ray through its outline's middle in the image (the lying plate's own
    # middle lies along the far, stretched end)
    mid = camera.rays(np.array([0.5 * (hull[:, 0].min() + hull[:, 0].max())]),
                      np.array([0.5 * (hull[:, 1].min() + hull[:, 1].max())]))[0]
    if (math.degrees(math.atan2(-float(mid[2]), float(np.linalg.norm(mid[:2])))) < UPRIGHT_MIN_DEPRESSION_DEG
            or float(np.ptp(uv[:, 1])) < UPRIGHT_MIN_ROWS):
        return None
    turns = np.arange(-UPRIGHT_TURN_DEG, UPRIGHT_TURN_DEG + 1e-9, UPRIGHT_TURN_STEP_DEG)
    lying_long = float(np.max(np.ptp(v[:, :2], axis=0)))
    graze = math.cos(math.radians(UPRIGHT_MAX_GRAZE_DEG))
    reads = []
    for a in turns:
        r = math.radians(a)
        normal = np.array([math.cos(r) * facing[0] - math.sin(r) * facing[1],
                           math.sin(r) * facing[0] + math.cos(r) * facing[1], 0.0])
        normal = normal / np.linalg.norm(normal)
        along = d @ normal
        if np.any(along <= graze * np.linalg.norm(d, axis=1)):
            continue
        on = _on_plane(camera, d, along, point, normal)
        side = np.array([-normal[1], normal[0], 0.0])
        flat = np.c_[on @ side, on[:, 2]]
        if float(np.ptp(flat[:, 0])) > UPRIGHT_MAX_GROW * lying_long:
            continue
        reads.append((rectangularity(flat), float(a), on, normal))
    if not reads:
        return None
    top = max(r[0] for r in reads)
    near = [r for r in reads if r[0] >= top - UPRIGHT_TURN_TIE]
    middle = float(np.median([r[1] for r in near]))
    best = min(near, key=lambda r: (abs(r[1] - middle), abs(r[1])))
    if best[0] < max(lying + UPRIGHT_MARGIN, UPRIGHT_FILL):
        return None
    _, _, on, normal = best
    # held up by nothing seen, the plane is its middle
    return _slab(on + 0.5 * thickness * normal, normal, thickness, camera)


def _on_plane(camera, d: np.ndarray, along: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Where the rays ``d`` (n, 3) from the camera meet the plane through ``point`` with ``normal`` (``along``:
    ``d @ normal``, each positive)."""
    return camera.origin + ((point - camera.origin) @ normal / along)[:, None] * d


def _slab(back: np.ndarray, normal: np.ndarray, thickness: float, camera) -> tuple[np.ndarray, np.ndarray]:
    """The plate whose back face is the outline ``back`` and front ``thickness`` towards ``normal``'s
    opposite (the camera's side)."""
    pts = np.vstack([back, back - thickness * normal])
    mesh = trimesh.convex.convex_hull(pts)
    return fine_faces(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64), camera)
