"""SAM 3 for physomni-usd through ``transformers``: every instance of a phrase ("cup") in the photo.

Registered as the ``sam3`` finder (``build --find 'cup, saucer, spoon'``). Weights: a ``from_pretrained``
folder of ``Sam3Model`` with its tokenizer (``config.json``, the weights, ``tokenizer.json`` or
``vocab.json`` and ``merges.txt``, and the processor's ``preprocessor_config.json``) named by
``PHYSOMNI_SAM3_WEIGHTS``. The photo is resized and normalised here with OpenCV as SAM 3's image
processor does (its own needs torchvision, which the CPU set-up lacks); scores and masks follow its
instance post-processing. Importing this module imports no torch.
"""

from __future__ import annotations

import json
import os
import pathlib

import cv2
import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_SAM3_WEIGHTS"
WHAT = "a SAM 3 folder saved by transformers' from_pretrained (e.g. facebook/sam3)"
#: Lowest score (the query's logit and the phrase's presence, both through a sigmoid) of an instance kept.
SCORE_THRESHOLD = 0.3
#: SAM 3's image processor's defaults, where the folder's preprocessor_config.json does not say.
IMAGE_SIZE = 1008
IMAGE_MEAN = (0.5, 0.5, 0.5)
IMAGE_STD = (0.5, 0.5, 0.5)
#: Tokens of a phrase (SAM 3's text encoder reads 32).
TEXT_LENGTH = 32
__version__ = "0.1.0"


def _preprocessing(folder: pathlib.Path) -> dict:
    """Size (height, width), mean and std of the folder's image processor (its saved config, else SAM 3's)."""
    cfg = {}
    for name in ("preprocessor_config.json", "processor_config.json"):
        p = folder / name
        if p.is_file():
            data = json.loads(p.read_text())
            cfg = data.get("image_processor", data)
            break
    size = cfg.get("size") or {}
    return {"size": (int(size.get("height", IMAGE_SIZE)), int(size.get("width", IMAGE_SIZE))),
            "mean": np.array(cfg.get("image_mean", IMAGE_MEAN), np.float32),
            "std": np.array(cfg.get("image_std", IMAGE_STD), np.float32)}


class Sam3Finder:
    """Instance masks of phrases with SAM 3: the image encoder runs once per photo, the rest once a phrase."""

    kind, name = "finder", "sam3"

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        problem = (registry.lacking_modules(("torch", "transformers"), "the sam3 finder", "physomni-sam3[models]")
                   or registry.weights_problem(ENV, WHAT, "config.json"))
        if problem:
            return problem
        model_type = json.loads((pathlib.Path(cls.weights()) / "config.json").read_text()).get("model_type")
        if model_type != "sam3":
            return f"{ENV}={cls.weights()} holds a {model_type!r} model, not SAM 3: point it at {WHAT}"
        return None

    def __init__(self):
        import torch
        from transformers import AutoTokenizer, Sam3Model

        path = pathlib.Path(self.weights())
        self.device = "cuda" if torch.cuda.is_available() else "cpu"
        self.tokenizer = AutoTokenizer.from_pretrained(path)
        self.model = Sam3Model.from_pretrained(path).to(self.device).eval()
        self.prep = _preprocessing(path)

    def pixels(self, photo: np.ndarray):
        """(1, 3, h, w) float tensor: ``photo`` (H, W, 3) uint8 RGB resized bilinearly, scaled to [0, 1],
        normalised by the processor's mean and std."""
        import torch

        h, w = self.prep["size"]
        img = cv2.resize(photo, (w, h), interpolation=cv2.INTER_LINEAR).astype(np.float32) / 255.0
        img = (img - self.prep["mean"]) / self.prep["std"]
        return torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1)))[None].to(self.device)

    def find(self, photo: np.ndarray, phrases: list[str]) -> list[list[np.ndarray]]:
        """For each phrase, the (H, W) bool masks of its instances scoring above SCORE_THRESHOLD, best first."""
        import torch

        H, W = photo.shape[:2]
        out = []
        with torch.inference_mode():
            vision = self.model.get_vision_features(pixel_values=self.pixels(photo))
            for phrase in phrases:
                text = self.tokenizer([phrase], padding="max_length", max_length=TEXT_LENGTH, truncation=True,
                                      return_tensors="pt")
                result = self.model(vision_embeds=vision, input_ids=text["input_ids"].to(self.device),
                                    attention_mask=text["attention_mask"].to(self.device))
                scores = result.pred_logits[0].sigmoid()
                if result.presence_logits is not None:
                    scores = scores * result.presence_logits[0].sigmoid()
                keep = torch.nonzero(scores > SCORE_THRESHOLD).flatten()
                keep = keep[torch.argsort(scores[keep], descending=True)]
                masks = []
                if len(keep):
                    logits = torch.nn.functional.interpolate(result.pred_masks[0, keep][None].float(), size=(H, W),
                                                             mode="bilinear", align_corners=False)[0]
                    masks = [m.cpu().numpy() > 0 for m in logits]  # sigmoid > 0.5
                out.append(masks)
        return out
