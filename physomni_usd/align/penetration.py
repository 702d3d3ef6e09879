"""Resolving interpenetration measured on the meshes themselves, never by pushing into the ground.

Each overlapping pair (deepest vertex of one inside the other, by signed
distance) is pushed apart horizontally along the line between their centres
by the depth plus a clearance, half each; passes repeat until no pair
overlaps. Moves are horizontal, so no object goes below z = 0, and there is no
cap on the total displacement: the loop ends when the meshes are apart (or
after ``max_passes``, reported to the caller).
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..metrics.geometry import max_penetration

MAX_PASSES = 100


def resolve_penetration(vertex_sets: list[np.ndarray], faces: list[np.ndarray], gap: float = 0.002,
                        max_passes: int = MAX_PASSES) -> tuple[list[np.ndarray], bool]:
    """Horizontal offsets (k, 3) that leave no pair of meshes interpenetrating; and whether that was reached."""
    k = len(vertex_sets)
    offsets = np.zeros((k, 3))
    meshes = [trimesh.Trimesh(v, f, process=False) for v, f in zip(vertex_sets, faces)]
    for _ in range(max_passes):
        moved = False
        for i in range(k):
            for j in range(i + 1, k):
                a = trimesh.Trimesh(meshes[i].vertices + offsets[i], meshes[i].faces, process=False)
                b = trimesh.Trimesh(meshes[j].vertices + offsets[j], meshes[j].faces, process=False)
                depth = max_penetration({"a": a, "b": b})
                if depth <= 0.0:
                    continue
                d = b.vertices.mean(0) - a.vertices.mean(0)
                d[2] = 0.0
                n = np.linalg.norm(d)
                d = d / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
                step = 0.5 * (depth + gap) * d
                offsets[i] -= step
                offsets[j] += step
                moved = True
        if not moved:
            return [o.copy() for o in offsets], True
    return [o.copy() for o in offsets], False
