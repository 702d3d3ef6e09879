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


def _directions(n: int = 256) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over a hemisphere (a Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z * z)
    return np.c_[r * np.cos(phi), r * np.sin(phi), z]


_DIRECTIONS = _directions()


def longest_dimension(vertices: np.ndarray) -> float:
    """The largest extent of the points (n, 3) along any direction (their diameter, within 1 %), in their units.

    Unlike the axis-aligned box's longest side, it does not shrink for a pencil lying diagonally.
    """
    v = np.asarray(vertices, float)
    if len(v) < 2:
        return 0.0
    proj = v @ _DIRECTIONS.T
    return float((proj.max(0) - proj.min(0)).max())
