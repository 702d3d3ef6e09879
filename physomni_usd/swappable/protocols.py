"""The protocols of the swappable steps: what a backend of each kind takes and returns.

Every backend also carries the class attributes of :class:`Backend` so that
the registry can list it, check it is ready and record it in ``report.json``.
Images are numpy arrays: (H, W, 3) uint8 RGB photos, (H, W) bool masks.
Camera coordinates are OpenCV's (x right, y down, z forward), in metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np


class Backend(Protocol):
    """What the registry needs of every backend class."""

    #: One of :data:`registry.KINDS`.
    kind: ClassVar[str]
    #: The name users pass to ``--segmenter`` etc.
    name: ClassVar[str]

    @classmethod
    def missing(cls) -> str | None:
        """``None`` when the backend can run here, else one line saying what to install or set."""

    @classmethod
    def weights(cls) -> str | None:
        """The weights the backend loads (a path), or ``None`` if it needs none."""


@dataclass
class Prompt:
    """What the user said about one object: a pixel box, clicked points, or words."""

    box: tuple[int, int, int, int] | None = None  # x0, y0, x1, y1 in pixels, x1/y1 exclusive
    points: list[tuple[float, float, bool]] = field(default_factory=list)  # (x, y, belongs to the object)
    text: str | None = None


@runtime_checkable
class Segmenter(Protocol):
    def segment(self, photo: np.ndarray, prompts: list[Prompt]) -> list[np.ndarray]:
        """One (H, W) bool mask per prompt, in order; an empty mask is returned as such (the caller says so)."""


@runtime_checkable
class Inpainter(Protocol):
    def inpaint(self, photo: np.ndarray, hole: np.ndarray) -> np.ndarray:
        """The photo (H, W, 3) uint8 with the ``hole`` (H, W) bool filled in; pixels outside it may be changed,
        the caller keeps the photo's own there."""


@runtime_checkable
class Outpainter(Protocol):
    def outpaint(self, plate: np.ndarray, margins: tuple[int, int, int, int]) -> np.ndarray:
        """The plate (H, W, 3) uint8 widened by (top, bottom, left, right) pixels: (H+t+b, W+l+r, 3) uint8,
        the original pixels at [t:t+H, l:l+W]."""


@dataclass
class LiftedObject:
    """A mesh in its own frame and where it sits in the camera: p_cam = scale·R(rotation)·p_mesh + translation."""

    vertices: np.ndarray  # (N, 3) float, mesh frame
    faces: np.ndarray  # (M, 3) int
    rotation_wxyz: tuple[float, float, float, float]  # unit quaternion, mesh frame → OpenCV camera
    translation: tuple[float, float, float]  # metres, OpenCV camera
    scale: float = 1.0
    #: How the mesh was made, as ``report.json`` names it ('external' for a model's or a user's mesh).
    shape: str = "external"
    #: Lines about the mesh for the report (holes filled, normals made consistent).
    notes: list[str] = field(default_factory=list)
    #: Set only by a lifter that stood the mesh on a ground it measured in the photo (the built-in): the
    #: mesh frame is then that world (z up, ground at z = 0, metres) and this is a
    #: :class:`GroundEvidence`; ``build`` places such meshes on that ground instead of fitting one.
    ground: "GroundEvidence | None" = None


@dataclass
class GroundEvidence:
    """What a lifter that measured the ground tells *place* about one object (mesh frame = world)."""

    camera: object  # geometry.camera.PinholeCamera of the photo, in the world of the mesh
    contact: np.ndarray  # (3,) where the object's outline meets what it stands on (its front foot; a ball
    # rests behind it), world metres
    fixed_depth: bool = False  # seen from above, or a ball seen standing: its depth was measured, not guessed
    support: tuple[int, str] | None = None  # (index of the object it rests on, how that was seen)
    info: dict = field(default_factory=dict)  # how it was lifted, for the report
    scene: dict = field(default_factory=dict)  # what was measured of the whole scene (camera, scale)


@runtime_checkable
class Lifter(Protocol):
    def lift(self, photo: np.ndarray, masks: list[np.ndarray], labels: list[str]) -> list[LiftedObject]:
        """One mesh and camera pose per mask, in order; ``build`` places every lifter's meshes in one scene.

        A lifter whose ``lift`` also takes the keywords ``settings`` (``settings.BuildSettings``), ``names``
        (the objects' prim names) and ``sizes`` (prim name → longest side in metres, the user's ``--size``)
        is given them."""


@dataclass
class DepthMap:
    depth: np.ndarray  # (H, W) float32, along the optical axis: metres if metric, else up to an unknown scale
    metric: bool


@runtime_checkable
class DepthEstimator(Protocol):
    def depth(self, photo: np.ndarray) -> DepthMap:
        """Depth of every pixel of the photo (larger = farther)."""


@runtime_checkable
class Estimator(Protocol):
    def estimate(self, photo: np.ndarray, masks: list[np.ndarray], labels: list[str], fps: float):
        """A ``materials.config.SceneConfig``: one material (and its parameters in SI units) per mask, in order,
        and any force fields; ``fps`` converts frame numbers in an answer to seconds."""


@dataclass
class ControlPasses:
    """The renderer's exact control passes of every frame (see ``render --passes``), at the frames' size."""

    depth: np.ndarray  # (T, H, W) float32, metres along the camera's optical axis, finite everywhere
    object_id: np.ndarray  # (T, H, W) int32, 0 for the environment, 1..K for the objects
    motion: np.ndarray  # (T, H, W, 2) float32, forward motion to the next frame in pixels (+x right, +y down)


@runtime_checkable
class Rerenderer(Protocol):
    def rerender(self, frames: np.ndarray, masks: np.ndarray | None, reference: np.ndarray, *, prompt: str,
                 strength: float, steps: int, seed: int, passes: ControlPasses | None = None) -> np.ndarray:
        """New frames (T, H, W, 3) uint8 from rendered ``frames`` (T, H, W, 3) uint8, the objects' pixels
        ``masks`` (T, H, W) bool (or None), and the photo as ``reference`` (H', W', 3) uint8.
        ``strength`` in (0, 1]: how much of the denoising runs (1 = from pure noise); ``steps``: denoising
        steps actually run. ``passes``: the control passes of the same frames (``masks`` is their
        ``object_id > 0``); a backend whose ``rerender`` takes no ``passes`` keyword is called without it."""
