"""Rotations as plain 3×3 matrices and (w, x, y, z) quaternions, the conventions USD uses.

SciPy's ``Rotation`` does the arithmetic; these functions only fix the
quaternion order (SciPy and warp store x, y, z, w).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def axis_angle(axis, angle: float) -> np.ndarray:
    """3×3 rotation by ``angle`` radians about ``axis`` (any length)."""
    axis = np.asarray(axis, float)
    return Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()


def from_wxyz(q) -> np.ndarray:
    """3×3 rotation of a (w, x, y, z) quaternion (normalised first)."""
    w, x, y, z = np.asarray(q, float)
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def to_wxyz(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) quaternion of a 3×3 rotation."""
    x, y, z, w = Rotation.from_matrix(np.asarray(r, float)).as_quat()
    return np.array([w, x, y, z])


def between(a, b) -> np.ndarray:
    """The smallest rotation (det +1) taking direction ``a`` onto direction ``b``."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        other = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return axis_angle(other, np.pi)
    return axis_angle(axis, np.arctan2(s, c))


def random(rng) -> np.ndarray:
    """A uniformly random 3×3 rotation drawn from ``rng`` (numpy Generator)."""
    return Rotation.random(random_state=rng).as_matrix()
