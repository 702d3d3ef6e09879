"""Mesh topology helpers shared by every stage that reads USD meshes."""

from __future__ import annotations

import numpy as np


def triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons given USD's faceVertexCounts / faceVertexIndices → (M, 3)."""
    if counts.size and np.all(counts == 3):
        return indices.reshape(-1, 3)
    tris = []
    start = 0
    for c in counts:
        for k in range(1, c - 1):
            tris.append((indices[start], indices[start + k], indices[start + k + 1]))
        start += c
    return np.asarray(tris, np.int64).reshape(-1, 3)


#: Turns about the vertical tried for an object's own box, radians (half-degree steps over a quarter turn).
_TURNS = np.radians(np.arange(0.0, 90.0, 0.5))


def longest_dimension(vertices: np.ndarray) -> float:
    """The longest side of the points' (n, 3) upright box turned about the vertical to fit them tightest,
    in their units: a lying pencil's length whichever way it points, a mug's height or width (not the
    diagonal between them). Unlike the axis-aligned box's longest side, it does not shrink for a pencil
    lying diagonally.
    """
    v = np.asarray(vertices, float)
    if len(v) < 2:
        return 0.0
    c, s = np.cos(_TURNS), np.sin(_TURNS)
    a = v[:, :1] * c + v[:, 1:2] * s  # (n, turns): along each turned axis
    b = -v[:, :1] * s + v[:, 1:2] * c
    wa = a.max(0) - a.min(0)
    wb = b.max(0) - b.min(0)
    k = int(np.argmin(wa * wb))
    return float(max(wa[k], wb[k], np.ptp(v[:, 2])))
