"""Image metrics: SSIM (Wang et al. 2004) and mask IoU."""

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
