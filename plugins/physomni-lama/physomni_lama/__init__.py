"""The LaMa inpainter for physomni-usd, through TorchScript.

Registered as the ``lama`` inpainter. Weights: LaMa exported to TorchScript
(``big-lama.pt``), named by ``PHYSOMNI_LAMA_WEIGHTS``; it is called as
``model(image, mask)`` with image (1, 3, H, W) in [0, 1] and mask
(1, 1, H, W), 1 in the hole, and returns the filled image (1, 3, H, W) in
[0, 1]. Importing this module imports no torch.
"""

from __future__ import annotations

import os

import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_LAMA_WEIGHTS"
WHAT = "LaMa's TorchScript file (big-lama.pt)"
#: LaMa's encoder downsamples by 8: inputs are padded to a multiple of it.
MULTIPLE = 8
__version__ = "0.1.0"


class LamaInpainter:
    """Fills the objects' hole in the plate with LaMa."""

    kind, name = "inpainter", "lama"

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        return (registry.lacking_modules(("torch",), "the lama inpainter", "physomni-lama[models]")
                or registry.weights_problem(ENV, WHAT))

    def __init__(self):
        import torch

        self.device = "cuda" if torch.cuda.is_available() else "cpu"
        self.model = torch.jit.load(self.weights(), map_location=self.device).eval()

    def inpaint(self, photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
        """(H, W, 3) uint8: the photo with ``hole`` (H, W) bool filled by the model."""
        import torch

        h, w = hole.shape
        ph, pw = -h % MULTIPLE, -w % MULTIPLE
        img = np.pad(photo, ((0, ph), (0, pw), (0, 0)), mode="reflect").astype(np.float32) / 255.0
        msk = np.pad(hole, ((0, ph), (0, pw)), mode="reflect").astype(np.float32)
        image = torch.from_numpy(img).permute(2, 0, 1)[None].to(self.device)
        mask = torch.from_numpy(msk)[None, None].to(self.device)
        with torch.inference_mode():
            out = self.model(image, mask)
        out = out[0].permute(1, 2, 0).float().cpu().numpy()[:h, :w]
        return np.clip(out * 255.0 + 0.5, 0, 255).astype(np.uint8)
