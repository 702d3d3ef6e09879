"""What every video the project writes needs of its frames."""

from __future__ import annotations

import numpy as np


def even_sides(frame: np.ndarray) -> np.ndarray:
    """H.264 in yuv420p needs even sides: ``frame`` (H, W, ...) without its last row or column where needed."""
    h, w = frame.shape[:2]
    return np.ascontiguousarray(frame[:h - h % 2, :w - w % 2])
