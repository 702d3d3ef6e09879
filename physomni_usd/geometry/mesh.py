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
