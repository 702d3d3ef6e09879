"""The built-in backends: thin adapters from the protocols to the classical code in perceive/ and materials/."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..swappable.protocols import Prompt


class _Builtin:
    @classmethod
    def missing(cls) -> str | None:
        return None

    @classmethod
    def weights(cls) -> str | None:
        return None


class GrabCutSegmenter(_Builtin):
    """OpenCV GrabCut inside each box (``perceive.masks.mask_from_box``); no points or text."""

    kind, name = "segmenter", "grabcut"

    def segment(self, photo: np.ndarray, prompts: list[Prompt]) -> list[np.ndarray]:
        from ..perceive.masks import mask_from_box

        out = []
        for i, p in enumerate(prompts):
            if p.box is None:
                raise InputError("the grabcut segmenter needs a box per object (--box); "
                                 "points and text need a model segmenter such as --segmenter sam")
            out.append(mask_from_box(photo, ",".join(map(str, p.box)), i).mask)
        return out


class BuiltinInpainter(_Builtin):
    """The classical fill of ``perceive.plate.background_plate``."""

    kind, name = "inpainter", "builtin"

    def inpaint(self, photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
        from ..perceive.plate import background_plate

        return background_plate(photo, [hole], 0.0)

    def plate(self, photo: np.ndarray, masks: list[np.ndarray], dilation: float) -> np.ndarray:
        """The whole plate as ``build`` has always made it (dilation included)."""
        from ..perceive.plate import background_plate

        return background_plate(photo, masks, dilation)


class MirrorOutpainter(_Builtin):
    """The plate mirrored across its edges, softened with the distance from them (``perceive.plate.mirror_outpaint``).

    Seen only when the camera moves: it continues the floor and the walls' colours and textures without
    inventing objects, where an exemplar fill of frame-wide margins repeats whole parts of the scene."""

    kind, name = "outpainter", "mirror"

    def outpaint(self, plate: np.ndarray, margins: tuple[int, int, int, int]) -> np.ndarray:
        from ..perceive.plate import mirror_outpaint

        return mirror_outpaint(plate, margins)


class SilhouetteLifter(_Builtin):
    """Silhouette lofting on the ground (``perceive.lift``): ``build``'s own placement, not a camera pose."""

    kind, name = "lifter", "silhouette"
    #: ``build`` lifts and places with its silhouette path rather than calling :meth:`lift`.
    placement = "ground"

    def lift_world(self, mask, camera, settings):
        from ..perceive.lift import lift_silhouette

        return lift_silhouette(mask, camera, settings)


class RulesEstimator(_Builtin):
    """Label keywords to materials (``materials.rules``)."""

    kind, name = "estimator", "rules"

    def estimate(self, photo, masks, labels, fps):
        from ..materials.rules import estimate_rules

        return estimate_rules(labels, photo, masks)


class VLMEstimator(_Builtin):
    """The paper's prompt to an OpenAI-compatible vision-language server (``materials.vlm``)."""

    kind, name = "estimator", "vlm"

    @classmethod
    def note(cls) -> str:
        import os

        from ..materials.vlm import ENV_MODEL, ENV_URL

        url, model = os.environ.get(ENV_URL), os.environ.get(ENV_MODEL)
        if url and model:
            return f"model {model} at {url}"
        return f"needs {ENV_URL} and {ENV_MODEL} (or estimate --vlm-url and --vlm-model)"

    def __init__(self, settings=None):
        from ..materials.vlm import VLMSettings

        self.settings = settings or VLMSettings.resolve()

    def estimate(self, photo, masks, labels, fps):
        from ..materials.vlm import estimate_vlm

        return estimate_vlm(self.settings, photo, masks, labels, fps)
