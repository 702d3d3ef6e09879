"""Closed triangle meshes from cross-sections: lofting, and the inflated sections of rounded bodies.

Shared by the side-view lift (``silhouette.py``) and the lift from above
(``footprint.py``): a tube through K sections of n points each, closed by a fan
at each end, is watertight by construction.
"""

from __future__ import annotations

import numpy as np

#: An inflated section is never thinner than this fraction of the object's largest bulge (no flat slivers).
MIN_BULGE = 0.08


def loft(rings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed tube through cross-sections ``rings`` (K, n, 3), top first, with a fan cap at each end.

    Every ring must list its n points in the same rotational order. Returns
    vertices (K·n + 2, 3) and outward triangles (M, 3).
    """
    k, sections = rings.shape[:2]
    verts = rings.reshape(-1, 3)
    top, bottom = len(verts), len(verts) + 1
    verts = np.vstack([verts, rings[0].mean(0), rings[-1].mean(0)])
    faces = []
    j = np.arange(sections)
    jn = (j + 1) % sections
    for i in range(k - 1):
        a, b = i * sections + j, i * sections + jn
        c, d = (i + 1) * sections + j, (i + 1) * sections + jn
        faces.append(np.stack([a, c, b], 1))
        faces.append(np.stack([b, c, d], 1))
    faces.append(np.stack([np.full(sections, top), j, jn], 1))
    last = (k - 1) * sections
    faces.append(np.stack([np.full(sections, bottom), last + jn, last + j], 1))
    faces = np.concatenate(faces).astype(np.int32)
    return verts, _outward(verts, faces)


def bulge(dist: np.ndarray, radius: float, floor: float = MIN_BULGE) -> np.ndarray:
    """Inflation profile √(2Rd − d²) / R in [floor, 1] of points ``dist`` inside an outline whose largest
    inner distance is ``radius``: a quarter circle across the outline's rim, so a disc inflates to a ball."""
    d = np.clip(np.asarray(dist, float), 0.0, radius)
    return np.maximum(np.sqrt(np.maximum(2.0 * radius * d - d * d, 0.0)) / max(radius, 1e-12), floor)


def span_samples(left, right, count: int) -> np.ndarray:
    """(K, count) positions from ``left`` to ``right`` (K,), denser towards the ends where outlines curve."""
    t = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, count)))
    return left[:, None] + (right - left)[:, None] * t[None, :]


def inflated_rings(middle: np.ndarray, offsets: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Closed sections (K, 2·n − 2, 3) through ``middle`` (K, n, 3) points, bulging ±``offsets`` (K, n) along
    ``direction`` ((3,) or (K, n, 3)): one side left to right, the other back; the two ends stay on the
    middle. Along the camera's rays, the bulge leaves every point where the photo shows it."""
    off = offsets.copy()
    off[:, [0, -1]] = 0.0
    direction = np.broadcast_to(direction, middle.shape)
    one = middle - off[..., None] * direction
    other = middle + off[..., None] * direction
    return np.concatenate([one, other[:, -2:0:-1]], axis=1)


def _outward(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Flip every face if the signed volume is negative (the tube's handedness depends on the axes)."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    return faces[:, ::-1].copy() if volume < 0 else faces
