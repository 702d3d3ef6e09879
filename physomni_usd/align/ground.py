"""The ground plane of a scene of reconstructed meshes, and the transform that puts it at z = 0.

Three ways, as in the paper's ablation:

- :func:`canonical_pose` — one object alone: centre it, turn its minor PCA
  axis to +Z (the shortest dimension rests along gravity), set it on z = 0;
- :func:`ransac_plane` — vanilla RANSAC on the lowest points of all meshes
  (the paper's settings: 5,000 samples, lowest 5 %, distance 0.01, 2,000
  iterations, normal within cos 0.8 of the gravity prior, up to 8 retries that
  widen the thresholds). Dense vertical structures (a wall, a standing figure)
  pull it off the floor;
- :func:`agmf_plane` — Anchor-Guided Manifold Fitting: anchors are each
  object's lowest vertices along the camera's gravity prior (within δ of its
  extreme), and the plane minimises a robust (Huber or Tukey) loss of their
  distances by iteratively reweighted least squares. Two refinements of ours:
  the anchors are picked again along the fitted normal until it settles (the
  prior is only the camera's up), and each object keeps its own offset along
  the shared normal, so per-object translation noise cannot tilt the plane.

Randomness is seeded. Fit once and share the result: :func:`ground_transform`
turns a plane into the one rigid transform every later step applies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rotations import between


@dataclass
class Plane:
    normal: np.ndarray  # (3,) unit, pointing up (against gravity)
    offset: float  # n·x + offset = 0
    inliers: int = 0
    method: str = ""

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distances (N,) of points above the plane."""
        return np.asarray(points, float) @ self.normal + self.offset


def _up(normal: np.ndarray, up_prior: np.ndarray) -> np.ndarray:
    normal = normal / np.linalg.norm(normal)
    return -normal if normal @ up_prior < 0 else normal


def fit_plane_lsq(points: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Weighted total-least-squares plane through points (N, 3): (unit normal, offset)."""
    w = np.ones(len(points)) if weights is None else np.asarray(weights, float)
    w = w / max(w.sum(), 1e-300)
    centre = (points * w[:, None]).sum(0)
    d = points - centre
    cov = (d * w[:, None]).T @ d
    _, vecs = np.linalg.eigh(cov)
    n = vecs[:, 0]
    return n, -float(n @ centre)


def canonical_pose(vertices: np.ndarray) -> np.ndarray:
    """4×4 transform putting one mesh in its canonical pose: centred, minor PCA axis on +Z, resting on z = 0."""
    v = np.asarray(vertices, float)
    centre = v.mean(0)
    _, vecs = np.linalg.eigh(np.cov((v - centre).T))
    r = between(vecs[:, 0], np.array([0.0, 0.0, 1.0]))
    moved = (v - centre) @ r.T
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = -r @ centre - np.array([0.0, 0.0, moved[:, 2].min()])
    return m


def _lowest(points: np.ndarray, up: np.ndarray, fraction: float) -> np.ndarray:
    h = points @ up
    return points[h <= np.quantile(h, fraction)]


def ransac_plane(point_sets: list[np.ndarray], up_prior, seed: int = 0, samples: int = 5000,
                 percentile: float = 5.0, distance: float = 0.01, iterations: int = 2000,
                 min_cos: float = 0.8, retries: int = 8) -> Plane:
    """Vanilla RANSAC (the paper's settings) on the lowest points of all meshes together."""
    rng = np.random.default_rng(seed)
    up = np.asarray(up_prior, float) / np.linalg.norm(up_prior)
    pts = np.vstack(point_sets)
    if len(pts) > samples:
        pts = pts[rng.choice(len(pts), samples, replace=False)]
    best = None
    for attempt in range(retries + 1):
        pct = percentile + 5.0 * attempt
        low = _lowest(pts, up, min(pct, 100.0) / 100.0)
        if len(low) < 1000 and pct < 10:
            low = _lowest(pts, up, 0.10)
        tol = distance + 0.005 * attempt
        cos_min = max(min_cos - 0.05 * attempt, 0.5)
        if len(low) < 3:
            break
        idx = rng.integers(0, len(low), size=(iterations, 3))
        a, b, c = low[idx[:, 0]], low[idx[:, 1]], low[idx[:, 2]]
        normals = np.cross(b - a, c - a)
        norms = np.linalg.norm(normals, axis=1)
        ok = norms > 1e-12
        normals[ok] /= norms[ok, None]
        cosines = np.abs(normals @ up)
        ok &= cosines >= cos_min
        if not ok.any():
            continue
        normals, a = normals[ok], a[ok]
        offsets = -np.einsum("ij,ij->i", normals, a)
        counts = (np.abs(low @ normals.T + offsets) <= tol).sum(0)
        k = int(np.argmax(counts))
        inl = low[np.abs(low @ normals[k] + offsets[k]) <= tol]
        n, d = fit_plane_lsq(inl) if len(inl) >= 3 else (normals[k], offsets[k])
        if n @ up < 0:
            n, d = -n, -d
        best = Plane(n, d, int(counts[k]), "ransac")
        break
    if best is None:
        return Plane(up.copy(), -float(np.min(pts @ up)), 0, "ransac-fallback")
    return best


def _robust_weights(r: np.ndarray, kind: str, scale: float) -> np.ndarray:
    a = np.abs(r) / scale
    if kind == "huber":
        k = 1.345
        return np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))
    c = 4.685  # tukey biweight
    return np.where(a < c, (1 - (a / c) ** 2) ** 2, 0.0)


def anchor_points(point_sets: list[np.ndarray], up_prior, delta: float) -> np.ndarray:
    """Each mesh's vertices within ``delta`` of its lowest point along the gravity prior (the anchors)."""
    up = np.asarray(up_prior, float) / np.linalg.norm(up_prior)
    out = []
    for pts in point_sets:
        h = np.asarray(pts, float) @ up
        out.append(pts[h <= h.min() + delta])
    return np.vstack(out)


def agmf_plane(point_sets: list[np.ndarray], up_prior, delta: float | None = None, loss: str = "tukey",
               iterations: int = 30, retries: int = 4, min_cos: float = 0.5) -> Plane:
    """Anchor-Guided Manifold Fitting: a robust (IRLS) plane through every object's base.

    ``delta`` defaults to 2 % of the scene's extent. With a single object the
    anchors all lie on one base, which still fixes a plane; degenerate anchor
    sets (too few, collinear) widen δ and retry, and finally fall back to the
    plane through the lowest point perpendicular to the prior.
    """
    prior = np.asarray(up_prior, float) / np.linalg.norm(up_prior)
    pts = np.vstack(point_sets)
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    delta = 0.02 * extent if delta is None else delta
    for attempt in range(retries + 1):
        plane = _agmf_once(point_sets, prior, delta * (2 ** attempt), loss, iterations, extent, min_cos)
        if plane is None:
            continue
        # the prior is only the camera's up: pick the anchors again along the fitted normal, so that
        # they are each object's base rather than the edge nearest the camera
        for _ in range(ANCHOR_ROUNDS):
            again = _agmf_once(point_sets, plane.normal, delta * (2 ** attempt), loss, iterations, extent, min_cos,
                               prior)
            if again is None or np.degrees(np.arccos(np.clip(again.normal @ plane.normal, -1, 1))) < 0.01:
                plane = again or plane
                break
            plane = again
        return plane
    return Plane(prior.copy(), -float(np.min(pts @ prior)), 0, "agmf-fallback")


#: Times the anchors are re-picked along the fitted normal.
ANCHOR_ROUNDS = 5


def _agmf_once(point_sets, up, delta, loss, iterations, extent, min_cos, prior=None) -> Plane | None:
    """One robust fit through the anchors picked along ``up``; None when they fix no plane.

    The normal is shared by all objects but each object's anchors keep an
    offset of their own: a reconstruction model's per-object translation noise
    then shifts that object's base along the normal instead of tilting the
    plane. With exact poses all offsets agree and this is the paper's plane.
    """
    prior = up if prior is None else prior
    groups = [g for g in (anchor_points([p], up, delta) for p in point_sets) if len(g)]
    anchors = np.vstack(groups) if groups else np.zeros((0, 3))
    if len(anchors) < 3:
        return None
    sv = np.linalg.svd(anchors - anchors.mean(0), compute_uv=False)
    if sv[1] < 1e-6 * max(sv[0], 1e-12):  # collinear anchors fix no plane
        return None
    weights = [np.ones(len(g)) for g in groups]
    n = None
    for _ in range(iterations):
        scatter = np.zeros((3, 3))
        for g, w in zip(groups, weights):
            if w.sum() <= 0:
                continue
            c = (g * w[:, None]).sum(0) / w.sum()
            d = g - c
            scatter += (d * w[:, None]).T @ d
        vals, vecs = np.linalg.eigh(scatter)
        if vals[1] < 1e-12 * max(vals[2], 1e-300):  # the pooled anchors are (nearly) one line
            return None
        n_new = vecs[:, 0] if n is None or vecs[:, 0] @ n >= 0 else -vecs[:, 0]
        done = n is not None and np.linalg.norm(n_new - n) < 1e-9
        n = n_new
        residuals = [g @ n - np.median(g @ n) for g in groups]
        r_all = np.concatenate(residuals)
        scale = 1.4826 * np.median(np.abs(r_all)) + 1e-9 * extent
        weights = [_robust_weights(r, loss, scale) for r in residuals]
        if done:
            break
    if n @ prior < 0:
        n = -n
    offset = -float(min(np.median(g @ n) for g in groups))
    return Plane(n, offset, len(anchors), f"agmf-{loss}") if n @ prior >= min_cos else None


def ground_transform(plane: Plane, point_sets: list[np.ndarray] | None = None) -> np.ndarray:
    """4×4 rigid transform taking the plane's normal to +Z and the plane itself to z = 0.

    With ``point_sets``, the lowest transformed point is put on z = 0 instead
    (the paper's rule when the plane is only a direction estimate).
    """
    r = between(plane.normal, np.array([0.0, 0.0, 1.0]))
    m = np.eye(4)
    m[:3, :3] = r
    m[2, 3] = plane.offset  # a point on the plane (n·x = −offset) lands at z = 0
    if point_sets is not None:
        z = (np.vstack(point_sets) @ r.T)[:, 2]
        m[2, 3] = -z.min()
    return m


def apply(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) through a 4×4 transform."""
    return np.asarray(points, float) @ m[:3, :3].T + m[:3, 3]
