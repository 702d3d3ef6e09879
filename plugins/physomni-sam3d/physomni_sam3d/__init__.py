"""SAM 3D Objects as a lifter for physomni-usd: one mesh and camera pose per mask.

Registered as the ``sam3d`` lifter. It runs SAM 3D Objects' inference
pipeline (the package ``sam3d_objects``, installed from its own repository)
built from the ``pipeline.yaml`` named by ``PHYSOMNI_SAM3D_CONFIG`` (the
checkpoints lie beside it). Each object's output — a mesh in its own frame
and a pose local → camera (rotation quaternion wxyz, translation, scale) —
is turned into what ``build --meshes`` reads, so that the paper's scene
alignment (ground plane, contact, silhouettes, separation) runs on it.

SAM 3D gives poses in PyTorch3D's camera frame (x left, y up, z forward);
:data:`TO_OPENCV` turns them into OpenCV's (x right, y down, z forward).
Importing this module imports no torch.
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_SAM3D_CONFIG"
WHAT = "SAM 3D Objects' checkpoints/<tag>/pipeline.yaml (its checkpoints beside it)"
#: The Python packages SAM 3D Objects installs under (the first one found is used).
MODULES = ("sam3d_objects", "sam_3d_objects")
#: PyTorch3D camera axes → OpenCV camera axes.
TO_OPENCV = np.diag([-1.0, -1.0, 1.0])
__version__ = "0.1.0"


def _module() -> str | None:
    for name in MODULES:
        try:
            if importlib.util.find_spec(name) is not None:
                return name
        except ValueError:  # a module put in sys.modules without a spec
            import sys

            if name in sys.modules:
                return name
    return None


def load_pipeline(config_path: str):
    """SAM 3D Objects' inference pipeline from its hydra config (as its own notebook API builds it)."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    config = OmegaConf.load(config_path)
    config.rendering_engine = "pytorch3d"
    config.compile_model = False
    config.workspace_dir = os.path.dirname(os.path.abspath(config_path))
    return instantiate(config)


def _array(x) -> np.ndarray:
    if hasattr(x, "detach"):
        x = x.detach().float().cpu().numpy()
    return np.asarray(x, float)


def _mesh(output: dict):
    """(vertices (N, 3), faces (M, 3)) of one output: its ``glb`` (a trimesh mesh or scene) or ``mesh``."""
    import trimesh

    mesh = output.get("glb")
    if mesh is None:
        mesh = output.get("mesh")
        if isinstance(mesh, (list, tuple)):
            mesh = mesh[0]
    if isinstance(mesh, trimesh.Scene):
        mesh = mesh.dump(concatenate=True)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return _array(mesh.vertices), np.asarray(_array(mesh.faces), np.int64)
    raise ValueError("SAM 3D Objects returned no mesh (run it with mesh decoding)")


def to_camera_pose(output: dict):
    """A ``LiftedObject`` (OpenCV camera) from one SAM 3D Objects output dict."""
    from physomni_usd.swappable.protocols import LiftedObject
    from physomni_usd.rotations import from_wxyz, to_wxyz

    verts, faces = _mesh(output)
    q = _array(output["rotation"]).reshape(-1)[:4]
    t = _array(output["translation"]).reshape(-1)[:3]
    s = _array(output["scale"]).reshape(-1)
    rotation = TO_OPENCV @ from_wxyz(q / np.linalg.norm(q))
    return LiftedObject(verts, faces, tuple(to_wxyz(rotation)), tuple(TO_OPENCV @ t), float(s[0]))


class Sam3DLifter:
    """Meshes and poses from SAM 3D Objects, one inference per mask."""

    kind, name = "lifter", "sam3d"
    seed = 42

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        if _module() is None:
            return ("the sam3d lifter needs SAM 3D Objects (package sam3d_objects), installed from "
                    "github.com/facebookresearch/sam-3d-objects with its [inference] extra, and torch")
        return registry.weights_problem(ENV, WHAT)

    def __init__(self):
        self.pipeline = load_pipeline(self.weights())

    def lift(self, photo: np.ndarray, masks: list[np.ndarray], labels: list[str]):
        out = []
        for mask in masks:
            rgba = np.dstack([photo[..., :3], mask.astype(np.uint8) * 255])
            output = self.pipeline.run(rgba, None, self.seed, stage1_only=False, with_mesh_postprocess=False,
                                       with_texture_baking=False, with_layout_postprocess=True,
                                       use_vertex_color=True, stage1_inference_steps=None, pointmap=None)
            out.append(to_camera_pose(output))
        return out
