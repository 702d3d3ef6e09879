"""What the line where a wall behind the objects meets the ground (read from the photo by ``perceive/wall.py``)
says about an object whose foot is above it.

The line bounds the ground: an object whose foot is above it in the photo would, stood on the ground, stand
behind the wall, so something the masks do not show holds it (a shelf, a hook). It then stands in front of
the wall: its back against the wall's plane (:func:`depth_against`), which brings it nearer along the
camera's rays and keeps its outline exactly.
"""

from __future__ import annotations

import numpy as np

from ..lift.silhouette import plane_points
from ..perceive.wall import WallLine, find_wall_line, foot_above  # noqa: F401 (re-exported for align.support)


def wall_plane(line: WallLine, camera) -> tuple[np.ndarray, np.ndarray] | None:
    """(a point, the unit horizontal normal pointing away from the camera) of the wall whose foot is ``line``,
    under ``camera`` (the ground at z = 0); None where the line is not on the ground in front of it."""
    us = np.array([0.25, 0.75]) * line.width
    pts = plane_points(camera, us, line.row(us), 0.0)
    if not np.all(np.isfinite(pts)):
        return None
    along = pts[1] - pts[0]
    along[2] = 0.0
    if np.linalg.norm(along) < 1e-9:
        return None
    normal = np.array([along[1], -along[0], 0.0]) / np.linalg.norm(along)
    if normal @ (pts[0] - np.asarray(camera.origin, float)) < 0:
        normal = -normal
    return pts[0], normal


def depth_against(vertices: np.ndarray, plane, origin) -> float | None:
    """The factor ``t`` (0 < t) that scales ``vertices`` about the camera's ``origin`` until their farthest
    point touches the wall ``plane`` (:func:`wall_plane`); None where they cannot reach it."""
    point, normal = plane
    o = np.asarray(origin, float)
    reach = float(np.max((np.asarray(vertices, float) - o) @ normal))
    gap = float((point - o) @ normal)
    if reach <= 1e-9 or gap <= 0:
        return None
    return gap / reach
