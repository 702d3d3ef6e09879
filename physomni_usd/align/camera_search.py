"""Coarse-to-fine camera search: the camera that makes the scene's render agree with the photo.

Variables: camera position (3), viewing direction (yaw, pitch about the
camera's own axes) and vertical field of view. Loss, with the paper's weights:

    L = 1.0·L_obj + 0.2·L_bg + 1.0·(1 − Dice)

where L_obj and L_bg are the mean absolute RGB error (0..1) inside and outside
the union of the target masks, and Dice is averaged over objects. The render is
the background plate with each object's visible silhouette filled with its
mean colour in the photo, at reduced resolution (a quarter for the global
phase, a half for the local one); silhouettes come from the renderer's warp ray
caster, so the search runs on the CPU and on CUDA alike.

Phases: ``global`` draws seeded uniform samples in the bounded box around the
initial camera; ``local`` runs SciPy's bounded Powell from the best point so
far; ``coarse_to_fine`` does both. Every evaluation counts against ``max_evals``
and the loss of each is kept, so the curve can go into the report.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import minimize

from ..rotations import axis_angle
from ..geometry.camera import PinholeCamera
from .external import visible_silhouettes

WEIGHTS = {"obj": 1.0, "bg": 0.2, "mask": 1.0}
#: Best global samples re-scored at the local phase's resolution before Powell starts from the best.
TOP_CANDIDATES = 4
#: Powell runs of the local phase (from the best start, and from the initial camera).
LOCAL_STARTS = 2


@dataclass
class SearchResult:
    camera: PinholeCamera
    loss: float
    initial_loss: float
    evaluations: int
    seconds: float
    curve: list[float] = field(default_factory=list)  # best loss after each evaluation


class CameraLoss:
    """The loss of a camera, ``x = (dx, dy, dz, yaw°, pitch°, fov°)`` relative to ``initial``."""

    def __init__(self, initial: PinholeCamera, vertex_sets, faces, photo, masks, plate=None):
        self.initial = initial
        self.vertex_sets, self.faces = vertex_sets, faces
        self.photo, self.masks = photo, masks
        self.plate = photo if plate is None else plate
        self.colours = [photo[m].mean(axis=0) if m.any() else np.zeros(3) for m in masks]
        from ..geometry.raycast import SilhouetteRenderer

        self.renderer = SilhouetteRenderer(vertex_sets, faces)
        self._levels = {}
        self.evaluations = 0
        self.history: list[float] = []

    def camera(self, x, scale: float = 1.0) -> PinholeCamera:
        dx, dy, dz, yaw, pitch, fov = x
        r0 = self.initial.world_from_camera  # columns: camera x, y, z in world
        rot = axis_angle(r0[:, 1], math.radians(yaw)) @ axis_angle(r0[:, 0], math.radians(-pitch)) @ r0
        w = max(8, int(round(self.initial.width * scale)))
        h = max(8, int(round(self.initial.height * scale)))
        return PinholeCamera.from_pose(w, h, float(fov), self.initial.origin + [dx, dy, dz], rot)

    def _level(self, scale: float):
        if scale not in self._levels:
            w = max(8, int(round(self.initial.width * scale)))
            h = max(8, int(round(self.initial.height * scale)))
            photo = cv2.resize(self.photo, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
            plate = cv2.resize(self.plate, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
            masks = [cv2.resize(m.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST) > 0 for m in self.masks]
            union = np.any(masks, axis=0) if masks else np.zeros((h, w), bool)
            self._levels[scale] = (photo, plate, masks, union)
        return self._levels[scale]

    def __call__(self, x, scale: float = 0.5) -> float:
        photo, plate, masks, union = self._level(scale)
        cam = self.camera(x, scale)
        seen = visible_silhouettes(self.vertex_sets, self.faces, cam, self.renderer)
        render = plate.copy()
        for s, c in zip(seen, self.colours):
            render[s] = c / 255.0
        err = np.abs(render - photo).mean(axis=2)
        l_obj = float(err[union].mean()) if union.any() else 0.0
        l_bg = float(err[~union].mean()) if (~union).any() else 0.0
        dice = [2 * (s & m).sum() / max(s.sum() + m.sum(), 1) for s, m in zip(seen, masks)]
        loss = WEIGHTS["obj"] * l_obj + WEIGHTS["bg"] * l_bg + WEIGHTS["mask"] * (1 - float(np.mean(dice)))
        self.evaluations += 1
        best = min(self.history[-1], loss) if self.history else loss
        self.history.append(best)
        return loss


def search_camera(initial: PinholeCamera, vertex_sets, faces, photo, masks, plate=None, mode="coarse_to_fine",
                  samples: int = 60, max_evals: int = 300, position_range: float | None = None,
                  angle_range: float = 10.0, fov_range: float = 15.0, seed: int = 0) -> SearchResult:
    """Refine ``initial`` so that the scene's render matches the photo and its masks."""
    t0 = time.perf_counter()
    loss = CameraLoss(initial, vertex_sets, faces, photo, masks, plate)
    if position_range is None:
        centre = np.vstack(vertex_sets).mean(0)
        position_range = 0.15 * float(np.linalg.norm(centre - initial.origin))
    lo = np.array([-position_range] * 3 + [-angle_range, -angle_range, max(20.0, initial.fov_deg - fov_range)])
    hi = np.array([position_range] * 3 + [angle_range, angle_range, min(120.0, initial.fov_deg + fov_range)])
    x0 = np.array([0, 0, 0, 0, 0, initial.fov_deg], float)
    mid, half = 0.5 * (hi + lo), 0.5 * (hi - lo)

    def to_x(u):  # Powell works in a unit box so that metres and degrees get comparable steps
        return mid + half * np.clip(u, -1.0, 1.0)

    candidates = [x0]
    if mode in ("global", "coarse_to_fine"):
        rng = np.random.default_rng(seed)
        drawn = rng.uniform(lo, hi, size=(max(0, min(samples, max_evals - 8)), 6))
        coarse = sorted((loss(x, 0.25), i) for i, x in enumerate(drawn))
        candidates += [drawn[i] for _, i in coarse[:TOP_CANDIDATES]]
    scored = sorted((loss(x, 0.5), i) for i, x in enumerate(candidates))
    initial_loss = next(v for v, i in scored if i == 0)
    best, best_x = scored[0][0], candidates[scored[0][1]]
    if mode in ("local", "coarse_to_fine"):
        # Powell from the best start and from the initial camera: a global sample can score better at
        # low resolution yet sit in a worse basin
        starts = [candidates[i] for _, i in scored[:LOCAL_STARTS]]
        if not any(np.array_equal(x, x0) for x in starts):
            starts[-1] = x0
        for k, start in enumerate(starts):
            budget = max(1, (max_evals - loss.evaluations) // (len(starts) - k))
            res = minimize(lambda u: loss(to_x(u), 0.5), (start - mid) / half, method="Powell",
                           bounds=[(-1.0, 1.0)] * 6, options={"maxfev": budget, "xtol": 1e-2, "ftol": 1e-4})
            if res.fun < best:
                best_x, best = to_x(res.x), float(res.fun)
    return SearchResult(loss.camera(best_x, 1.0), best, initial_loss, loss.evaluations,
                        time.perf_counter() - t0, [round(v, 6) for v in loss.history])
