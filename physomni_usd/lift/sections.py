"""Closed triangle meshes from cross-sections: the sections of each shape (round, a slab along the camera's
rays, inflated) and lofting them.

Shared by the side-view lift (``silhouette.py``, which picks the shape and
where each section stands) and the lift from above (``footprint.py``): a tube
through K sections of n points each, closed by a fan at each end, is
watertight by construction.
"""

from __future__ import annotations

import numpy as np

#: An inflated section is never thinner than this fraction of the object's largest bulge (no flat slivers).
MIN_BULGE = 0.08
#: Superellipse exponent of round cross-sections (2: a circle).
ROUND_EXPONENT = 2.0


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


def superellipse(n: int, exponent: float) -> np.ndarray:
    """(n, 2) points (x, y) of the unit superellipse |x|^p + |y|^p = 1, counter-clockwise."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    e = 2.0 / exponent
    return np.stack([np.sign(c) * np.abs(c) ** e, np.sign(s) * np.abs(s) ** e], axis=1)


def round_rings(centres, radii, tangent, normal, sections: int) -> np.ndarray:
    """Polygons (K, n, 3) circumscribing circles of ``radii`` about ``centres``, in the horizontal plane."""
    ring = superellipse(sections, ROUND_EXPONENT) / np.cos(np.pi / sections)
    return (centres[:, None, :] + ring[None, :, 0:1] * radii[:, None, None] * tangent
            + ring[None, :, 1:2] * radii[:, None, None] * normal)


def ray_slab_rings(front_left, front_right, dir_left, dir_right, normal, depth: "float | np.ndarray",
                   sections: int) -> np.ndarray:
    """Quadrilateral sections (K, n, 3) whose sides follow the camera rays through the outline, seen from above.

    The front edge of each section is the outline's row on the front plane and
    the back edge lies ``depth`` (one for all, or (K,) one per section) further along ``normal`` at the same height;
    the sides run along the rays' horizontal directions, so from the camera
    they hide behind the front face's edges instead of widening the outline.
    """
    depth = np.broadcast_to(np.asarray(depth, float), (len(front_left),))
    dir_left = dir_left * np.array([1.0, 1.0, 0.0])
    dir_right = dir_right * np.array([1.0, 1.0, 0.0])
    back_left = front_left + dir_left * (depth / (dir_left @ normal))[:, None]
    back_right = front_right + dir_right * (depth / (dir_right @ normal))[:, None]
    side = max(1, sections // 6)
    face = max(1, (sections - 2 * side) // 2)
    corners = [front_left, front_right, back_right, back_left]
    counts = [face, side, sections - face - 2 * side, side]
    parts = []
    for c, (a, b) in zip(counts, zip(corners, corners[1:] + corners[:1])):
        t = (np.arange(c) / c)[None, :, None]
        parts.append(a[:, None, :] * (1 - t) + b[:, None, :] * t)
    return np.concatenate(parts, axis=1)


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
