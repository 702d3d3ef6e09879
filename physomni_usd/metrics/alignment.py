"""The paper's alignment and physics metrics (appendix, "Evaluation Metrics"), plus our mesh-level penetration.

- mask IoU: rendered silhouette against the ground-truth mask;
- reprojection error: distance in pixels between the centroids of the predicted and true masks;
- penetration rate (PR): fraction of object pairs whose axis-aligned boxes overlap (the paper's);
- mesh penetration rate: fraction of pairs whose meshes interpenetrate by more than 1 mm (ours);
- support violation rate (SVR): fraction of objects whose lowest point is more than 2 cm above the ground;
- interaction success rate (ISR): fraction of frames in which an object's mask covers more than 0.1 %
  of the image.
"""

from __future__ import annotations

import numpy as np
import trimesh

from .geometry import max_penetration
from .image import mask_iou

SUPPORT_TOLERANCE = 0.02  # m
PENETRATION_TOLERANCE = 0.001  # m
ISR_COVERAGE = 0.001  # fraction of the image


def reprojection_px(predicted: np.ndarray, truth: np.ndarray) -> float:
    """Distance in pixels between the centroids of two masks (inf when either is empty)."""
    if not predicted.any() or not truth.any():
        return float("inf")
    py, px = np.nonzero(predicted)
    ty, tx = np.nonzero(truth)
    return float(np.hypot(px.mean() - tx.mean(), py.mean() - ty.mean()))


def box_penetration_rate(meshes: list[trimesh.Trimesh]) -> float:
    """Fraction of pairs whose axis-aligned bounding boxes overlap (0 with fewer than two objects)."""
    pairs = [(a, b) for i, a in enumerate(meshes) for b in meshes[i + 1:]]
    if not pairs:
        return 0.0
    hit = sum(bool(np.all(a.bounds[0] < b.bounds[1]) and np.all(b.bounds[0] < a.bounds[1])) for a, b in pairs)
    return hit / len(pairs)


def mesh_penetration_rate(meshes: list[trimesh.Trimesh], tolerance: float = PENETRATION_TOLERANCE) -> float:
    """Fraction of pairs whose meshes interpenetrate deeper than ``tolerance`` (signed distances)."""
    pairs = [(a, b) for i, a in enumerate(meshes) for b in meshes[i + 1:]]
    if not pairs:
        return 0.0
    return sum(max_penetration({"a": a, "b": b}) > tolerance for a, b in pairs) / len(pairs)


def support_violation_rate(meshes: list[trimesh.Trimesh], tolerance: float = SUPPORT_TOLERANCE) -> float:
    """Fraction of objects floating: lowest point more than ``tolerance`` above z = 0."""
    if not meshes:
        return 0.0
    return sum(m.vertices[:, 2].min() > tolerance for m in meshes) / len(meshes)


def interaction_success_rate(masks_per_frame: list[list[np.ndarray]], coverage: float = ISR_COVERAGE) -> float:
    """Fraction of (frame, object) masks covering more than ``coverage`` of the image."""
    seen = [m.mean() > coverage for frame in masks_per_frame for m in frame]
    return float(np.mean(seen)) if seen else 0.0


__all__ = ["box_penetration_rate", "interaction_success_rate", "mask_iou", "mesh_penetration_rate",
           "reprojection_px", "support_violation_rate"]
