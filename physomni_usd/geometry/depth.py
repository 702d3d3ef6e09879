"""The ground a depth map sees: the camera's pitch (and, with metric depth, its height) from a plane fit.

A pure function of the depth backend's map and the camera's field of view, below every stage, so that
``build`` reads the pitch from it where it resolves its settings (a ``--pitch`` given wins there).
"""

from __future__ import annotations

import math

import numpy as np


def ground_pitch(depth, fov_deg: float, background: np.ndarray) -> dict | None:
    """The camera's downward pitch (degrees) from a plane fitted to the ground seen in a depth map.

    The lower half of the background pixels is back-projected with the
    pinhole of vertical field of view ``fov_deg`` and a plane is fitted by
    RANSAC; its normal gives the pitch, and with metric depth its distance
    the camera height. ``depth`` is a ``swappable.protocols.DepthMap`` ((H, W)
    depth along the optical axis, and whether it is in metres), ``background``
    an (H, W) bool of the pixels no object covers. Returns None when no
    plausible ground is seen.
    """
    d = np.asarray(depth.depth, np.float64)
    h, w = d.shape
    f = 0.5 * h / math.tan(math.radians(fov_deg) / 2)
    vv, uu = np.mgrid[0:h, 0:w] + 0.5
    use = background & (vv > h / 2) & np.isfinite(d) & (d > 0)
    if use.sum() < 50:
        return None
    z = d[use]
    pts = np.stack([(uu[use] - w / 2) / f * z, (vv[use] - h / 2) / f * z, z], 1)
    rng = np.random.default_rng(0)
    if len(pts) > 4000:
        pts = pts[rng.choice(len(pts), 4000, replace=False)]
    tol = 0.01 * float(np.median(z))
    best, best_n = None, 0
    for _ in range(300):
        a, b, c = pts[rng.choice(len(pts), 3, replace=False)]
        n = np.cross(b - a, c - a)
        if np.linalg.norm(n) < 1e-12:
            continue
        n /= np.linalg.norm(n)
        count = int((np.abs((pts - a) @ n) < tol).sum())
        if count > best_n:
            best, best_n = (n, a), count
    if best is None:
        return None
    n, a = best
    inl = pts[np.abs((pts - a) @ n) < tol]
    centre = inl.mean(0)
    n = np.linalg.svd(inl - centre)[2][-1]  # least squares over the inliers
    if n[1] > 0:
        n = -n  # up is -y in the camera
    if -n[1] < 0.5:  # a ground tilted more than 60° from the image's vertical is not a floor
        return None
    pitch = math.degrees(math.asin(float(np.clip(-n[2], -1, 1))))
    out = {"pitch_deg": round(pitch, 3), "inliers": int(len(inl)), "metric": bool(depth.metric)}
    if depth.metric:
        out["camera_height_m"] = round(float(abs(centre @ n)), 4)
    return out
