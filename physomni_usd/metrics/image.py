"""Image metrics: SSIM (Wang et al. 2004), mask IoU, and how much a widened plate's margins mirror it."""

from __future__ import annotations

import cv2
import numpy as np

_C1 = (0.01 * 255) ** 2
_C2 = (0.03 * 255) ** 2


def ssim(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Mean structural similarity of two uint8 images (H, W[, 3]), Gaussian window σ = 1.5.

    Colour images are compared channel by channel and averaged; with ``mask``
    (H, W) bool only the SSIM map inside it is averaged.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} vs {b.shape}")
    if a.ndim == 3:
        maps = [_ssim_map(a[..., c], b[..., c]) for c in range(a.shape[2])]
        m = np.mean(maps, axis=0)
    else:
        m = _ssim_map(a, b)
    return float(m[mask].mean() if mask is not None else m.mean())


def _ssim_map(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    blur = lambda im: cv2.GaussianBlur(im, (11, 11), 1.5)  # noqa: E731
    mx, my = blur(x), blur(y)
    sxx = blur(x * x) - mx * mx
    syy = blur(y * y) - my * my
    sxy = blur(x * y) - mx * my
    return ((2 * mx * my + _C1) * (2 * sxy + _C2)) / ((mx * mx + my * my + _C1) * (sxx + syy + _C2))


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (1.0 when both are empty)."""
    a = np.asarray(a, bool)
    b = np.asarray(b, bool)
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else 1.0


#: The strips :func:`mirror_similarity` compares: their depth across each edge, as a fraction of the plate's
#: side across it, after a seam of MIRROR_SEAM of its longer side (where any fill may blend in from the edge).
MIRROR_STRIP = 0.15
MIRROR_SEAM = 0.02


def mirror_similarity(wide: np.ndarray, margins: tuple[int, int, int, int]) -> float:
    """The largest, over the four margins of ``wide`` (H, W, 3) uint8 (the plate widened by (top, bottom, left,
    right) pixels), of the normalised cross-correlation of the margin's fine detail (grey minus its
    Gaussian blur, σ 2 px, less its mean across the edge) with that of the plate's own strip reflected across
    the same edge: near 1 where a margin is the photo mirrored, near 0 where it is anything else."""
    t, b, l, r = (int(m) for m in margins)
    grey = cv2.cvtColor(np.ascontiguousarray(wide), cv2.COLOR_RGB2GRAY).astype(np.float32)
    detail = grey - cv2.GaussianBlur(grey, (0, 0), 2.0)
    H, W = grey.shape
    h, w = H - t - b, W - l - r
    seam = int(round(MIRROR_SEAM * max(h, w)))
    dy, dx = max(4, int(MIRROR_STRIP * h)), max(4, int(MIRROR_STRIP * w))
    rows, cols = slice(t, t + h), slice(l, l + w)
    pairs = []  # (margin strip, the plate's strip reflected onto it, the axis across the edge)
    if t > seam + dy and h > seam + dy + 1:
        pairs.append((detail[t - seam - dy:t - seam, cols], detail[t + seam + 1:t + seam + dy + 1, cols][::-1], 0))
    if b > seam + dy and h > seam + dy + 1:
        e = t + h - 1
        pairs.append((detail[e + seam + 1:e + seam + dy + 1, cols], detail[e - seam - dy:e - seam, cols][::-1], 0))
    if l > seam + dx and w > seam + dx + 1:
        pairs.append((detail[rows, l - seam - dx:l - seam], detail[rows, l + seam + 1:l + seam + dx + 1][:, ::-1], 1))
    if r > seam + dx and w > seam + dx + 1:
        e = l + w - 1
        pairs.append((detail[rows, e + seam + 1:e + seam + dx + 1], detail[rows, e - seam - dx:e - seam][:, ::-1], 1))
    best = 0.0
    for a, m, across in pairs:
        # what does not change across the edge (a horizon running into a side margin) continues the same in
        # a mirror and in any other fill: only what changes across it tells them apart
        a, m = a - a.mean(across, keepdims=True), m - m.mean(across, keepdims=True)
        a, m = a.ravel(), m.ravel()
        best = max(best, float(a @ m / (np.linalg.norm(a) * np.linalg.norm(m) + 1e-9)))
    return best
