"""A monocular depth model for physomni-usd, through ``transformers``' ``AutoModelForDepthEstimation``.

Registered as the ``depth-anything`` depth estimator (any model that class
loads works: Depth Anything V1/V2, DPT, ZoeDepth, …). Weights: a
``from_pretrained`` folder with its image processor, named by
``PHYSOMNI_DEPTH_WEIGHTS``. Models whose config says
``depth_estimation_type = "metric"`` give metres; the others give relative
inverse depth, turned into depth up to an unknown scale. ``build`` fits a
plane to the ground the model sees and takes the camera's pitch from it.
Importing this module imports no torch.
"""

from __future__ import annotations

import json
import os
import pathlib

import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_DEPTH_WEIGHTS"
WHAT = "a depth model folder saved by transformers' from_pretrained (e.g. depth-anything/Depth-Anything-V2-Small-hf)"
__version__ = "0.1.0"


class DepthAnything:
    """Per-pixel depth of the photo."""

    kind, name = "depth", "depth-anything"

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        return (registry.lacking_modules(("torch", "transformers"), "the depth-anything estimator",
                                         "physomni-depth[models]")
                or registry.weights_problem(ENV, WHAT, "config.json"))

    def __init__(self):
        import torch
        from transformers import AutoImageProcessor, AutoModelForDepthEstimation

        path = self.weights()
        config = json.loads((pathlib.Path(path) / "config.json").read_text())
        self.metric = config.get("depth_estimation_type") == "metric"
        self.device = "cuda" if torch.cuda.is_available() else "cpu"
        self.processor = AutoImageProcessor.from_pretrained(path)
        self.model = AutoModelForDepthEstimation.from_pretrained(path).to(self.device).eval()

    def depth(self, photo: np.ndarray):
        """A ``DepthMap``: (H, W) float32 depth at the photo's size, metric or relative."""
        import cv2
        import torch

        from physomni_usd.swappable.protocols import DepthMap

        inputs = self.processor(images=photo, return_tensors="pt").to(self.device)
        with torch.inference_mode():
            pred = self.model(**inputs).predicted_depth[0].float().cpu().numpy()
        h, w = photo.shape[:2]
        pred = cv2.resize(pred, (w, h), interpolation=cv2.INTER_LINEAR)
        if self.metric:
            return DepthMap(pred.astype(np.float32), True)
        # relative models predict disparity (near = large): invert, keeping it finite
        disparity = np.maximum(pred, 1e-6 * max(float(pred.max()), 1e-6))
        return DepthMap((1.0 / disparity).astype(np.float32), False)
