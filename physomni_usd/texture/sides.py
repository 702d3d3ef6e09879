"""Texture for the sides of a lifted object that the photo never saw.

The photo projected from its camera textures the surfaces that face the camera
(and, mirrored, those that face away: a round or extruded lift is symmetric
front to back). Surfaces at a grazing angle to the photo's camera — an
extrusion's walls, the flanks of a turned object — would take the rim's few
pixels smeared along their whole width. They are textured instead from an opaque copy of the
object's texture whose outside is filled from its own interior, reflected
through the silhouette (never the border's pixels drawn outward), folded in
at the rim (:func:`folded_sides`): a point of a side as far behind the surface
the photo saw as it is takes the pixel that far inside the outline, at the
photo's pixel density, so that a side continues the front beside it (a
tyre's tread next to the tyre, a box's side next to its front's edge) rather
than repeating the middle of the object on every wall. Each face keeps its own
undistorted map, laid rigidly where the fold puts it (:func:`_laid`), so that a
fold deeper than the outline's curvature draws no face together; the
texture file holds [photo crop | opaque copy] side by side and ``st`` is
faceVarying (one pair per triangle corner) so that a DCC tool shows the same.
"""

from __future__ import annotations

import cv2
import numpy as np

#: Faces whose normal makes less than this cosine with the direction to the photo's camera (either way) are
#: seen edge-on: their projected texture would be the rim smeared across them, so they take the planar map.
#: (Where such a face shows in the photo, the frame shows the photo itself while the object is in place.)
EDGE_ON = 0.3
#: An edge-on face whose projection in the photo lies farther than this fraction of the crop's diagonal (and
#: at least :data:`GAP_MIN_PX`) from the object's mask is not the object's side: it bridges a gap the photo
#: shows background through (a lofted row spans a mirror and a tail with the wall between them). It keeps the
#: photo's projection, which is transparent there, instead of an opaque planar map.
GAP_FRACTION = 0.02
GAP_MIN_PX = 3.0


def _fold(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``x`` reflected back and forth into [lo, hi] (a reflection that leaves the crop comes back into it,
    where a clamp would lay every such texel on the crop's last one)."""
    period = 2.0 * (hi - lo)
    y = np.mod(x - lo, period)
    return lo + np.where(y > hi - lo, period - y, y)


def _fit_faces(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Per face, its corners' coordinates ``x`` (F, 3) moved as one into [lo, hi]: the face's centre wrapped
    into the range (a planar map wider than the texture repeats it), then the face shifted, or, larger
    than the range, shrunk about its centre, until it lies inside. Each face keeps its own shape: folding or
    clamping corners one by one would lay two corners on one texel and draw it out across the face."""
    span = hi - lo
    centre = x.mean(1, keepdims=True)
    x = x + (lo + np.mod(centre - lo, span)) - centre
    centre = x.mean(1, keepdims=True)
    extent = x.max(1, keepdims=True) - x.min(1, keepdims=True)
    x = centre + (x - centre) * np.minimum(1.0, span / np.maximum(extent, 1e-9))
    x = x + np.maximum(lo - x.min(1, keepdims=True), 0.0) - np.maximum(x.max(1, keepdims=True) - hi, 0.0)
    return x


#: How many times a texel outside the silhouette is reflected back through its nearest silhouette pixel
#: before it gives up and takes that pixel itself (a thin part, where each reflection leaves it again).
REFLECTIONS = 4


def copy_sources(mask: np.ndarray) -> np.ndarray:
    """(h, w, 2) float32: for each texel of the opaque copy of a texture whose mask is ``mask`` (h, w) bool, the
    crop pixel (x, y) its colour is taken from: itself inside the mask; outside it, the point reflected
    through the nearest pixel of the mask, into the object's own interior (again from there, up to
    :data:`REFLECTIONS` times, where a thin part lets it out on the other side). A reflection keeps the
    texture's grain and scale: no pixel of the silhouette's edge is drawn out across the fill."""
    h, w = mask.shape
    ys, xs = np.mgrid[:h, :w].astype(np.float32)
    own = np.stack([xs, ys], -1)
    if not mask.any() or mask.all():
        return own
    _, labels = cv2.distanceTransformWithLabels((~mask).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    my, mx = np.nonzero(mask)
    nearest = np.zeros((labels.max() + 1, 2), np.float32)
    nearest[labels[my, mx]] = np.stack([mx, my], -1)  # label → the mask pixel it stands for
    src = own.copy()
    todo = ~mask
    for _ in range(REFLECTIONS):
        if not todo.any():
            break
        qx = np.clip(np.rint(src[..., 0]), 0, w - 1).astype(np.int32)
        qy = np.clip(np.rint(src[..., 1]), 0, h - 1).astype(np.int32)
        n = nearest[labels[qy, qx]]
        q = 2.0 * n - src  # past the crop's edge: folded back into it, never clamped onto the edge
        q = np.stack([_fold(q[..., 0], 0.0, w - 1.0), _fold(q[..., 1], 0.0, h - 1.0)], -1)
        src = np.where(todo[..., None], q, src)
        todo &= ~mask[np.clip(np.rint(src[..., 1]), 0, h - 1).astype(np.int32),
                      np.clip(np.rint(src[..., 0]), 0, w - 1).astype(np.int32)]
    if todo.any():  # still outside: the nearest silhouette pixel of where it ended
        qx = np.clip(np.rint(src[..., 0]), 0, w - 1).astype(np.int32)
        qy = np.clip(np.rint(src[..., 1]), 0, h - 1).astype(np.int32)
        src = np.where(todo[..., None], nearest[labels[qy, qx]], src)
    return src.astype(np.float32)


def reduced_sources(mask: np.ndarray, factor: float) -> np.ndarray:
    """:func:`copy_sources` of ``mask`` (h, w) bool found on a copy ``factor`` times smaller and scaled back:
    the reflections are as wide as the object, so the smaller copy finds the same ones for a fraction of
    the work on a large photo's texture; inside the mask every texel is still its own pixel."""
    h, w = mask.shape
    sw, sh = max(2, round(w / factor)), max(2, round(h / factor))
    small = cv2.resize(mask.astype(np.uint8) * 255, (sw, sh), interpolation=cv2.INTER_AREA) >= 128
    src = cv2.resize(copy_sources(small), (w, h), interpolation=cv2.INTER_LINEAR)
    # pixel centres mapped as cv2.resize maps them
    src[..., 0] = (src[..., 0] + 0.5) * (w / sw) - 0.5
    src[..., 1] = (src[..., 1] + 0.5) * (h / sh) - 0.5
    ys, xs = np.nonzero(mask)
    src[ys, xs, 0], src[ys, xs, 1] = xs, ys
    return src


def filled_copy(rgba: np.ndarray, reduce: float = 1.0, out: np.ndarray | None = None) -> np.ndarray:
    """(h, w, 4) uint8: the texture's colours with its transparent part filled from the object's own interior
    (:func:`copy_sources`; found ``reduce`` times smaller when that is above 1, :func:`reduced_sources`),
    fully opaque; written into ``out`` (h, w, 4) uint8 when given (a part of a larger texture)."""
    mask = rgba[..., 3] >= 128
    src = copy_sources(mask) if reduce <= 1.0 else reduced_sources(mask, reduce)
    out = np.empty(rgba.shape[:2] + (4,), np.uint8) if out is None else out
    out[..., :3] = cv2.remap(np.ascontiguousarray(rgba[..., :3]), src[..., 0], src[..., 1], cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
    out[..., 3] = 255
    return out


def two_sided_texture(rgba: np.ndarray, reduce: float = 1.0) -> np.ndarray:
    """(h, 2w, 4): the photo crop on the left, :func:`filled_copy` (``reduce`` as it takes it) on the right."""
    h, w = rgba.shape[:2]
    both = np.empty((h, 2 * w, 4), np.uint8)
    both[:, :w] = rgba
    filled_copy(rgba, reduce, both[:, w:])
    return both


def _over_background(corners: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(F,) bool: whether each projected triangle's centre (``corners`` (F, 3, 2) crop pixels) lies farther
    from ``mask`` (h, w) bool than the gap threshold (:data:`GAP_FRACTION`)."""
    h, w = mask.shape
    far = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, 3)
    c = corners.mean(1)
    inside = (c[:, 0] >= 0) & (c[:, 0] <= w - 1) & (c[:, 1] >= 0) & (c[:, 1] <= h - 1)
    x = np.clip(np.rint(c[:, 0]), 0, w - 1).astype(np.int32)
    y = np.clip(np.rint(c[:, 1]), 0, h - 1).astype(np.int32)
    limit = max(GAP_MIN_PX, GAP_FRACTION * float(np.hypot(w, h)))
    return inside & (far[y, x] > limit)


def _clear_texel(mask: np.ndarray) -> tuple[int, int] | None:
    """(x, y) of a crop pixel that is transparent together with its eight neighbours (so that a renderer's
    bilinear sample there is transparent), the one farthest from ``mask`` (h, w) bool; None where there is none."""
    if mask.all() or min(mask.shape) < 3:
        return None
    far = cv2.distanceTransform(np.pad(~mask, 1, constant_values=False).astype(np.uint8), cv2.DIST_L2, 3)[1:-1, 1:-1]
    y, x = np.unravel_index(int(np.argmax(far)), far.shape)
    return (int(x), int(y)) if far[y, x] >= 2.0 else None


#: The inward direction at the rim is read off the outline's signed distance smoothed over this many pixels,
#: so that the fold follows the outline's course, not its pixel steps.
FOLD_SMOOTH = 2.0


def _inward(mask: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(n, 2) float32 unit vectors (x, y) pointing into ``mask`` (h, w) bool across its outline at the pixels
    ``at`` (n, 2: x, y, inside the mask's bounds): the gradient of its smoothed signed distance; (0, 0) where
    that is flat. Only those pixels are normalised (a 12 MP photo's crop took seconds whole)."""
    inside = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, 5)[1:-1, 1:-1]
    outside = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, 5)
    sd = cv2.GaussianBlur(inside - outside, (0, 0), FOLD_SMOOTH)
    x, y = at[:, 0], at[:, 1]
    g = np.stack([cv2.Sobel(sd, cv2.CV_32F, 1, 0, ksize=3)[y, x],
                  cv2.Sobel(sd, cv2.CV_32F, 0, 1, ksize=3)[y, x]], -1)
    norm = np.linalg.norm(g, axis=-1, keepdims=True)
    return np.where(norm > 1e-6, g / np.maximum(norm, 1e-6), 0.0).astype(np.float32)


def folded_sides(points: np.ndarray, faces: np.ndarray, px: np.ndarray, seen: np.ndarray, camera,
                 mask: np.ndarray) -> np.ndarray | None:
    """(F, 3, 2) crop pixels of the corners of the edge-on ``faces`` (F, 3) in the opaque copy: each corner, at
    ``px`` (N, 2, crop pixels of every point as the photo saw it), lies some distance behind the surface the photo
    saw there (the distance from the camera beyond the nearest corner of the ``seen`` faces (M, 3) in the image);
    it takes the pixel that many metres, at the photo's density there, inside the outline ``mask`` (h, w) bool,
    reflected back into the crop where it would leave it (the copy's outside is the interior reflected, so a
    fold past a thin part comes back into it). None where the photo saw no face of the object."""
    from scipy.spatial import cKDTree

    front = np.unique(seen)
    if not len(front) or not mask.any():
        return None
    h, w = mask.shape
    along = np.linalg.norm(points - camera.origin, axis=1)
    _, depth = camera.project(points)
    used = np.unique(faces)
    _, nearest = cKDTree(px[front]).query(px[used])
    ahead = front[nearest]
    behind = np.maximum(along[used] - along[ahead], 0.0)
    ppm = camera.focal_px / np.maximum(depth[ahead], 1e-6)
    q = px[used]
    qi = np.clip(np.rint(q), 0, [w - 1, h - 1]).astype(np.int64)
    g = _inward(mask, qi)
    flat = ~np.any(g != 0.0, axis=1)  # where the outline's distance is flat: towards its middle
    if flat.any():
        ys, xs = np.nonzero(mask)
        d = np.array([xs.mean(), ys.mean()]) - q[flat]
        g[flat] = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    to = q + g * (behind * ppm)[:, None]
    to = np.stack([_fold(to[:, 0], 0.5, w - 0.5), _fold(to[:, 1], 0.5, h - 0.5)], -1)
    where = np.zeros((len(points), 2))
    where[used] = to
    return where[faces]


def _laid(own: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(F, 3, 2): each face's corners ``own`` (F, 3, 2, its own undistorted map) moved rigidly (turned, and mirrored
    where that fits better) onto ``target`` (F, 3, 2) as closely as they go (least squares): where the fold
    draws a face together (a wall around a wheel folded deeper than the wheel's radius), the face keeps its
    size and takes the fold's place and direction."""
    x = own - own.mean(1, keepdims=True)
    y_mean = target.mean(1, keepdims=True)
    u, _, vt = np.linalg.svd(np.einsum("fki,fkj->fij", x, target - y_mean))
    return np.einsum("fki,fij->fkj", x, u @ vt) + y_mean


def corner_st(points: np.ndarray, faces: np.ndarray, camera, texture_size: tuple[int, int],
              origin: tuple[int, int], mask: np.ndarray | None = None, open_back: bool = False) -> np.ndarray:
    """(F·3, 2) faceVarying ``st`` into a :func:`two_sided_texture`, for world ``points`` (N, 3) as the photo
    saw them and triangles ``faces`` (F, 3); ``texture_size`` (w, h) of the photo crop at photo pixel
    ``origin`` (x0, y0). With the crop's ``mask`` (h, w) bool, edge-on faces that the photo shows as
    background (:data:`GAP_FRACTION`) keep the projection, transparent there; with ``open_back`` too, the
    faces turned away from the photo's camera all take a transparent texel of the crop (:func:`_clear_texel`)."""
    w, h = texture_size
    x0, y0 = origin
    uv, depth = camera.project(points)
    px = uv - np.array([x0, y0], float)  # crop pixels
    corners = px[faces]  # (F, 3, 2)
    tri = points[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    centre = tri.mean(1)
    to_cam = camera.origin - centre
    to_cam /= np.linalg.norm(to_cam, axis=1, keepdims=True)
    edge_on = np.abs(np.einsum("ij,ij->i", n, to_cam)) < EDGE_ON
    if mask is not None and edge_on.any() and mask.any():
        edge_on &= ~_over_background(corners, mask)
    st = np.empty((len(faces), 3, 2))
    st[..., 0] = corners[..., 0] / (2.0 * w)
    st[..., 1] = 1.0 - corners[..., 1] / h
    clear = _clear_texel(mask) if open_back and mask is not None else None
    if clear is not None:
        # a slab's back is its outline again one depth behind: projected, it repeats the front's picture there
        # (a second front wheel beside the first once a camera orbits); open, the orbit sees through the front's
        # cut-outs to what lies behind, and the walls along the rim close the solid
        back = np.einsum("ij,ij->i", n, to_cam) <= -EDGE_ON
        st[back, :, 0] = (clear[0] + 0.5) / (2.0 * w)
        st[back, :, 1] = 1.0 - (clear[1] + 0.5) / h
    if edge_on.any():
        # each face's own map: its horizontal and vertical directions at the object's pixel density (one texel
        # is as wide on the side as on the front: no face draws one texel out)
        ppm = float(camera.focal_px / max(np.median(depth), 1e-6))
        up = np.array([0.0, 0.0, 1.0])
        fn = n[edge_on]
        side = np.cross(up, fn)
        flat = np.linalg.norm(side, axis=1) < 1e-3  # a horizontal face seen edge-on: use the camera's right
        side[flat] = camera.world_from_camera[:, 0]
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        vert = np.cross(fn, side)
        d = tri[edge_on] - tri[edge_on].mean(1, keepdims=True)
        own = np.stack([np.einsum("fkj,fj->fk", d, side), -np.einsum("fkj,fj->fk", d, vert)], -1) * ppm
        facing = np.einsum("ij,ij->i", n, to_cam) >= EDGE_ON
        folded = None if mask is None else folded_sides(points, faces[edge_on], px, faces[facing], camera, mask)
        if folded is None:  # without the outline, or with no face the photo saw: centred on the copy's middle
            centre = tri[edge_on].mean(1) - points.mean(0)
            at = np.stack([np.einsum("fj,fj->f", centre, side) * ppm + 0.5 * w,
                           -np.einsum("fj,fj->f", centre, vert) * ppm + 0.5 * h], -1)
            placed = own + at[:, None, :]
        else:  # laid where the fold puts it, turned (or mirrored) as the fold turns it
            placed = _laid(own, folded)
        a, b = _fit_faces(placed[..., 0], 0.5, w - 0.5), _fit_faces(placed[..., 1], 0.5, h - 0.5)
        st[edge_on, :, 0] = 0.5 + a / (2.0 * w)
        st[edge_on, :, 1] = 1.0 - b / h
    return st.reshape(-1, 2)
