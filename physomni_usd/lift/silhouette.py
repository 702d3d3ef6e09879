"""Lifting an object's silhouette into a closed, watertight triangle mesh.

The built-in lifter needs no model. Seen steeply from above (every ray
through the silhouette at least ``FOOTPRINT_MIN_DEG`` below the horizontal,
or a thing the size table says lies flat from ``FLAT_FOOTPRINT_MIN_DEG``),
the silhouette is a footprint: see ``footprint.py``. Seen from the side, it
assumes the object stands on the ground facing the camera:

1. The object's foot is the bottom of its silhouette; the camera ray through
   it meets the ground at the contact point.
2. Each sampled image row of the silhouette is cast onto the vertical plane
   through the object (facing the camera), which gives the row's height and
   metric width: the scale at which the silhouette matches the photo.
3. Each row becomes a cross-section and the sections are lofted into a tube
   with flat caps, one function per shape (the table ``SHAPES``):
   - ``round`` (outline mirror-symmetric and not ending in a straight
     bottom edge): circles, a surface of revolution whose axis follows the
     silhouette's mid-line, each touching the front plane — cups, bottles,
     on a flat base; a ball's outline (nearly a disc) about one upright axis
     through the ball's centre instead, its lowest point under it;
   - ``inflated`` (a label of a soft, rounded thing, ``sizes.body_kind``,
     whose outline is not mirror-symmetric — fruit, toys, bags): each
     point of the outline's inside bulges towards and away from the camera
     by √(2Rd − d²), d its distance to the outline and R the largest such
     distance, so a disc becomes a ball and a long outline a rounded tube
     as thick as it is high (:func:`inflated_rings`);
   - ``cuboid`` (a boxy label — boxes, books — whose top shows above its
     front side): the front side's top edge in the photo gives the height
     (``footprint.height_from_edge``), the outline's top row cast onto that
     height gives the depth, and the box has square edges;
   - ``extrude`` (otherwise): a slab of the outline whose depth is
     ``depth_ratio`` times the smaller of its width and height (no row
     deeper than it is wide: thin parts stay thin), with sides
     along the camera's rays so that it hides behind its own front —
     vehicles, furniture, and boxes whose top does not show.

Rows are spanned from the leftmost to the rightmost pixel, so concavities
(a handle's hole, the gap between wheels) are filled; the mesh's texture
carries the mask as alpha and renderers cut those pixels away.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..geometry.camera import PinholeCamera
from ..settings import BALL_SOLE, LiftSettings
from ..sizes import body_kind
from .sections import bulge, inflated_rings, loft, ray_slab_rings, round_rings, span_samples

#: How far (pixels, and as a fraction of its run) a slab's bottom edge may bend and still be one straight edge
#: running back on the ground (:func:`_foot_reaching_back`): a box's is straight to a pixel, a wheel's round
#: bottom bends by a third of its run.
SLOPE_SLACK_PX, SLOPE_SLACK = 2.0, 0.15
#: Fraction of an object's height that forms its base: a round object's flat base (balls excepted), a slab's
#: rows kept at full depth (:func:`slab_depths`) and the rows its foot is read from (:func:`_foot_reaching_back`).
BASE_BAND = 0.15
#: A bottom band of this fraction of the height, at least this fraction of the widest row wide, is flat.
FLAT_BOTTOM_BAND = 0.04
FLAT_BOTTOM_WIDTH = 0.85
#: A silhouette this close to a circle (IoU with its fitted circle) is a ball and keeps a round bottom.
BALL_IOU = 0.9

#: A cuboid needs its top to show: the front side's top edge at most this fraction of the silhouette's height,
#: and the photo's brightness across that edge changing by at least CUBOID_STEP grey levels and
#: CUBOID_STEP_NOISE times the bands' own spread (a top lit unlike the front, not a texture's grain).
CUBOID_TOP_SHOWS = 0.9
CUBOID_STEP = 10.0
CUBOID_STEP_NOISE = 1.5


@dataclass
class LiftedMesh:
    vertices: np.ndarray  # (N, 3) float64, world metres
    faces: np.ndarray  # (M, 3) int32, outward-facing
    shape: str  # a key of SHAPES standing, or what footprint.py or vessel.py made from above
    contact: np.ndarray  # (3,) where the silhouette's foot meets the ground
    foot_row: float  # image row of the foot
    info: dict = field(default_factory=dict)  # how it was lifted: mode, height source, …

    @property
    def height(self) -> float:
        return float(np.ptp(self.vertices[:, 2]))


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """Mask with every enclosed hole filled (background reachable from the border stays)."""
    m = mask.astype(np.uint8)
    padded = np.pad(m, 1)
    flood = padded.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    holes = (flood[1:-1, 1:-1] == 0)
    return mask.astype(bool) | holes


def foot_pixel(mask: np.ndarray) -> tuple[float, float]:
    """(u, v) of the object's foot: the middle of its lowest pixels, at their bottom edge."""
    rows = np.nonzero(mask.any(axis=1))[0]
    bottom = rows[-1]
    band = max(1, int(round(0.02 * (bottom - rows[0] + 1))))
    cols = np.nonzero(mask[bottom - band + 1:bottom + 1].any(axis=0))[0]
    return float(np.median(cols)) + 0.5, float(bottom + 1)


def mirror_iou(mask: np.ndarray) -> float:
    """IoU of the silhouette with its mirror image about its own vertical mid-line."""
    ys, xs = np.nonzero(mask)
    crop = mask[ys.min():ys.max() + 1, xs.min():xs.max() + 1]
    flipped = crop[:, ::-1]
    return float((crop & flipped).sum() / max(1, (crop | flipped).sum()))


def flat_bottom(mask: np.ndarray) -> bool:
    """Whether the silhouette ends in a straight bottom edge as wide as the object (a box seen front-on).

    A round object seen from above ends in the front arc of its base instead,
    whose lowest rows are much narrower than the object.
    """
    ys = np.nonzero(mask.any(axis=1))[0]
    height = ys[-1] - ys[0] + 1
    widths = mask[ys[0]:ys[-1] + 1].sum(axis=1)
    lowest = widths[-max(1, int(round(FLAT_BOTTOM_BAND * height))):]
    return lowest.min() >= FLAT_BOTTOM_WIDTH * widths.max()


def is_ball(mask: np.ndarray) -> bool:
    """Whether the silhouette is nearly a disc (IoU ≥ 0.9 with the disc of the same area and centroid)."""
    ys, xs = np.nonzero(mask)
    r = np.sqrt(len(xs) / np.pi)
    disc = (xs - xs.mean()) ** 2 + (ys - ys.mean()) ** 2 <= r * r
    inside = int(disc.sum())
    return inside / (len(xs) + (np.pi * r * r - inside)) >= BALL_IOU


def row_spans(mask: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Left and right pixel edges (len(edges), 2) of the silhouette around each sampled row.

    ``edges`` are increasing image rows (pixel edges). Each sample takes the
    widest span over the rows half-way to its neighbours, so that the lofted
    surface between two samples also covers the outline's bulges there.
    Rows without pixels take spans interpolated from their neighbours.
    """
    rows = np.nonzero(mask.any(axis=1))[0]
    left = np.array([np.argmax(mask[r]) for r in rows], float)
    right = np.array([mask.shape[1] - np.argmax(mask[r, ::-1]) for r in rows], float)
    every = np.arange(rows[0], rows[-1] + 1)
    left, right = np.interp(every, rows, left), np.interp(every, rows, right)
    out = np.empty((len(edges), 2))
    for k in range(len(edges)):
        lo = 0.5 * (edges[max(k - 1, 0)] + edges[k])
        hi = 0.5 * (edges[min(k + 1, len(edges) - 1)] + edges[k])
        sel = (every + 1 > lo) & (every < hi)
        if not sel.any():
            sel = every == np.clip(int(edges[k]), rows[0], rows[-1])
        out[k] = left[sel].min(), right[sel].max()
    return out


def _edge_is_a_step(photo, solid, camera, edge_point, band: int = 4) -> bool:
    """Whether the photo's brightness steps across the image row where ``edge_point`` (3,) projects, inside the
    middle of the silhouette: the front side below and the top above are lit differently."""
    gray = cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY).astype(float) if photo.ndim == 3 else photo.astype(float)
    uv, _ = camera.project(np.asarray(edge_point, float)[None])
    row = int(round(float(uv[0, 1])))
    ys, xs = np.nonzero(solid)
    x0, x1 = (int(x) for x in np.percentile(xs, [30, 70]))
    if row - band < ys.min() or row + band > ys.max() or x1 <= x0:
        return False
    above = gray[row - band:row - 1, x0:x1 + 1][solid[row - band:row - 1, x0:x1 + 1]]
    below = gray[row + 2:row + band + 1, x0:x1 + 1][solid[row + 2:row + band + 1, x0:x1 + 1]]
    if len(above) < 4 or len(below) < 4:
        return False
    step = abs(float(above.mean()) - float(below.mean()))
    spread = math.sqrt(0.5 * (float(above.var()) + float(below.var())))
    return step >= max(CUBOID_STEP, CUBOID_STEP_NOISE * spread)


def cuboid_from_faces(solid, camera, photo, left, right, z, contact, normal, tangent, base_z):
    """(vertices, faces, info) of a box whose front side and top the photo shows, or None where it does not.

    ``left``/``right`` (K, 3) are the silhouette's rows cast onto the front plane, ``z`` their heights.
    """
    from .footprint import fine_faces, height_from_edge

    height = height_from_edge(photo, solid, camera, base_z)
    if height is None or height > CUBOID_TOP_SHOWS * float(z.max() - base_z):
        return None
    ys, xs = np.nonzero(solid)
    top = ys.min()
    cols = xs[ys == top]
    back = plane_points(camera, float(np.median(cols)) + 0.5, float(top), base_z + height)
    depth = float((back - contact) @ normal) if np.all(np.isfinite(back)) else -1.0
    front = z <= base_z + height + 1e-9
    if depth <= 0 or not front.any():
        return None
    if not _edge_is_a_step(photo, solid, camera, contact + [0.0, 0.0, height]):
        return None
    lo = float(((left[front] - contact) @ tangent).min())
    hi = float(((right[front] - contact) @ tangent).max())
    corners = [contact + a * tangent + b * normal + c * np.array([0.0, 0.0, 1.0])
               for a in (lo, hi) for b in (0.0, depth) for c in (0.0, height)]
    corners = np.asarray(corners)
    corners[:, 2] = np.where(corners[:, 2] > base_z + 0.5 * height, base_z + height, base_z)
    import trimesh

    box = trimesh.convex.convex_hull(corners)
    verts, faces = fine_faces(np.asarray(box.vertices, float), np.asarray(box.faces, np.int64), camera)
    return verts, faces, {"height_m": round(height, 5), "depth_m": round(depth, 5),
                          "height_source": "visible sides (edge of the top)"}


#: Where every ray through the silhouette looks down at least this steeply (degrees), it is a footprint.
FOOTPRINT_MIN_DEG = 20.0
#: ... or, when the camera itself looks down at least FOOTPRINT_MIN_DEG, where its foot is seen this
#: steeply and its top at least FLAT_FOOTPRINT_MIN_DEG.
FOOTPRINT_FOOT_DEG = 25.0
#: Things whose typical height is at most this fraction of their length lie flat: from this steep already.
FLAT_PRIOR_RATIO = 0.3
FLAT_FOOTPRINT_MIN_DEG = 8.0


def lift_mode(solid: np.ndarray, camera: PinholeCamera, settings: LiftSettings, flat: bool = False) -> str:
    """'footprint' where every ray through the silhouette looks down steeply (or, for a thing that lies
    ``flat``, somewhat; or the foot steeply and the top somewhat), else 'standing'. ``--shape round|extrude``
    lifts standing wherever the view can show the object standing (:meth:`StandingRows.holds`)."""
    if settings.shape != "auto":
        return "standing"
    ys, xs = np.nonzero(solid)
    top, bottom = ys.min(), ys.max()

    def steep(row):
        d = camera.rays(float(np.median(xs[ys == row])) + 0.5, float(row))
        return float(np.degrees(np.arcsin(np.clip(-d[2], -1.0, 1.0))))

    top_deg, foot_deg = steep(top), steep(bottom)
    if top_deg >= (FLAT_FOOTPRINT_MIN_DEG if flat else FOOTPRINT_MIN_DEG):
        return "footprint"
    return "footprint" if (camera.pitch_deg >= FOOTPRINT_MIN_DEG and foot_deg >= FOOTPRINT_FOOT_DEG
                           and top_deg >= FLAT_FOOTPRINT_MIN_DEG) else "standing"


def plane_points(camera: PinholeCamera, u, v, z: float = 0.0) -> np.ndarray:
    """Where the rays through (u, v) meet the horizontal plane at height ``z`` (…, 3); NaN where they do not."""
    d = camera.rays(u, v)
    dz = d[..., 2]
    t = np.where(dz < -1e-9, (z - camera.origin[2]) / np.minimum(dz, -1e-9), np.nan)
    t = np.where(t > 0, t, np.nan)
    return camera.origin + t[..., None] * d


def lift_silhouette(mask: np.ndarray, camera: PinholeCamera, settings: LiftSettings = LiftSettings(),
                    height_hint: float | None = None, prior_shape: str | None = None,
                    base_z: float = 0.0, flat: bool = False, photo: np.ndarray | None = None,
                    label: str | None = None) -> LiftedMesh:
    """Closed mesh of the object whose silhouette is ``mask`` (H, W) bool, standing on z = ``base_z``.

    ``height_hint`` (the camera's units) and ``prior_shape`` come from the
    label's typical size; they are used where the photo cannot show a height.
    ``flat``: the label's thing lies flat (a coin, a pencil), so a footprint
    from any view steeper than ``FLAT_FOOTPRINT_MIN_DEG``. ``photo`` (H, W, 3)
    lets a footprint take its height from the edges of its visible sides.
    ``label`` chooses the body (``sizes.body_kind``): inflated for organic
    things, a cuboid for boxy ones, from above a hollow vessel for open containers (``vessel.py``).
    Where the body the label asks for cannot be made (an inflated body with no patch of itself to stand on),
    the outline alone decides, as for an unknown label.
    """
    solid = fill_holes(mask)
    seen = Silhouette(solid, lift_mode(solid, camera, settings, flat), camera, settings, height_hint, prior_shape,
                      base_z, flat, photo)
    kind = body_kind(label) if label else None
    lifted = None
    for body in dict.fromkeys((kind, None)):  # the label's body, then the outline alone
        for lift in LIFTS[seen.mode]:
            lifted = lift(seen, body)
            if lifted is not None:
                return lifted
    return lifted


@dataclass
class Silhouette:
    """What a silhouette is lifted from: its hole-filled mask ``solid`` (H, W) bool, how it is seen (``mode``:
    'footprint' or 'standing', :func:`lift_mode`), and :func:`lift_silhouette`'s camera and hints."""
    solid: np.ndarray
    mode: str
    camera: PinholeCamera
    settings: LiftSettings
    height_hint: float | None
    prior_shape: str | None
    base_z: float
    flat: bool
    photo: np.ndarray | None
    _rows: "StandingRows | None" = field(default=None, repr=False)

    def rows(self) -> "StandingRows":
        """The silhouette's rows cast as standing (:meth:`StandingRows.cast`), once."""
        if self._rows is None:
            self._rows = StandingRows.cast(self.solid, self.camera, self.settings, self.base_z, self.photo)
        return self._rows


def vessel_from_above(seen: Silhouette, kind: str | None) -> LiftedMesh | None:
    """An open container seen from above (``vessel.py``): a hollow body with a rim; None where the label is no
    vessel's or the outline shows no rim."""
    if kind != "vessel":
        return None
    from .footprint import fine_faces, outline
    from .vessel import lift_vessel

    solid, camera, base_z = seen.solid, seen.camera, seen.base_z
    found = lift_vessel(solid, outline(solid), camera, base_z)
    if found is None:
        return None
    mesh, info = found
    verts, faces = fine_faces(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64), camera)
    base = verts[verts[:, 2] <= base_z + 1e-9, :2]  # the contact: the base's point nearest the camera
    contact = np.r_[base[np.argmin(np.linalg.norm(base - camera.origin[:2], axis=1))], base_z]
    return LiftedMesh(verts, faces, "vessel", contact, foot_pixel(solid)[1], {"mode": "footprint", "shape": "vessel"} | info)


def footprint_from_above(seen: Silhouette, kind: str | None) -> LiftedMesh | None:
    """The footprint extruded to its height (``footprint.py``); None where it cannot be."""
    from .footprint import lift_footprint

    found = lift_footprint(seen.solid, seen.camera, seen.height_hint, seen.prior_shape, seen.base_z,
                           photo=seen.photo, flat_prior=seen.flat, kind=kind)
    if found is None:
        return None
    verts, faces, shape, contact, info = found
    return LiftedMesh(verts, faces, shape, contact, foot_pixel(seen.solid)[1], info)


def standing(seen: Silhouette, kind: str | None) -> LiftedMesh | None:
    """The silhouette standing on the ground, lifted as the shape :func:`standing_shape` picks from :data:`SHAPES`;
    None where the view cannot show it standing (:meth:`StandingRows.holds`)."""
    rows = seen.rows()
    if not rows.holds():
        return None
    return SHAPES[standing_shape(seen.solid, seen.settings, kind, seen.photo)](rows)


def from_above_where_it_cannot_stand(seen: Silhouette, kind: str | None) -> LiftedMesh | None:
    """The footprint (:func:`footprint_from_above`) of a silhouette the view cannot show standing, even one seen
    from the side or with ``--shape`` given; None where it can (its standing lift is the one to have)."""
    return None if seen.rows().holds() else footprint_from_above(seen, kind)


def standing_as_cast(seen: Silhouette, kind: str | None) -> LiftedMesh | None:
    """The silhouette standing however the view casts it, where the view cannot show it standing and nothing else
    lifts it: the last resort."""
    rows = seen.rows()
    if rows.holds():
        return None  # :func:`standing` made it, or the shape refused the photo
    return SHAPES[standing_shape(seen.solid, seen.settings, kind, seen.photo)](rows)


#: How each mode of :func:`lift_mode` lifts a silhouette: lifters ``(Silhouette, body kind) → mesh or None``,
#: tried in turn until one makes a mesh (seen from above, what cannot be a footprint stands; seen too steeply
#: to stand, even with ``--shape`` given or from the side, it is a footprint where it can be).
LIFTS = {"footprint": (vessel_from_above, footprint_from_above, standing, standing_as_cast),
         "standing": (standing, from_above_where_it_cannot_stand, standing_as_cast)}


def standing_shape(solid: np.ndarray, settings: LiftSettings, kind: str | None, photo: np.ndarray | None) -> str:
    """The key in :data:`SHAPES` a standing silhouette is lifted as: ``--shape`` where given; else round where the
    outline is mirror-symmetric without a flat bottom, extruded otherwise, unless the label's body (``kind``)
    turns that shape into its own (:data:`BODY_SHAPES`)."""
    if settings.shape != "auto":
        return settings.shape
    shape = "round" if mirror_iou(solid) >= settings.symmetry_iou and not flat_bottom(solid) else "extrude"
    return BODY_SHAPES.get(kind, {}).get(shape, shape)


#: A standing silhouette's rows meet the plane through its foot at most this many times as far along their rays as
#: the foot's own ray (a level camera before a thing three times its height: 1.6×); farther, the rays run along the
#: plane and the cast is no measure (:meth:`StandingRows.holds`).
STANDING_REACH = 4.0


@dataclass
class StandingRows:
    """A standing silhouette's sampled rows cast onto the vertical plane through its foot, what every shape
    of :data:`SHAPES` is made from.

    The foot is the object's front edge, so rows are first cast onto the vertical plane through the contact:
    that gives each row's height ``z`` (the foot row lands exactly on z = base_z) and its metric width
    (``left``, ``right``: (K, 3) its ends). ``edges`` (K,) are the rows' image heights, ``spans`` (K, 2) their
    leftmost and rightmost pixels.
    """

    solid: np.ndarray
    camera: PinholeCamera
    settings: LiftSettings
    photo: np.ndarray | None
    base_z: float
    contact: np.ndarray
    v_foot: float
    ys: np.ndarray
    edges: np.ndarray
    spans: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    left: np.ndarray
    right: np.ndarray
    z: np.ndarray

    @property
    def k(self) -> int:
        return len(self.edges)

    @classmethod
    def cast(cls, solid, camera: PinholeCamera, settings: LiftSettings, base_z: float, photo) -> "StandingRows":
        u_foot, v_foot = foot_pixel(solid)
        contact = plane_points(camera, u_foot, v_foot, base_z)
        if not np.all(np.isfinite(contact)):
            raise ValueError("the object's foot is above the horizon")
        ys = np.nonzero(solid.any(axis=1))[0]
        top, bottom = float(ys[0]), float(ys[-1] + 1)  # pixel edges
        k = int(min(settings.rows, max(4, ys[-1] - ys[0] + 2)))
        edges = np.linspace(top, bottom, k)
        spans = row_spans(solid, edges)
        # The object's plane faces the camera's horizontal forward direction; with a camera
        # that only pitches, every pixel of an image row then lands at the same height on it.
        normal = camera.world_from_camera[:, 2].copy()
        normal[2] = 0.0
        normal /= np.linalg.norm(normal)  # horizontal, away from the camera
        tangent = np.cross(normal, [0.0, 0.0, 1.0])  # horizontal, to the image's right
        left = _on_plane(camera, normal, spans[:, 0], edges, contact)
        right = _on_plane(camera, normal, spans[:, 1], edges, contact)
        z = _on_plane(camera, normal, 0.5 * spans.sum(axis=1), edges, contact)[:, 2]
        return cls(solid, camera, settings, photo, base_z, contact, v_foot, ys, edges, spans, normal, tangent,
                   left, right, z)

    def holds(self) -> bool:
        """Whether the view can show the silhouette standing on the vertical plane through its foot: every row
        climbs the plane from the foot (none lands below the base) and meets it no farther along its ray than
        :data:`STANDING_REACH` times the foot's ray. From steeply above, the rows' rays run nearly along the
        plane and meet it metres away, above the camera or under the ground (a top-down desk's coin cast 25 m
        across); such a cast measures nothing."""
        origin, d = self.camera.origin, self.camera.rays(0.5 * self.spans.sum(axis=1), self.edges)
        along = d @ self.normal
        reach = ((self.contact - origin) @ self.normal) / np.where(np.abs(along) > 1e-12, along, np.nan)
        foot = float(np.linalg.norm(self.contact - origin))
        lengths = reach * np.linalg.norm(d, axis=-1)
        slack = 1e-6 * max(foot, 1e-9)
        return bool(np.all(np.isfinite(lengths)) and np.all(lengths > 0)
                    and lengths.max() <= STANDING_REACH * foot
                    and self.z.min() >= self.base_z - slack and np.all(np.diff(self.z) <= slack))

    def on_plane(self, u, v, point):
        """Where the rays through pixels (u, v) meet the vertical plane through ``point`` facing the camera."""
        return _on_plane(self.camera, self.normal, u, v, point)


def _on_plane(camera: PinholeCamera, normal, u, v, point):
    origin = camera.origin
    d = camera.rays(u, v)
    s = ((point - origin) @ normal) / (d @ normal)
    return origin + s[..., None] * d


def _standing_info(shape: str) -> dict:
    return {"mode": "standing", "shape": shape, "height_source": "silhouette"}


def _lofted(rows: StandingRows, rings, shape: str) -> LiftedMesh:
    verts, faces = loft(rings)
    verts[:, 2] += rows.base_z - verts[:, 2].min()  # rounding only: the foot row is already at z = base_z
    return LiftedMesh(verts, faces, shape, rows.contact, rows.v_foot, _standing_info(shape))


def round_body(rows: StandingRows) -> LiftedMesh:
    """A surface of revolution: a ball's (:func:`is_ball`) about one vertical axis (:func:`ball_body`); any other
    outline's (a cup, a bottle) each row a circle touching the front plane, its width measured where a circle is
    widest."""
    r = rows
    if is_ball(r.solid):
        ball = ball_body(r)
        if ball is not None:
            return ball
    # a circle's widest points lie one radius behind the front plane: measure the width there
    radius = 0.5 * np.linalg.norm(r.right - r.left, axis=1)
    for _ in range(2):
        behind = r.contact + radius[:, None] * r.normal
        left = np.stack([r.on_plane(r.spans[i, 0], r.edges[i], behind[i]) for i in range(r.k)])
        right = np.stack([r.on_plane(r.spans[i, 1], r.edges[i], behind[i]) for i in range(r.k)])
        radius = np.maximum(0.5 * np.linalg.norm(right - left, axis=1), 1e-4)
    # Seen from above, a round base shows as an ellipse whose lowest rows are
    # narrow; they are the base's front, not a tapering bottom. The bottom band
    # takes its widest section, so cups and bottles stand on a flat base.
    band = r.z <= r.z.min() + BASE_BAND * (r.z.max() - r.z.min())
    radius[band] = radius[band].max()
    centres = 0.5 * (left + right)
    # each circle touches the front plane with its nearest point
    centres += ((r.contact - centres) @ r.normal + radius)[:, None] * r.normal
    centres[:, 2] = r.z
    return _lofted(r, round_rings(centres, radius, r.tangent, r.normal, r.settings.sections), "round")


#: Rings that close each end of a ball (:func:`ball_body`) over the part of it no row of the photo shows.
BALL_CAP_RINGS = 4


def ball_body(rows: StandingRows) -> LiftedMesh | None:
    """A ball: circles about one vertical axis, its lowest point on that axis under its centre of mass
    (``info['rest']``; its ``contact`` stays where the outline's foot meets the ground, in front of it, and
    ``info['axis']`` is ``ball``: placing keeps its depth, as measured, and shrinks it about that axis).

    A cup's foot is its front edge, a ball's is under its middle: the ray through the outline's lowest pixel
    grazes the ball's front-underside and meets the ground ``R·tan(θ/2)`` in front of where it rests (θ that
    ray's angle below the horizontal, R its radius). Lofted against the front plane as a cup is, a ball's
    lowest point lay at its front with its centre of mass one radius behind it, and stacked on another fruit
    (no sole cut under it) it tipped backward off it (three of three generated piles, 25-29 cm).

    Seen from above, a ball's outline is the circle where the rays graze it, which lies in the plane through
    its centre facing the camera, tilted back by the view's angle: its top row is the back of a ring near
    the top, its bottom row the front of one near the bottom. So each row is cast onto that tilted plane
    and made the ring about the axis through both its ends (as wide as the row, as deep off the axis as the
    row lies), which from the camera shows the row as the photo does, no wider than the ball's sphere there
    (stretched up to the top row where that is higher). What no row shows (under the bottom row, over the top
    row) closes as that ball: to its top pole, and down to a small round sole (``BALL_SOLE``). None where the
    tilted plane does not keep the rows in order (a view it cannot hold)."""
    r = rows
    camera = r.camera
    origin = camera.origin
    # the cone of rays grazing it: its half-angle from the widest row, its axis half-way between the rays
    # through that row's ends across and the outline's top and bottom up and down
    widest = int(np.argmax(r.spans[:, 1] - r.spans[:, 0]))
    unit = lambda d: d / np.linalg.norm(d)  # noqa: E731
    ends = [unit(camera.rays(float(u), float(r.edges[widest]))) for u in r.spans[widest]]
    half_angle = 0.5 * math.acos(float(np.clip(ends[0] @ ends[1], -1.0, 1.0)))
    column = 0.5 * float(r.spans[widest].sum())
    top, bottom = (unit(camera.rays(column, float(v))) for v in (r.edges[0], r.edges[-1]))
    across, up = unit(ends[0] + ends[1]), unit(top + bottom)
    level = unit(across * np.array([1.0, 1.0, 0.0]))
    slope = up[2] / max(float(np.linalg.norm(up[:2])), 1e-12)
    axis_ray = unit(level + np.array([0.0, 0.0, slope]))
    # resting on the ground: its centre one radius above it, the radius its distance times sin(half-angle)
    dip = float(axis_ray[2]) - math.sin(half_angle)
    if dip >= -1e-9:
        return None  # its bottom at or above the horizon: no ball resting on the ground shows so
    reach = (r.base_z - float(origin[2])) / dip
    centre = origin + reach * axis_ray
    radius = reach * math.sin(half_angle)
    facing = centre - origin
    facing -= (facing @ r.tangent) * r.tangent  # the plane keeps the image's rows level
    facing /= np.linalg.norm(facing)
    left = _on_plane(camera, facing, r.spans[:, 0], r.edges, centre)
    right = _on_plane(camera, facing, r.spans[:, 1], r.edges, centre)
    middle = 0.5 * (left + right)
    z = middle[:, 2]
    if not np.all(np.isfinite(middle)) or np.any(np.diff(z) >= 0.0):
        return None
    half = 0.5 * np.linalg.norm(right - left, axis=1)
    # one axis for every ring, where the rows' middles lie on the whole (weighted by each ring's area)
    across = (middle - centre) @ r.tangent
    axis = centre + float(np.average(across, weights=half ** 2 + 1e-12)) * r.tangent
    deep = (middle - axis) @ r.normal
    rings_r = np.sqrt(half ** 2 + deep ** 2)
    # The ball is the sphere of the cone, resting on the ground, stretched up only as far as the outline's top
    # row reaches: each row's ring is no wider than that ball's at its height, to a pixel (a row takes the
    # widest span of the rows half-way to its neighbours, so the bottom row's ring was 15 mm across where a
    # sphere's is 1 mm, and the ball stood on a flat foot), and what no row shows closes as the ball to its poles.
    tall = max(radius, 0.5 * (float(z[0]) - r.base_z))
    middle_z = r.base_z + tall
    polar = np.arccos(np.clip((z - middle_z) / tall, -1.0, 1.0))  # 0 at the top pole, π at the bottom one
    # it rests on a small round sole, the ball cut BALL_SOLE of its radius over its lowest point (on its pole
    # alone its hull, which a ball something rests on collides as, rocked on the pole's small facets)
    sole = math.acos(min(BALL_SOLE * radius / tall, 1.0) - 1.0)
    seen = (polar > 1e-6) & (polar < sole)
    if seen.sum() < 2:
        return None
    z, polar = z[seen], polar[seen]
    pixel = 2.0 * radius / max(float(np.ptp(r.spans[widest])), 1.0)  # a pixel at the ball, in metres
    rings_r = np.minimum(rings_r[seen], radius * np.sin(polar) + 0.5 * pixel)
    steps = np.arange(1, BALL_CAP_RINGS + 1) / (BALL_CAP_RINGS + 1)
    # each end's rings shrink as the ball's towards its pole, from the end row's (narrower where it is)
    top_polar = polar[0] * (1.0 - steps)
    bottom_polar = sole - (sole - polar[-1]) * (1.0 - np.r_[steps, 1.0])
    heights = np.r_[middle_z + tall * np.cos(top_polar[::-1]), z, middle_z + tall * np.cos(bottom_polar)]
    radii = np.r_[rings_r[0] * np.sin(top_polar[::-1]) / np.sin(polar[0]), rings_r,
                  rings_r[-1] * np.sin(bottom_polar) / np.sin(polar[-1])]
    heights[-1] = r.base_z  # the sole's rim brought down onto the ground
    centres = np.repeat(axis[None], len(heights), axis=0)
    centres[:, 2] = heights
    verts, faces = loft(round_rings(centres, np.maximum(radii, 1e-5), r.tangent, r.normal, r.settings.sections))
    verts[-2] = np.r_[axis[:2], middle_z + tall]  # the top's fan closes on its pole, not a flat disc
    # its contact stays the outline's foot on the ground (what placing reads), ahead of where it rests
    lifted = LiftedMesh(verts, faces, "round", r.contact, r.v_foot, _standing_info("round"))
    lifted.info["axis"] = "ball"
    lifted.info["rest"] = [round(float(x), 5) for x in (*axis[:2], r.base_z)]
    return lifted


def slab_depths(widths: np.ndarray, z: np.ndarray, ratio: float) -> np.ndarray:
    """(K,) metres: how deep each row of a thinned slab is, rows ``widths`` (K,) metres wide at heights ``z``
    (K,). The slab is ``ratio`` times the smaller of the outline's width and height deep, and no row deeper
    than it is wide: a row whose whole span is narrow (a mirror's stalk, an antenna, a handle's end) stays thin
    rather than a wall as deep as the body, which a turned object shows as a long strip of its rim. The rows
    of the bottom band (:data:`BASE_BAND` of the height) keep the slab's full depth, so that it stands on the
    base it stood on, however narrow its foot (a body deep above a thin foot would otherwise tip over it)."""
    height = float(z.max() - z.min())
    depth = ratio * min(float(widths.max()), height or float(widths.max()))
    rows = np.minimum(widths, depth)
    band = z <= z.min() + BASE_BAND * height
    rows[band] = depth
    return rows


def _foot_reaching_back(r: StandingRows, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, 3) each: the directions in which the slab's rows run back from their left and right ends.

    A row's sides follow its own rays, except the foot's where the bottom band's outline slopes out from the
    foot to a corner (a box turned to the camera: its bottom edges run back in depth). Those pixels show the
    ground, so that side's corner pixel is cast along its own ray onto the ground (z = base_z) and the foot
    runs back from its front end to that corner, pushed straight back to the slab's back: the slab stands on a
    foot reaching behind its front face to its true corners. Cast as they show, the slab stood on its lowest
    corner only, its centre beyond it, and toppled off the box under it (a box of three falling 37 cm). The
    foot's side stays behind the bottom edge (the line to the corner), so the photo's view keeps its outline
    and nothing fills the wedge in front of the box's sides. A side is left as cast where its band's ends do
    not run straight out from the foot to the corner (:data:`SLOPE_SLACK`: a stem with a leaf, a pole on a
    base, a wheel: no sloping edge)."""
    dirs = [r.camera.rays(r.spans[:, 0], r.edges), r.camera.rays(r.spans[:, 1], r.edges)]
    band = np.nonzero(r.z <= r.z.min() + BASE_BAND * (r.z.max() - r.z.min()))[0]
    foot = int(band.max())  # rows run top to bottom: the band's last row is the foot's
    # the band's pixel rows, each one's ends: the sampled rows are too coarse to tell an edge from a leaf
    rows = np.arange(max(int(np.floor(r.edges[band.min()])), int(r.ys[0])), int(r.ys[-1]) + 1)
    rows = rows[r.solid[rows].any(axis=1)]
    if len(rows) < 2:  # a band under two pixel rows (a thin outline seen steeply): no edge to read a slope from
        return dirs[0], dirs[1]
    width = r.solid.shape[1]
    ends = np.stack([np.argmax(r.solid[rows], axis=1), width - np.argmax(r.solid[rows, ::-1], axis=1)], axis=1)
    for side, (front, outward) in enumerate(((r.left, -1.0), (r.right, 1.0))):
        out = outward * ends[:, side].astype(float)
        # the lowest pixel row reaching furthest out (an edge a pixel off the side's is still the side)
        corner = int(np.nonzero(out >= out.max() - SLOPE_SLACK_PX)[0].max())
        run = out[corner:]
        if len(run) < 2 or run[0] <= run[-1]:
            continue
        # a sloping edge: straight from the corner down to the foot (a leaf or a wheel's round bottom bends)
        line = np.linspace(run[0], run[-1], len(run))
        if np.abs(run - line).max() > max(SLOPE_SLACK_PX, SLOPE_SLACK * (run[0] - run[-1])):
            continue
        ground = plane_points(r.camera, float(ends[corner, side]), float(rows[corner]) + 0.5, r.base_z)
        reach = (ground - r.contact) @ r.normal
        if not (np.all(np.isfinite(ground)) and reach > 0.0):
            continue
        # a corner deeper than the slab: the foot runs part of the way along its bottom edge
        back = ground + max(depth - reach, 0.0) * r.normal
        way = back - front[foot]
        way[2] = 0.0
        dirs[side][foot] = way
    return dirs[0], dirs[1]


def extruded_body(rows: StandingRows) -> LiftedMesh:
    """A slab of the outline, ``depth_ratio`` times the smaller of its width and height deep and no row deeper
    than it is wide (:func:`slab_depths`), its sides along the camera's rays.

    The thinned slab is kept only where it is no worse than the full one (every row as deep as the body) on
    what the build judges (:func:`_keeps_thinned`); otherwise the full slab is: a short slanted outline (a kiwi
    at the frame's edge) thinned is judged too thin along the slab's depth against its extent along the slab's
    axes; a narrow post with a wide arm to one side (a gallows, a signpost) thinned below the arm carries its
    weight toward the arm, off its foot, and tips over where the full slab stood."""
    r = rows
    widths = np.linalg.norm(r.right - r.left, axis=1)
    thinned = slab_depths(widths, r.z, r.settings.depth_ratio)
    dir_left, dir_right = _foot_reaching_back(r, float(thinned.max()))

    def slab(depth):
        return _lofted(r, ray_slab_rings(r.left, r.right, dir_left, dir_right, r.normal, depth, r.settings.sections),
                       "extrude")

    full = slab(float(thinned.max()))
    if np.all(thinned == thinned.max()):  # no row narrower than the slab is deep: nothing to thin
        return full
    thin = slab(thinned)
    return thin if _keeps_thinned(thin, full, r) else full


def _keeps_thinned(thin: LiftedMesh, full: LiftedMesh, rows: StandingRows) -> bool:
    """Whether a thinned slab ``thin`` may stand for the full slab ``full``: it stands (:func:`stands`) wherever
    the full one does, and it is as thick as ``metrics.geometry.thin_side`` asks of a thing whose label says
    nothing (a third of its outline's smaller side; a ball's label asks more, a flat one nothing), both by its
    least width over every direction and by its extents along the slab's axes (a build's later poses can make
    the first find either)."""
    from ..metrics.geometry import THIN_FRACTION, THIN_SLACK, thin_side

    if not stands(thin.vertices, thin.faces) and stands(full.vertices, full.faces):
        return False
    v = thin.vertices
    if thin_side(v, "", rows.camera.origin) is not None:
        return False
    extents = np.sort([np.ptp(v @ axis) for axis in (rows.tangent, rows.normal, np.array([0.0, 0.0, 1.0]))])
    return bool(extents[0] >= THIN_FRACTION * THIN_SLACK * extents[1])


def inflated_body(rows: StandingRows) -> LiftedMesh | None:
    """The outline's inside bulging towards and away from the camera, resting on a flat patch of itself; None
    where no such patch holds its weight (the photo's rest then says it is not this body)."""
    r = rows
    solid, camera = r.solid, r.camera
    dist = cv2.distanceTransform(solid.astype(np.uint8), cv2.DIST_L2, 5)
    big = float(dist.max())
    rows_px = np.clip(r.edges.astype(int), r.ys[0], r.ys[-1])
    per_px = np.linalg.norm(r.right - r.left, axis=1) / np.maximum(r.spans[:, 1] - r.spans[:, 0], 1e-9)
    # the outline is widest half-way through the body: cast it onto the plane that far behind the front
    middle_at = r.contact + big * float(np.median(per_px)) * r.normal
    cols = span_samples(r.spans[:, 0], r.spans[:, 1], r.settings.sections // 2 + 1)
    middle = r.on_plane(cols, np.broadcast_to(r.edges[:, None], cols.shape), middle_at)
    per_px = np.linalg.norm(middle[:, -1] - middle[:, 0], axis=1) / np.maximum(r.spans[:, 1] - r.spans[:, 0], 1e-9)
    inside = dist[rows_px[:, None], np.clip(cols.astype(int), 0, solid.shape[1] - 1)]
    along = camera.rays(cols, np.broadcast_to(r.edges[:, None], cols.shape))
    along = along / (along @ r.normal)[..., None]  # one metre of depth along each pixel's own ray
    verts, faces = loft(inflated_rings(middle, big * bulge(inside, big) * per_px[:, None], along))
    # its back bulges below the ground along the foot's rays: shrink it towards the camera until it rests
    # there, which leaves every vertex where the photo shows it
    origin = camera.origin
    k = (origin[2] - r.base_z) / (origin[2] - verts[:, 2].min())
    verts = origin + k * (verts - origin)
    contact = origin + k * (r.contact - origin)
    verts[:, 2] += r.base_z - verts[:, 2].min()  # rounding only
    # A soft body at rest sits on a patch of itself, not on a point: without one it rolls away from where
    # the photo shows it still. Its lowest band comes down onto the ground; where no such patch holds its
    # weight, the photo's rest says it is not this body.
    for band in SOFT_BASE_BANDS:
        based = flat_base(verts, band)
        if stands(based, faces):
            return LiftedMesh(based, faces, "inflated", contact, r.v_foot, _standing_info("inflated"))
    return None


def cuboid_body(rows: StandingRows) -> LiftedMesh | None:
    """A box with square edges, its height from the front side's top edge in the photo; the slab of the
    outline where the top does not show."""
    r = rows
    if r.photo is None:  # no photo to find the top's edge in: the outline decides
        return None
    box = cuboid_from_faces(r.solid, r.camera, r.photo, r.left, r.right, r.z, r.contact, r.normal, r.tangent,
                            r.base_z)
    if box is None:
        return extruded_body(r)
    return LiftedMesh(box[0], box[1], "cuboid", r.contact, r.v_foot, _standing_info("cuboid") | box[2])


#: How a standing silhouette becomes each shape: one function per shape, :class:`StandingRows` → mesh, or None
#: where the photo says the object is not that body. :func:`standing_shape` picks the key.
SHAPES = {"round": round_body, "extrude": extruded_body, "inflated": inflated_body, "cuboid": cuboid_body}
#: The shape a label's body (``sizes.body_kind``) makes of a standing silhouette in place of the outline's:
#: organic things bulge where the outline would be a slab (a round outline stays round); boxy things keep square
#: edges whatever their outline (a box seen corner-on from above is a mirror-symmetric hexagon).
BODY_SHAPES = {"organic": {"extrude": "inflated"}, "boxy": {"round": "cuboid", "extrude": "cuboid"}}


#: The shares of an inflated body's height that may rest flat on the ground (:func:`flat_base`), tried in
#: turn: the thinnest patch that holds the body's weight is taken.
SOFT_BASE_BANDS = (0.1,)


def flat_base(verts: np.ndarray, band: float) -> np.ndarray:
    """``verts`` (N, 3) metres, z up, with every vertex lower than ``band`` of the height above the lowest
    brought down to the lowest: a flat patch to rest on. Nothing else moves."""
    out = verts.copy()
    z0 = out[:, 2].min()
    out[out[:, 2] < z0 + band * float(np.ptp(out[:, 2])), 2] = z0
    return out


def stands(verts: np.ndarray, faces: np.ndarray) -> bool:
    """Whether the closed mesh (``verts`` (N, 3) metres, z up, ``faces`` (M, 3)) can stand still on the ground
    its lowest points rest on: its centre of mass lies over the convex hull of those points."""
    import trimesh
    from scipy.spatial import ConvexHull, QhullError

    z = verts[:, 2]
    low = verts[z <= z.min() + 1e-6 * max(float(np.ptp(z)), 1e-9), :2]
    mesh = trimesh.Trimesh(verts, faces, process=False)
    centre = (mesh.center_mass if mesh.is_volume else verts.mean(0))[:2]
    try:
        hull = ConvexHull(low)
    except (QhullError, ValueError):  # one point or a line: nothing that holds it
        return False
    return bool(np.all(hull.equations[:, :2] @ centre + hull.equations[:, 2] <= 0.0))
