"""Metrics of the paper and of our own checks, as plain functions over arrays."""

from .geometry import max_penetration, overlaps, rest_drift, world_meshes
from .image import mask_iou, mirror_similarity, ssim

__all__ = ["mask_iou", "mirror_similarity", "max_penetration", "overlaps", "rest_drift", "ssim", "world_meshes"]
