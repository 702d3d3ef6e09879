"""What a run leaves behind: each frame's body poses, deformed surfaces and particles, which of them
moved (only those get time samples), ``sim.usdc`` written from them, and the checks a user asks of a
finished run."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics.geometry import Penetrations, WorldMeshes
from ..usd import layers
from ..usd.author import PARTICLES, write_sim_layer
from .cloth import soft_turn
from .mpm import SURFACE_TYPES, deform_surface, particle_gradients

#: Motion below these (1 mm, 0.11°; solver creep of a resting body stays under them) is "did not
#: move": such prims get no time samples.
STILL_METRES = 1e-3
STILL_RADIANS = 2e-3


@dataclass
class Take:
    """A run's recorded frames, what ``sim.usdc`` is written from: rigid bodies' poses ``body_q``
    (F, B, 7: x, y, z, qx, qy, qz, qw), deformed surfaces ``surfaces`` (prim path → (F, N, 3) local
    points), MPM particles ``mpm_points`` (F, P, 3, or None), the ``plan`` (``stability.StepPlan``) they
    were stepped on, and the ``seconds`` they simulate."""
    plan: object
    body_q: np.ndarray
    surfaces: dict
    mpm_points: np.ndarray | None
    seconds: float

    @property
    def frames(self) -> int:
        return len(self.body_q)


class Recorder:
    """One sample per video frame of everything the writer needs, from a :class:`~.assembly.ShotModels`."""

    def __init__(self, models, frames: int):
        self.models = models
        mpm = models.mpm
        self.body_q = np.zeros((frames, models.model.body_count, 7), np.float32)  # x, y, z, qx, qy, qz, qw
        self.surfaces = {o.path: np.zeros((frames, len(o.points), 3)) for o in models.objects
                         if o.family in ("cloth", "soft") or (mpm and o.family == "mpm" and o.kind in SURFACE_TYPES)}
        self.mpm_points = np.zeros((frames, mpm.model.particle_count, 3), np.float32) if mpm else None
        # read once: a prim's path is a USD call, and a pile's twenty bodies asked for theirs every frame
        self._surfaced = [(o, o.path) for o in models.objects if o.path in self.surfaces]
        self._bound = bool(mpm and any(o.binding is not None for o in mpm.objects))

    def record(self, f: int) -> None:
        m = self.models
        state = m.stepper.state
        if m.model.body_count:
            self.body_q[f] = state.body_q.numpy()
        x = state.particle_q.numpy() if m.model.particle_count else None
        # deformation gradients only move surfaces bound to particles (elastic kinds); sand and liquid have none
        grads = particle_gradients(m.mpm) if self._bound else None
        if m.mpm:
            self.mpm_points[f] = m.mpm.state.particle_q.numpy()
        for o, path in self._surfaced:
            if o.family == "cloth":
                start, count = m.ranges[path]
                sheet = m.cloth_sheets[path]
                # each surface vertex at its rest offset from its particle: add_cloth starts the particles lifted
                # clear of the ground for contact, and the offsets take that lift off, so that frame 0 is the
                # surface as built (the photo) and the cloth rests on what it touches
                world = x[start:start + count].astype(np.float64)[sheet.index] + sheet.offset
            elif o.family == "soft":
                start, count = m.ranges[path]
                now = x[start:start + count].astype(np.float64)
                world = deform_surface(m.soft_bindings[path], now, soft_turn(m.soft_rest[path], now))
            else:
                mo = m.mpm_objects[path]
                pts = self.mpm_points[f, mo.start:mo.start + mo.count].astype(np.float64)
                g = grads[mo.start:mo.start + mo.count] if grads is not None else None
                world = deform_surface(mo.binding, pts, g)
            self.surfaces[path][f] = o.to_local(world)


    def still(self, f0: int, f1: int, bound: float = STILL_METRES) -> bool:
        """Whether nothing moved from frame ``f0`` through ``f1``: no point of a body, surface or particle
        farther than ``bound`` (m) from where it was at ``f0``, a body's turn counted at its farthest point."""
        q = self.body_q[f0:f1 + 1].astype(np.float64)
        if q.shape[1]:
            dots = np.abs(np.einsum("fbi,bi->fb", q[:, :, 3:], q[0, :, 3:]))
            dots /= np.linalg.norm(q[:, :, 3:], axis=2) * np.linalg.norm(q[0, :, 3:], axis=1)
            turn = 2 * np.arccos(np.clip(dots, -1, 1))  # (F, B) rad
            shift = np.linalg.norm(q[:, :, :3] - q[0, :, :3], axis=2)
            if float((shift + turn * self._reach()).max()) > bound:
                return False
        for pts in self.surfaces.values():
            if np.abs(pts[f0:f1 + 1] - pts[f0]).max() > bound:
                return False
        if self.mpm_points is not None and np.abs(self.mpm_points[f0:f1 + 1] - self.mpm_points[f0]).max() > bound:
            return False
        return True

    def _reach(self) -> np.ndarray:
        """(B,) each body's farthest point from its origin at the start (m); 0.1 m for a body no object gives."""
        if getattr(self, "_reach_m", None) is None:
            reach = np.full(self.body_q.shape[1], 0.1)
            objects = {o.path: o for o in self.models.objects}
            for path, b in self.models.path_body.items():
                if path in objects:
                    reach[b] = float(np.linalg.norm(objects[path].points - self.body_q[0, b, :3], axis=1).max())
            self._reach_m = reach
        return self._reach_m

    def take(self, plan, seconds: float) -> Take:
        """The frames recorded, as a :class:`Take` of ``seconds`` stepped on ``plan``."""
        return Take(plan, self.body_q, self.surfaces, self.mpm_points, seconds)

    def truncate(self, frames: int) -> None:
        """Keep the first ``frames`` frames (a run that ended early)."""
        self.body_q = self.body_q[:frames]
        self.surfaces = {p: pts[:frames] for p, pts in self.surfaces.items()}
        if self.mpm_points is not None:
            self.mpm_points = self.mpm_points[:frames]


def moving_tracks(path_body: dict, body_q: np.ndarray, surfaces: dict) -> tuple[dict, dict, list]:
    """Body tracks path → (positions (F, 3), quaternions w, x, y, z (F, 4)) and surface tracks path →
    points (F, N, 3) of what moved, and the moved prims' paths."""
    tracks, point_tracks, moved = {}, {}, []
    for path, b in path_body.items():
        pos = body_q[:, b, :3].astype(np.float64)
        quat = body_q[:, b, [6, 3, 4, 5]].astype(np.float64)  # → w, x, y, z
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        if _moved(pos, quat):
            tracks[path] = (pos, quat)
            moved.append(path)
    for path, pts in surfaces.items():
        if np.abs(pts - pts[0]).max() > STILL_METRES:
            point_tracks[path] = pts
            moved.append(path)
    return tracks, point_tracks, moved


def write_take(folder, models, take: Take, metadata: dict | None = None) -> list[str]:
    """Write ``folder/sim.usdc`` (time samples only for what moved, the previous layer replaced once the
    new one is complete) and the shot's time range from ``take``, frames recorded from ``models`` (a
    :class:`~.assembly.ShotModels`); ``metadata`` adds to the layer's. Returns the moved prims' paths."""
    frames, plan, cfg = take.frames, take.plan, models.cfg
    body_q, surfaces, mpm_points, seconds = take.body_q, take.surfaces, take.mpm_points, take.seconds
    tracks, point_tracks, moved = moving_tracks(models.path_body, body_q, surfaces)
    particles = {}
    if models.mpm:
        for o in models.mpm.objects:
            particles[o.obj.name] = {"points": mpm_points[:, o.start:o.start + o.count], "show": o.binding is None,
                                     "mesh": o.obj.path, "colour": o.colour, "width": models.mpm.spacing}
            moved.append(f"{PARTICLES}/{o.obj.name}")
    meta = {"physomni:solver": cfg.solver, "physomni:substeps": plan.substeps, "physomni:dt": plan.dt,
            "physomni:iterations": plan.iterations, "physomni:seconds": seconds,
            "physomni:solvers": ", ".join(models.solvers)}
    if plan.mpm_steps:
        meta |= {"physomni:mpmSteps": plan.mpm_steps, "physomni:mpmDt": plan.mpm_dt,
                 "physomni:particleSpacing": models.mpm.spacing}
    write_sim_layer(folder / layers.SIM, fps=cfg.fps, frames=frames, tracks=tracks,
                    metadata=meta | (metadata or {}), point_tracks=point_tracks, particles=particles)
    layers.set_shot_time(folder, cfg.fps, frames)
    return moved


def _moved(pos: np.ndarray, quat: np.ndarray) -> bool:
    if np.abs(pos - pos[0]).max() > STILL_METRES:
        return True
    dots = np.abs(quat @ quat[0])
    return float(2 * np.arccos(np.clip(dots.min(), -1, 1))) > STILL_RADIANS


def shot_checks(stage, frames: int) -> dict:
    """What a user asks of a finished run: where objects end up, and whether meshes ever overlap."""
    meshes = WorldMeshes(stage)
    final = meshes.vertices(frames - 1)
    times = [0] if meshes.still() else range(frames)  # nothing moved: every frame is the first
    depth = Penetrations(meshes)
    return {
        "final_lowest_z_m": {name: round(float(v[:, 2].min()), 5) for name, v in final.items()},
        "max_penetration_m": round(max(depth.at(t) for t in times), 5),
    }
