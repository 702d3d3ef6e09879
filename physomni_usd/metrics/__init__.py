"""Metrics of the paper and of our own checks, as plain functions over arrays."""

from .image import mask_iou, ssim

__all__ = ["mask_iou", "ssim"]
