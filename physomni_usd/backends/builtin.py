"""The built-in backends: thin adapters from the protocols to the classical code in perceive/, lift/, texture/,
align/ and materials/."""

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
    """The classical fill of ``texture.fill.background_plate``."""

    kind, name = "inpainter", "builtin"

    def inpaint(self, photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
        from ..texture.fill import background_plate

        return background_plate(photo, [hole], 0.0)

    def plate(self, photo: np.ndarray, masks: list[np.ndarray], dilation: float,
              sources: np.ndarray | None = None, camera=None, weight: np.ndarray | None = None) -> np.ndarray:
        """The whole plate as ``build`` has always made it (dilation included); ``sources``, ``weight`` and
        ``camera`` (the ground's, when measured: the floor's part of the hole is then filled top-down) as
        ``texture.fill.background_plate`` takes them."""
        from ..texture.fill import background_plate

        return background_plate(photo, masks, dilation, sources=sources, camera=camera, weight=weight)


class MirrorOutpainter(_Builtin):
    """The plate mirrored across its edges, softened with the distance from them (``texture.outpaint.mirror_outpaint``).

    Seen only when the camera moves: every margin is the photo reflected, so an orbit shows the scene again
    as in a mirror; kept for shots that want no invented texture at all (``build --outpainter mirror``)."""

    kind, name = "outpainter", "mirror"

    def outpaint(self, plate: np.ndarray, margins: tuple[int, int, int, int]) -> np.ndarray:
        from ..texture.outpaint import mirror_outpaint

        return mirror_outpaint(plate, margins)


class SilhouetteLifter(_Builtin):
    """Silhouette lofting (``lift.silhouette``) on the ground it measures in the photo (``align.photo_scene``).

    Its meshes come in the world of that ground with the camera that sees it (``LiftedObject.ground``)."""

    kind, name = "lifter", "silhouette"

    def lift(self, photo, masks, labels, *, settings=None, names=None, sizes=None, visible=None):
        from ..align.photo_scene import lift_photo_scene
        from ..rotations import to_wxyz
        from ..settings import BuildSettings
        from .protocols import GroundEvidence, LiftedObject

        names = names or [f"{label}_{i}" for i, label in enumerate(labels)]
        found = lift_photo_scene(masks, labels, names, photo, settings or BuildSettings(), sizes or {},
                                 visible=visible)
        camera = found.camera
        # the protocol's pose: the world (each mesh's frame) → OpenCV camera
        to_camera = camera.world_from_camera.T
        pose = dict(rotation_wxyz=tuple(float(x) for x in to_wxyz(to_camera)),
                    translation=tuple(float(x) for x in -to_camera @ camera.origin))
        return [LiftedObject(m.vertices, m.faces, shape=m.shape, **pose,
                             ground=GroundEvidence(camera, m.contact, _depth_measured(m.info),
                                                   found.supports.get(i), m.info, found.info))
                for i, m in enumerate(found.lifted)]


def _depth_measured(info: dict) -> bool:
    """Whether a lift measured its object's depth (``GroundEvidence.fixed_depth``): seen from above, or a ball
    seen standing (round about its own axis, as deep as it is wide). Squashed behind its foot as a guessed
    depth is, a ball kept its front half and lost its back's, its centre of mass ahead of where it rests."""
    return info.get("mode") == "footprint" or info.get("axis") == "ball"


class MeshFolderLifter(_Builtin):
    """The meshes and camera poses a folder holds (``build --meshes``: ``poses.json`` and one mesh per label)."""

    kind, name = "lifter", "meshes"

    def __init__(self, folder):
        self.folder = folder

    def lift(self, photo, masks, labels):
        import numpy as np

        from ..align.external import read_poses
        from .protocols import LiftedObject

        return [LiftedObject(np.asarray(mesh.vertices), np.asarray(mesh.faces), wxyz, tuple(t), s)
                for mesh, wxyz, t, s in read_poses(self.folder, labels)]


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


class ExemplarOutpainter(_Builtin):
    """The plate's margins quilted from its own surfaces (``texture.outpaint.exemplar_outpaint``): camera moves
    reveal more floor, table and wall, and no mirrored copy of the photo. The default."""

    kind, name = "outpainter", "exemplar"

    def outpaint(self, plate: np.ndarray, margins: tuple[int, int, int, int]) -> np.ndarray:
        from ..texture.outpaint import exemplar_outpaint

        return exemplar_outpaint(plate, margins)
