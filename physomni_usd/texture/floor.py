"""The fill on the ground plane: the part of the plate's hole that lies on the floor, filled in a top-down view.

Owns :func:`fill_on_ground`, and where the floor ends (:func:`off_floor`). The image-plane
fills copy patches as the photo shows them; on a patterned floor seen in perspective (checks, tiles, boards) the
pattern shrinks with the distance and a copy taken beside the hole lands out of step. Where the camera is known (a
pinhole over the ground plane z = 0), the floor around the hole is warped to a top-down image by the plane's
homography, where the pattern is regular and equal-sized, filled there by the same fill, and warped back; the
hole's pixels off the floor keep the image-plane fill. The floor ends where a wall stands on it
(:func:`off_floor`): above the wall's line the photo shows the wall, which the plane's homography would take for
floor far behind it and stretch into the fill.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..geometry.camera import PinholeCamera
from ..lift.silhouette import fill_holes, foot_pixel
from ..perceive.wall import ABOVE_FRACTION, find_wall_line
from .pixels import dilate

#: A camera pitched at least this steeply sees the floor nearly top-down already: the warp would only resample
#: it, softening its grain (the desk example, seen at 82°, kept 0.575 of its wood's gradient where the ball
#: stood, under bench look's 0.6), so the image-plane fill stands.
TOP_DOWN_DEG = 70.0
#: Ground farther than this many camera heights from the camera (along the floor) is left to the image-plane
#: fill: near the horizon a pixel covers so much floor that the top-down view would be mostly stretch.
GROUND_REACH = 8.0
#: Longest side of the top-down image, pixels: it is scaled to the photo's pixel size at the hole, and cut
#: down to this where the floor around the hole is deep (the fill's time grows with its area).
FLOOR_MAX_SIDE = 320
#: How much floor around the hole the top-down image takes, as a fraction of the photo's diagonal (the fill
#: copies from there).
FLOOR_MARGIN = 0.08
#: The part of the top-down image that the photo does not show (beyond its frame, past the reach) joins the
#: hole where it lies within this many pixels of it, so that the fill does not take the warp's border for floor.
OFF_PHOTO_PX = 8
#: The top-down fill's local colour (a Gaussian this fraction of the photo's diagonal wide) is replaced by the
#: image-plane fill's.
COLOUR_SIGMA = 0.02


def image_from_ground(camera: PinholeCamera, width: int) -> np.ndarray:
    """3×3 homography from the ground plane's (x, y, 1), metres, to the pixels of a photo ``width`` pixels wide
    that ``camera`` sees (its intrinsics scaled to that width)."""
    s = width / camera.width
    k = np.diag([s, s, 1.0]) @ camera.K
    cam_from_world = camera.world_from_camera.T
    return k @ np.column_stack([cam_from_world[:, 0], cam_from_world[:, 1], -cam_from_world @ camera.origin])


def off_floor(photo: np.ndarray, masks) -> np.ndarray | None:
    """(H, W) bool: the pixels of ``photo`` above the line where a wall (or a backdrop) meets the floor
    (``perceive.wall.find_wall_line``, the objects' ``masks`` left out), or None where the photo shows no such
    line that an object stands in front of: its foot below the line by at least ``ABOVE_FRACTION`` of the photo.
    A line with every object's foot above it is no wall's foot (a shade across the floor beyond them)."""
    masks = [np.asarray(m, bool) for m in masks if np.any(m)]
    line = find_wall_line(photo, masks) if masks else None
    if line is None:
        return None
    h, w = photo.shape[:2]
    feet = [foot_pixel(fill_holes(m)) for m in masks]
    if not any(v >= float(line.row(u)) + ABOVE_FRACTION * h for u, v in feet):
        return None
    return np.arange(h)[:, None] < line.row(np.arange(w) + 0.5)[None, :]


def fill_on_ground(photo: np.ndarray, hole: np.ndarray, camera: PinholeCamera, fill, filled: np.ndarray,
                   wall: np.ndarray | None = None) -> np.ndarray:
    """``filled`` (the image-plane fill of ``hole`` in ``photo``, (H, W, 3) uint8) with the hole's pixels on
    the floor replaced by ``fill(image, hole)`` run on the floor warped top-down under ``camera``. ``wall``:
    (H, W) bool, the pixels that are not floor however the plane sees them (:func:`off_floor`)."""
    h, w = hole.shape
    h_ig = image_from_ground(camera, w)
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    g = np.linalg.solve(h_ig, np.stack([uu.ravel(), vv.ravel(), np.ones(h * w)]))
    g = g[:2] / np.where(np.abs(g[2]) < 1e-12, 1e-12, g[2])
    gx, gy = g[0].reshape(h, w), g[1].reshape(h, w)
    # a ray at or above the horizon meets the plane behind the camera, where the point's depth is negative
    forward = camera.world_from_camera[:, 2]
    in_front = (forward[0] * (gx - camera.origin[0]) + forward[1] * (gy - camera.origin[1])
                - forward[2] * camera.origin[2]) > 0
    reach = GROUND_REACH * max(float(camera.origin[2]), 1e-6)
    ground = in_front & (np.hypot(gx - camera.origin[0], gy - camera.origin[1]) < reach)
    if wall is not None:
        ground &= ~wall
    use = hole & ground
    if not use.any() or camera.origin[2] <= 0:
        return filled
    # the photo's pixel size on the floor (square root of the Jacobian's area) where the hole lies on it
    ys, xs = np.nonzero(use)
    gxx, gxy = np.gradient(gx, axis=1), np.gradient(gx, axis=0)
    gyx, gyy = np.gradient(gy, axis=1), np.gradient(gy, axis=0)
    foot = np.sqrt(np.abs(gxx * gyy - gxy * gyx))[ys, xs]
    region = dilate(hole, int(FLOOR_MARGIN * np.hypot(h, w))) & ground
    rx, ry = gx[region], gy[region]
    x0, y0 = float(rx.min()), float(ry.min())
    scale = 1.0 / max(float(np.median(foot)), 1e-9)
    side = max(float(rx.max()) - x0, float(ry.max()) - y0) * scale
    scale *= min(1.0, FLOOR_MAX_SIDE / max(side, 1e-9))
    size = (int(np.ceil((rx.max() - x0) * scale)) + 1, int(np.ceil((ry.max() - y0) * scale)) + 1)
    m = h_ig @ np.array([[1 / scale, 0, x0], [0, 1 / scale, y0], [0, 0, 1.0]])  # photo from top-down pixels
    def warp(img, flags, **kw):
        return cv2.warpPerspective(img, m, size, flags=flags | cv2.WARP_INVERSE_MAP, **kw)
    top = warp(photo, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    seen = warp(ground.astype(np.uint8), cv2.INTER_NEAREST, borderValue=0) > 0
    top_hole = dilate(warp(hole.astype(np.uint8), cv2.INTER_LINEAR, borderValue=0) > 0, 1)
    top_hole |= ~seen & dilate(top_hole, OFF_PHOTO_PX)
    top_filled = fill(top, top_hole)
    back = cv2.remap(top_filled, (scale * (gx - x0)).astype(np.float32), (scale * (gy - y0)).astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    # the top-down fill brings the pattern in step, its local colour is the image-plane fill's: under a low camera
    # (generated scene 52007, a bowl's hole reaching towards the horizon) the top-down fill alone came out lighter
    # than the floor, 8.60 levels off the truth where the image-plane fill erred 3.31; with its colour, 3.43
    sigma = COLOUR_SIGMA * float(np.hypot(h, w))
    low = lambda img: cv2.GaussianBlur(img.astype(np.float32), (0, 0), sigma)  # noqa: E731
    mixed = np.clip(back.astype(np.float32) + low(filled) - low(np.where(use[..., None], back, filled)) + 0.5, 0, 255)
    out = filled.copy()
    out[use] = mixed.astype(np.uint8)[use]
    return out
