"""Camera moves: the paper's orbits, lateral moves and descent (and dolly in/out), as one camera transform
per frame, starting at the photo's own camera.

Plain arrays in, plain arrays out: transforms are USD's row-vector 4×4 matrices (the translation in the last
row), the pivot is the objects' centre. The move advances at constant speed, as the paper's does, by
``amount`` × the default below over the whole shot.
"""

from __future__ import annotations

import numpy as np

from ..limits import Limit, Limits

#: Default size of each move over the whole shot, and its unit: orbits in degrees; truck, dolly and crane
#: as a fraction of the camera's distance to the objects' centre (crane: of the camera's height).
MOVES = {
    "static": (0.0, ""),
    "orbit-left": (15.0, "degrees about the vertical axis through the objects' centre, camera to its left"),
    "orbit-right": (15.0, "degrees about the vertical axis through the objects' centre, camera to its right"),
    "orbit-up": (10.0, "degrees about the horizontal axis through the objects' centre, camera rising"),
    "orbit-down": (10.0, "degrees about the horizontal axis through the objects' centre, camera sinking"),
    "truck-left": (0.15, "of the distance to the objects, sideways to the camera's left"),
    "truck-right": (0.15, "of the distance to the objects, sideways to the camera's right"),
    "crane-down": (0.3, "of the camera's height above the ground, straight down"),
    "dolly-in": (0.25, "of the distance to the objects, along the view"),
    "dolly-out": (0.25, "of the distance to the objects, along the view, backwards"),
}
#: Largest ``--camera-amount``: four times the default already turns an orbit by 60°.
MAX_AMOUNT = 4.0
#: The size of a move as the command line takes it (``--camera-amount``), checked by ``render_shot``.
LIMITS = Limits(camera_amount=Limit("--camera-amount", "Size of the move as a multiple of its default.", 0.0,
                                    MAX_AMOUNT, 1.0, lo_open=True))
#: The camera never comes closer to the ground than this share of its starting height.
MIN_HEIGHT = 0.05


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about the unit ``axis`` (column vectors)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def move_matrices(start: np.ndarray, centre: np.ndarray, move: str, amount: float, frames: int) -> np.ndarray:
    """(frames, 4, 4) camera-to-world matrices (USD row-vector form) of ``move`` from ``start``.

    ``start`` is the photo's camera (4, 4), ``centre`` (3,) the objects' centre in metres; frame 0 is
    ``start`` itself."""
    if move not in MOVES:
        raise ValueError(move)
    m0 = np.asarray(start, np.float64).reshape(4, 4)
    origin, right, back = m0[3, :3], m0[0, :3], m0[2, :3]
    right_h = np.array([right[0], right[1], 0.0])
    right_h = right_h / np.linalg.norm(right_h) if np.linalg.norm(right_h) > 1e-9 else np.array([1.0, 0, 0])
    forward = -back / np.linalg.norm(back)
    distance = float(np.linalg.norm(centre - origin))
    size = MOVES[move][0] * amount
    out = np.repeat(m0[None], frames, axis=0)
    for k in range(frames):
        s = k / max(frames - 1, 1)
        rot, shift = np.eye(3), np.zeros(3)
        if move in ("orbit-left", "orbit-right"):
            rot = _rotation(np.array([0.0, 0.0, 1.0]), np.radians(size * s) * (1 if move == "orbit-right" else -1))
        elif move in ("orbit-up", "orbit-down"):
            # about the camera's horizontal right axis: a negative angle lifts a camera in front of the pivot
            rot = _rotation(right_h, np.radians(size * s) * (-1 if move == "orbit-up" else 1))
        elif move in ("truck-left", "truck-right"):
            shift = right_h * distance * size * s * (1 if move == "truck-right" else -1)
        elif move == "crane-down":
            shift = np.array([0.0, 0.0, -abs(origin[2]) * min(size * s, 1.0 - MIN_HEIGHT)])
        elif move in ("dolly-in", "dolly-out"):
            shift = forward * distance * size * s * (1 if move == "dolly-in" else -1)
        m = out[k]
        m[:3, :3] = m0[:3, :3] @ rot.T  # row vectors: each axis row rotated
        m[3, :3] = (origin - centre) @ rot.T + centre + shift
        if move.startswith("orbit") and m[3, 2] < MIN_HEIGHT * abs(origin[2]):
            m[3, 2] = MIN_HEIGHT * abs(origin[2])  # an orbit down never takes the camera under the ground
    return out
