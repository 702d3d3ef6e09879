"""Texture for the sides of a lifted object that the photo never saw.

The photo projected from its camera textures the surfaces that face the camera
(and, mirrored, those that face away: a round or extruded lift is symmetric
front to back). Surfaces at a grazing angle to the photo's camera — an
extrusion's walls, the flanks of a turned object — would take the rim's few
pixels smeared along their whole width. They are textured instead by a planar map along their
own tangent plane, at the photo's pixel density, into an opaque copy of the
object's texture whose outside is filled from the silhouette's border; the
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


def filled_copy(rgba: np.ndarray) -> np.ndarray:
    """(h, w, 4) uint8: the texture's colours with its transparent part filled from the mask's border (the
    nearest opaque pixel's colour, softened), fully opaque."""
    mask = rgba[..., 3] >= 128
    rgb = rgba[..., :3].copy()
    if mask.any() and not mask.all():
        _, labels = cv2.distanceTransformWithLabels((~mask).astype(np.uint8), cv2.DIST_L2, 5,
                                                    labelType=cv2.DIST_LABEL_PIXEL)
        ys, xs = np.nonzero(mask)
        # label → the opaque pixel it stands for (labels number the zero pixels of the input: the mask)
        lut = np.zeros((labels.max() + 1, 3), np.uint8)
        lut[labels[ys, xs]] = rgb[ys, xs]
        near = lut[labels]
        soft = cv2.GaussianBlur(near, (0, 0), 2.0)
        rgb = np.where(mask[..., None], rgb, soft)
    return np.dstack([rgb, np.full(mask.shape, 255, np.uint8)])


def two_sided_texture(rgba: np.ndarray) -> np.ndarray:
    """(h, 2w, 4): the photo crop on the left, :func:`filled_copy` on the right."""
    return np.concatenate([rgba, filled_copy(rgba)], axis=1)


def corner_st(points: np.ndarray, faces: np.ndarray, camera, texture_size: tuple[int, int],
              origin: tuple[int, int]) -> np.ndarray:
    """(F·3, 2) faceVarying ``st`` into a :func:`two_sided_texture`, for world ``points`` (N, 3) as the photo
    saw them and triangles ``faces`` (F, 3); ``texture_size`` (w, h) of the photo crop at photo pixel
    ``origin`` (x0, y0)."""
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
    st = np.empty((len(faces), 3, 2))
    st[..., 0] = corners[..., 0] / (2.0 * w)
    st[..., 1] = 1.0 - corners[..., 1] / h
    if edge_on.any():
        # the planar map: the face's own horizontal and vertical directions, at the object's pixel density,
        # centred on the middle of the opaque copy
        c = points.mean(0)
        ppm = float(camera.focal_px / max(np.median(depth), 1e-6))
        up = np.array([0.0, 0.0, 1.0])
        fn = n[edge_on]
        side = np.cross(up, fn)
        flat = np.linalg.norm(side, axis=1) < 1e-3  # a horizontal face seen edge-on: use the camera's right
        side[flat] = camera.world_from_camera[:, 0]
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        vert = np.cross(fn, side)
        d = tri[edge_on] - c
        a = np.einsum("fkj,fj->fk", d, side) * ppm + 0.5 * w
        b = -np.einsum("fkj,fj->fk", d, vert) * ppm + 0.5 * h
        a, b = np.clip(a, 0.5, w - 0.5), np.clip(b, 0.5, h - 0.5)
        st[edge_on, :, 0] = 0.5 + a / (2.0 * w)
        st[edge_on, :, 1] = 1.0 - b / h
    return st.reshape(-1, 2)
