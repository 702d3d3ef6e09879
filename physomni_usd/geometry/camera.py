"""A pinhole camera over a ground plane at z = 0, in world coordinates (Z up, metres).

The camera sits at ``(0, 0, height)`` looking along +Y, tilted down by
``pitch``; pixels use OpenCV's convention (u right, v down, origin at the
top-left corner of the top-left pixel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: Smallest downward tilt the automatic pitch picks, degrees.
MIN_AUTO_PITCH_DEG = 10.0
#: Angle that must separate the highest foot of an object from the horizon, degrees.
HORIZON_MARGIN_DEG = 3.0
#: USD aperture of the vertical film side, in the camera's length units (mm by convention).
VERTICAL_APERTURE = 24.0


@dataclass(frozen=True)
class PinholeCamera:
    width: int
    height: int
    fov_deg: float
    pitch_deg: float
    position: tuple[float, float, float] = (0.0, 0.0, 1.0)
    rotation: tuple | None = None  # rows: camera x, y, z in world; None = level camera pitched by pitch_deg
    _axes: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        if self.rotation is not None:
            axes = np.asarray(self.rotation, float).reshape(3, 3)
        else:
            p = math.radians(self.pitch_deg)
            right = np.array([1.0, 0.0, 0.0])
            forward = np.array([0.0, math.cos(p), -math.sin(p)])
            axes = np.stack([right, np.cross(forward, right), forward])
        object.__setattr__(self, "_axes", axes)

    @classmethod
    def from_pose(cls, width: int, height: int, fov_deg: float, position, world_from_camera) -> "PinholeCamera":
        """A camera at ``position`` whose OpenCV axes (x right, y down, z forward) are the columns of
        ``world_from_camera`` (3, 3, a rotation)."""
        r = np.asarray(world_from_camera, float)
        forward = r[:, 2]
        pitch = math.degrees(math.asin(np.clip(-forward[2], -1.0, 1.0)))
        return cls(width, height, fov_deg, pitch, tuple(float(x) for x in position),
                   tuple(float(x) for x in r.T.ravel()))

    # intrinsics ---------------------------------------------------------------------------------
    @property
    def focal_px(self) -> float:
        return 0.5 * self.height / math.tan(math.radians(self.fov_deg) / 2)

    @property
    def principal_point(self) -> tuple[float, float]:
        return 0.5 * self.width, 0.5 * self.height

    @property
    def K(self) -> np.ndarray:
        """3×3 intrinsic matrix in pixels."""
        cx, cy = self.principal_point
        f = self.focal_px
        return np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]])

    @property
    def world_from_camera(self) -> np.ndarray:
        """3×3 rotation taking OpenCV camera axes (x right, y down, z forward) to world."""
        return self._axes.T

    @property
    def origin(self) -> np.ndarray:
        return np.asarray(self.position, dtype=float)

    # rays and projection ------------------------------------------------------------------------
    def rays(self, u, v) -> np.ndarray:
        """Unit world directions (…, 3) of the rays through pixel coordinates ``u``, ``v``."""
        u = np.asarray(u, dtype=float)
        v = np.asarray(v, dtype=float)
        cx, cy = self.principal_point
        f = self.focal_px
        d_cam = np.stack([(u - cx) / f, (v - cy) / f, np.ones(np.broadcast(u, v).shape)], axis=-1)
        d = d_cam @ self._axes
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (N, 2) and depths (N,) along the optical axis of world ``points`` (N, 3)."""
        p = (np.asarray(points, dtype=float) - self.origin) @ self._axes.T
        z = p[:, 2]
        safe = np.where(np.abs(z) < 1e-9, 1e-9, z)
        uv = p[:, :2] / safe[:, None] * self.focal_px + np.array(self.principal_point)
        return uv, z

    def ground_points(self, u, v) -> np.ndarray:
        """Where the rays through (u, v) meet z = 0, (…, 3); NaN for rays at or above the horizon."""
        d = self.rays(u, v)
        t = np.where(d[..., 2] < -1e-9, -self.origin[2] / np.minimum(d[..., 2], -1e-9), np.nan)
        return self.origin + t[..., None] * d

    def horizon_row(self) -> float:
        """Image row of the horizon (may lie outside the image)."""
        return self.principal_point[1] - self.focal_px * math.tan(math.radians(self.pitch_deg))

    def moved(self, offset) -> "PinholeCamera":
        """The same camera translated by ``offset`` (3,)."""
        return PinholeCamera(self.width, self.height, self.fov_deg, self.pitch_deg,
                             tuple(float(x) for x in self.origin + np.asarray(offset, dtype=float)), self.rotation)

    # USD ----------------------------------------------------------------------------------------
    def usd_apertures(self) -> tuple[float, float, float]:
        """(focalLength, horizontalAperture, verticalAperture) giving this field of view in USD."""
        va = VERTICAL_APERTURE
        ha = va * self.width / self.height
        focal = 0.5 * va / math.tan(math.radians(self.fov_deg) / 2)
        return focal, ha, va

    def usd_matrix(self) -> np.ndarray:
        """4×4 row-major local-to-world matrix of a USD camera (looks down −Z, +Y up)."""
        right, down, forward = self._axes
        m = np.eye(4)
        m[0, :3] = right
        m[1, :3] = -down
        m[2, :3] = -forward
        m[3, :3] = self.origin
        return m


def pick_pitch(fov_deg: float, height: int, foot_rows, pitch_deg: float | None) -> float:
    """The camera's downward tilt: the user's, or the smallest ≥ 10° that puts every foot below the horizon.

    ``foot_rows`` are the image rows where objects meet the ground. A given
    pitch that leaves a foot at or above the horizon is refused, since that
    object could not stand on the ground plane.
    """
    f = 0.5 * height / math.tan(math.radians(fov_deg) / 2)
    cy = 0.5 * height
    # angle of the highest foot above the optical axis (positive = above)
    highest = max(math.degrees(math.atan((cy - r) / f)) for r in foot_rows) if len(foot_rows) else -90.0
    needed = highest + HORIZON_MARGIN_DEG
    if pitch_deg is None:
        pitch = max(MIN_AUTO_PITCH_DEG, needed)
        if pitch > 80.0:
            raise InputError("objects' feet are too high in the photo for any camera pitch; give --pitch and --fov")
        return pitch
    if pitch_deg < needed:
        raise InputError(f"--pitch {pitch_deg:g} puts an object's foot above the horizon; "
                         f"use at least {math.ceil(needed)} or leave --pitch out")
    return float(pitch_deg)


def camera_from_usd(focal: float, h_ap: float, v_ap: float, matrix, width: int, height: int) -> "RenderCamera":
    """Camera for rendering from a USD camera's attributes and its local-to-world matrix."""
    m = np.asarray(matrix, dtype=float).reshape(4, 4)
    right = m[0, :3] / np.linalg.norm(m[0, :3])
    up = m[1, :3] / np.linalg.norm(m[1, :3])
    back = m[2, :3] / np.linalg.norm(m[2, :3])
    fx = focal / h_ap * width
    fy = focal / v_ap * height
    return RenderCamera(width, height, fx, fy, m[3, :3].copy(), np.stack([right, -up, -back]))


@dataclass
class RenderCamera:
    """Camera as the renderer needs it: pixel focal lengths, centre, and OpenCV axes in world."""

    width: int
    height: int
    fx: float
    fy: float
    origin: np.ndarray
    axes: np.ndarray  # rows: camera x (right), y (down), z (forward) in world

    def rays(self, step: int = 1) -> np.ndarray:
        """Unit directions (H/step, W/step, 3) through the centres of step×step pixel blocks."""
        u = (np.arange(0, self.width, step) + 0.5 * step - 0.5 * self.width) / self.fx
        v = (np.arange(0, self.height, step) + 0.5 * step - 0.5 * self.height) / self.fy
        uu, vv = np.meshgrid(u, v)
        d = np.stack([uu, vv, np.ones_like(uu)], axis=-1) @ self.axes
        return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        p = (np.asarray(points, dtype=float) - self.origin) @ self.axes.T
        z = np.where(np.abs(p[:, 2]) < 1e-9, 1e-9, p[:, 2])
        uv = np.stack([p[:, 0] / z * self.fx + 0.5 * self.width, p[:, 1] / z * self.fy + 0.5 * self.height], -1)
        return uv, p[:, 2]
