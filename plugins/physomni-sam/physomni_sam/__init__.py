"""SAM and SAM 2 segmenters for physomni-usd, through ``transformers``, from boxes and points.

Registered as the ``sam`` segmenter. Weights: a ``from_pretrained`` folder
(``config.json``, weights and the processor's ``preprocessor_config.json``)
named by ``PHYSOMNI_SAM_WEIGHTS``; its ``model_type`` (``sam`` or ``sam2``)
picks the model class. Importing this module imports no torch.
"""

from __future__ import annotations

import importlib.util
import json
import os
import pathlib

import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_SAM_WEIGHTS"
WHAT = "a SAM or SAM 2 folder saved by transformers' from_pretrained (e.g. facebook/sam-vit-base)"
__version__ = "0.1.0"


class SamSegmenter:
    """Masks from boxes and clicked points with a SAM-family model."""

    kind, name = "segmenter", "sam"

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        problem = (registry.lacking_modules(("torch", "transformers"), "the sam segmenter", "physomni-sam[models]")
                   or registry.weights_problem(ENV, WHAT, "config.json"))
        if problem:
            return problem
        config = pathlib.Path(cls.weights()) / "config.json"
        sam2 = json.loads(config.read_text()).get("model_type", "").startswith("sam2")
        if sam2 and importlib.util.find_spec("torchvision") is None:
            return "SAM 2's image processor needs torchvision: pip install 'physomni-sam[sam2]'"
        return None

    def __init__(self):
        import torch

        path = self.weights()
        model_type = json.loads((pathlib.Path(path) / "config.json").read_text()).get("model_type", "sam")
        if model_type.startswith("sam2"):
            from transformers import Sam2Model as Model, Sam2Processor as Processor
        else:
            from transformers import SamModel as Model, SamProcessor as Processor
        self.sam2 = model_type.startswith("sam2")
        self.device = "cuda" if torch.cuda.is_available() else "cpu"
        self.processor = Processor.from_pretrained(path)
        self.model = Model.from_pretrained(path).to(self.device).eval()

    def segment(self, photo: np.ndarray, prompts) -> list[np.ndarray]:
        """One (H, W) bool mask per prompt (box and/or points; SAM understands no text).

        The image encoder, the costly part, runs once per photo; each prompt then
        costs one pass of the small prompt encoder and mask decoder.
        """
        import torch

        with torch.inference_mode():
            pixels = self.processor(images=photo, return_tensors="pt")["pixel_values"].to(self.device)
            embeddings = self.model.get_image_embeddings(pixels)
        out = []
        for p in prompts:
            if p.box is None and not p.points:
                raise ValueError("the sam segmenter needs a box or points per object")
            kwargs = {}
            if p.box is not None:
                kwargs["input_boxes"] = [[[float(c) for c in p.box]]]
            if p.points:
                # images × objects × points × (x, y), and images × objects × points labels (1 = on the object)
                kwargs["input_points"] = [[[[float(x), float(y)] for x, y, _ in p.points]]]
                kwargs["input_labels"] = [[[int(bool(k)) for _, _, k in p.points]]]
            inputs = self.processor(images=photo, return_tensors="pt", **kwargs)
            sizes = [inputs.pop(k) for k in ("original_sizes", "reshaped_input_sizes") if k in inputs]
            inputs.pop("pixel_values")
            with torch.inference_mode():
                result = self.model(image_embeddings=embeddings, multimask_output=False,
                                    **{k: v.to(self.device) for k, v in inputs.items()})
            masks = self.processor.post_process_masks(result.pred_masks.cpu(), *sizes)
            out.append(np.asarray(masks[0]).reshape(-1, *photo.shape[:2])[0].astype(bool))
        return out
