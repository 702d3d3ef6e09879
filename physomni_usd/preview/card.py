"""The opening view's card while the scene plays: the first frame as ``render`` draws it (the photo), opaque
wherever nothing has moved, and clear only where something has — where a moved object stood (its pixels and
the plate filled in its place), where it is now, and where its contact shadow now lies — so that the live
meshes, the plate and the shadows behind the card show there and nowhere else.

Whether a thing has moved is read from its own points against the first frame's, projected through the
photo's camera, as ``render`` decides it: it holds for any mesh the build lifted, however poorly that mesh
reproduces the photo, because an object that has not moved is shown by the photo itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..rendering.video import IN_PLACE_PX

#: Plate and photo differ by more than this (levels 0–255, any channel) where the build filled an object, and
#: the shadow it cast, out of the plate: those pixels change once the object moves.
FILLED_LEVELS = 3
#: A pixel another object shares at least this much (``texture.fill.hole_owners``: a contact shadow that object
#: casts) is cleared only once both have moved, as ``render`` shows the plate there mostly only then.
SHARED = 0.5
#: Pixels by which a hole is widened, so that the resampled edges of what moved (in the browser, and in the
#: plate's fill) never leave a fringe of the photo around it.
HOLE_MARGIN = 2
#: Ground shadow darker than this (0–1) is part of the hole it lies in.
SHADOW_SEEN = 2.0 / 255.0
#: The card is sent as square tiles of this many pixels, and only the tiles whose holes changed are sent again:
#: a whole card a frame is more than a software-rendered page decodes while it plays.
TILE = 128


@dataclass
class Mover:
    """Something the preview moves: ``start`` (N, 3) its world points at frame 0, ``faces`` (M, 3) its
    triangles (None for a particle set, drawn as discs ``radius`` metres across), and ``path``, its prim's, the
    key of the card's pixels that show it in the photo or that the plate filled in its place
    (:func:`object_regions`; None: none known)."""
    start: np.ndarray
    faces: np.ndarray | None
    path: str | None
    radius: float = 0.0


def object_regions(renderer) -> dict[str | tuple[str, str], np.ndarray]:
    """Per object prim path, the pixels of ``renderer``'s frame (a :class:`~physomni_usd.rendering.video.
    ShotRenderer` through the photo's camera) that change when that object moves: where the photo shows it
    and where its plate was filled (its own shadow among them) nearer to it than to any other object; and per
    pair of paths (owner, sharer), the filled pixels nearer the first that the second shares (a contact shadow
    it casts, :data:`SHARED`), which change only once both have moved (:func:`moved_regions`)."""
    if renderer.photo is None:
        return {}
    h, w = renderer.height, renderer.width
    filled = np.abs(renderer.plate - renderer.photo).max(axis=2) > FILLED_LEVELS
    shared = filled & (renderer.sharer >= 0) & (renderer.share >= SHARED)
    sx, sy = renderer.to_frame
    out: dict = {}
    for k, o in enumerate(renderer.objects):
        mine = renderer.owner == k
        region = filled & mine & ~shared
        for j in np.unique(renderer.sharer[shared & mine]):
            out[(o.path, renderer.objects[j].path)] = shared & mine & (renderer.sharer == j)
        if o.origin is not None:
            # the photo crop: 255 where the photo shows the object (254: what others hide, painted by build)
            a = (o.texture[:, : o.texture.shape[1] // 2 if o.two_sided else None, 3] == 255).astype(np.uint8)
            x0, y0 = o.origin
            m = np.zeros((int(round(h / sy)), int(round(w / sx))), np.uint8)
            th, tw = min(a.shape[0], m.shape[0] - y0), min(a.shape[1], m.shape[1] - x0)
            if th > 0 and tw > 0:
                m[y0:y0 + th, x0:x0 + tw] = a[:th, :tw]
                region |= cv2.resize(m, (w, h), interpolation=cv2.INTER_NEAREST) > 0
        out[o.path] = region
    return out


def moved_regions(regions: dict, moved: set[str], shape: tuple[int, int]) -> np.ndarray:
    """(h, w) bool of ``shape``: the pixels of ``regions`` (:func:`object_regions`) that have changed once the
    objects whose prim paths are ``moved`` have moved: an object's own, and a pair's once both have."""
    out = np.zeros(shape, bool)
    for key, region in regions.items():
        if (key in moved) if isinstance(key, str) else all(p in moved for p in key):
            out |= region
    return out


class OpeningCard:
    """The card's image (h, w, 3) uint8, the photo camera (``view``, ``fx``) and :meth:`rgba` for the things
    that have moved."""

    def __init__(self, image: np.ndarray, view, fx: float):
        self.image = image
        self.view, self.fx = view, fx
        self.height, self.width = image.shape[:2]
        self.scale = np.array([self.width / view.width, self.height / view.height])
        self.opaque = np.dstack([image, np.full(image.shape[:2], 255, np.uint8)])

    def tiles(self) -> list[tuple[slice, slice]]:
        """The card's tiles, (rows, columns) of its image, row by row."""
        return [(slice(y, min(y + TILE, self.height)), slice(x, min(x + TILE, self.width)))
                for y in range(0, self.height, TILE) for x in range(0, self.width, TILE)]

    def tile_place(self, tile: tuple[slice, slice], centre: np.ndarray, width: float, height: float
                   ) -> tuple[np.ndarray, float, float]:
        """Where ``tile`` lies on the card whose centre is ``centre`` (3,) and which is ``width`` × ``height``
        metres: its centre (3,) and its width and height in metres (the card's orientation is the tile's)."""
        rows, cols = tile
        mx, my = width / self.width, height / self.height  # metres per card pixel
        dx = 0.5 * (cols.start + cols.stop) - 0.5 * self.width
        dy = 0.5 * (rows.start + rows.stop) - 0.5 * self.height
        return (centre + self.view.axes[0] * dx * mx + self.view.axes[1] * dy * my,
                (cols.stop - cols.start) * mx, (rows.stop - rows.start) * my)

    def pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Card pixels (N, 2) of world points and whether each lies in front of the camera."""
        p = (np.atleast_2d(points) - self.view.position) @ self.view.axes.T
        z = p[:, 2]
        uv = p[:, :2] / np.where(z > 1e-6, z, 1.0)[:, None] * self.fx + 0.5 * np.array([self.view.width,
                                                                                        self.view.height])
        return uv * self.scale, z > 1e-6

    def moved(self, now: np.ndarray, start: np.ndarray) -> bool:
        """Whether points ``now`` have moved more than :data:`IN_PLACE_PX` card pixels from ``start``."""
        if now.shape != start.shape:
            return True
        if np.array_equal(now, start):
            return False
        a, fa = self.pixels(start)
        b, fb = self.pixels(now)
        if not (fa & fb).all():
            return True
        return bool(np.hypot(*(b - a).T).max() > IN_PLACE_PX) if len(now) else False

    def silhouette(self, hole: np.ndarray, points: np.ndarray, mover: Mover) -> None:
        """Mark on ``hole`` (h, w) uint8 where ``mover`` with world points ``points`` is seen now."""
        uv, front = self.pixels(points)
        if mover.faces is not None and len(mover.faces):
            tri = mover.faces[front[mover.faces].all(axis=1)]
            if len(tri):
                # 4 bits of sub-pixel precision: thin parts stay as thin as the browser draws them
                poly = np.round(uv[tri] * 16).astype(np.int32)
                cv2.fillPoly(hole, list(poly), 1, lineType=cv2.LINE_8, shift=4)
            return
        pts = uv[front]
        inside = (pts[:, 0] >= 0) & (pts[:, 1] >= 0) & (pts[:, 0] < self.width) & (pts[:, 1] < self.height)
        pts = pts[inside]
        if not len(pts):
            return
        depth = np.median(((points[front][inside] - self.view.position) @ self.view.axes[2]))
        r = max(1, int(round(0.5 * mover.radius * self.fx * self.scale[0] / max(depth, 1e-6))))
        dots = np.zeros_like(hole)
        dots[pts[:, 1].astype(int), pts[:, 0].astype(int)] = 1
        hole |= cv2.dilate(dots, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))

    def shadow(self, hole: np.ndarray, ground, darkening: np.ndarray, height: float) -> None:
        """Mark on ``hole`` where ``darkening`` (the ground's shadow image of :class:`~.scene.GroundShadow`
        ``ground``, lying at ``height`` metres) is seen darker than :data:`SHADOW_SEEN`."""
        ny, nx = darkening.shape
        corners = np.array([[0, 0], [nx, 0], [nx, ny], [0, ny]], np.float64)
        world = np.column_stack([ground.origin + corners * ground.step, np.full(4, height)])
        uv, front = self.pixels(world)
        seen = (darkening > SHADOW_SEEN).astype(np.uint8)
        if front.all():
            m = cv2.getPerspectiveTransform(corners.astype(np.float32), uv.astype(np.float32))
            hole |= cv2.warpPerspective(seen, m, (self.width, self.height), flags=cv2.INTER_NEAREST)
            return
        # part of the ground image lies behind the camera: its texels one by one
        rows, cols = np.nonzero(seen)
        pts = np.column_stack([ground.origin + (np.column_stack([cols, rows]) + 0.5) * ground.step,
                               np.full(len(rows), height)])
        uv, front = self.pixels(pts)
        uv = uv[front]
        ok = (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < self.width) & (uv[:, 1] < self.height)
        hole[uv[ok, 1].astype(int), uv[ok, 0].astype(int)] = 1

    def rgba(self, hole: np.ndarray) -> np.ndarray:
        """(h, w, 4) uint8: the card's image, transparent over ``hole`` widened by :data:`HOLE_MARGIN` pixels
        and softened by a pixel (the opaque card itself where ``hole`` is empty)."""
        if not hole.any():
            return self.opaque
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * HOLE_MARGIN + 1, 2 * HOLE_MARGIN + 1))
        soft = cv2.GaussianBlur(cv2.dilate(hole, k).astype(np.float32), (0, 0), 1.0)
        out = self.opaque.copy()
        out[..., 3] = np.clip(255.0 * (1.0 - soft) + 0.5, 0, 255).astype(np.uint8)
        return out
