"""The preview's one door into the simulator: the shot prepared exactly as ``simulate`` prepares it
(``physics.prepare``: the same checks, every material, every force field, the artist's layer, the same
step plan), stepped a
frame at a time by ``simulate``'s own guarded loop (``physics.runner.GuardedRun``: the same graphs, the
same bound on start overlaps, the same guard), plus what only a live session has — a hand that pulls
bodies toward the cursor, parameters changed while it runs, a take kept and written by ``simulate``'s
writer under its contract.

Every use of the simulator's internals is in this module, so that the rest of the preview reads the
small API of :class:`Engine` and the simulator can change behind it.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from .._files import all_or_nothing, check_writable, folder_lock
from ..fields import ForceField
from ..physics.forces import FieldSet
from ..physics.prepare import prepare_simulation
from ..physics.recording import Recorder, Take, write_take
from ..physics.runner import GuardedRun
from ..settings import SimulateSettings
from ..usd import layers

#: The hand: a spring-damper toward the cursor, per unit mass so that light and heavy bodies follow
#: alike — 2 Hz, damped at 0.7 of critical, its pull capped at 10 g (Newton's desktop picking caps it too).
HAND_STIFFNESS = (2 * math.pi * 2.0) ** 2  # 1/s²
HAND_DAMPING = 2 * 0.7 * (2 * math.pi * 2.0)  # 1/s
HAND_MAX_ACCELERATION = 10 * 9.81  # m/s²
#: A take keeps at most this many frames (two minutes at 30 fps); later frames are not recorded.
MAX_TAKE_FRAMES = 3600
#: Material parameters a user changes live, and the physics-material attribute each is kept in.
LIVE_PARAMS = {"density": ("physics:density",), "friction": ("physics:staticFriction", "physics:dynamicFriction"),
               "restitution": ("physics:restitution",)}


@lru_cache(maxsize=1)
def _hand_kernel():
    import warp as wp

    @wp.kernel
    def pull(body_q: wp.array(dtype=wp.transform), body_qd: wp.array(dtype=wp.spatial_vector),
             body_com: wp.array(dtype=wp.vec3), body_mass: wp.array(dtype=float), body: wp.array(dtype=wp.int32),
             grab: wp.array(dtype=wp.vec3), target: wp.array(dtype=wp.vec3), gains: wp.array(dtype=wp.vec3),
             body_f: wp.array(dtype=wp.spatial_vector)):
        b = body[0]
        if b < 0:
            return
        m = body_mass[b]
        if m <= 0.0:
            return
        xf = body_q[b]
        com = wp.transform_point(xf, body_com[b])
        p = wp.transform_point(xf, grab[0])
        qd = body_qd[b]
        r = p - com
        v = wp.spatial_top(qd) + wp.cross(wp.spatial_bottom(qd), r)
        k = gains[0]
        a = k[0] * (target[0] - p) - k[1] * v
        n = wp.length(a)
        if n > k[2]:
            a = a * (k[2] / n)
        f = m * a
        body_f[b] = body_f[b] + wp.spatial_vector(f, wp.cross(r, f))

    return pull


class _Hand:
    """The hand's pull on the body it holds, one of the stepper's extra forces: added each substep after
    the force fields (so it follows the same schedule and is captured with the step)."""

    def __init__(self, model, device: str):
        import warp as wp

        self.model = model
        self.device = device
        self.body = wp.array([-1], dtype=wp.int32, device=device)
        self.grab = wp.zeros(1, dtype=wp.vec3, device=device)
        self.target = wp.zeros(1, dtype=wp.vec3, device=device)
        self.gains = wp.array([[HAND_STIFFNESS, HAND_DAMPING, HAND_MAX_ACCELERATION]], dtype=wp.vec3, device=device)

    def __call__(self, model, state, t: float, dt: float) -> None:
        import warp as wp

        if model is self.model and model.body_count:
            wp.launch(_hand_kernel(), dim=1, inputs=[state.body_q, state.body_qd, model.body_com, model.body_mass,
                                                      self.body, self.grab, self.target, self.gains],
                      outputs=[state.body_f], device=self.device)


@dataclass
class LiveObject:
    """One object as the preview shows and changes it."""
    name: str
    path: str
    family: str  # rigid, cloth, soft, mpm
    kind: str  # physomni:materialType
    material: str | None  # path of its bound physics material
    body: int | None  # rigid body index
    params: dict  # the live parameters (density, friction, restitution) it has now
    initial: dict = field(default_factory=dict)  # the same, as the stage has them


class Engine:
    """A shot's simulation, one frame per :meth:`step`; thread-safe for the setters (they apply at the
    next frame boundary)."""

    def __init__(self, shot, capture: bool = True, device: str | None = None):
        self.folder = layers.shot_folder(shot)
        stage = layers.open_shot(shot, mute_sim=True)
        self.settings = SimulateSettings(device=device)
        # its own models, not the last ones simulate built: the preview changes them as it runs
        prep = prepare_simulation(stage, self.settings, name=str(shot), reuse=False)
        self.cfg = prep.config
        self.stage = stage
        self.scene_objects = prep.objects
        sim = self.sim = prep.models
        self.stepper = sim.stepper
        self.wp = sim.wp
        self.device = sim.device
        self.base_plan = prep.plan
        self.hand = _Hand(sim.model, self.device)
        self.stepper.extra_forces.append(self.hand)
        # the preview's guard watches speed and finiteness only (the hand's work is not known), so the
        # fields' work is not summed: no read-back a frame, and the frame can be captured
        self.stepper.count_work = False
        self.field_list = list(sim.fields.fields)
        self.initial_fields = list(self.field_list)
        self._samples = sim.fields.samples.numpy() if sim.fields.samples is not None else None
        self.gravity = self._scene_gravity(stage)
        self.initial_gravity = self.gravity
        self.objects = self._live_objects(prep.objects)
        m = sim.model
        self._mass0 = m.body_mass.numpy().copy() if m.body_count else None
        self._inertia0 = m.body_inertia.numpy().copy() if m.body_count else None
        self._shape_body = m.shape_body.numpy() if m.shape_count else np.zeros(0, int)
        # one frame's poses, surfaces and particles, read as simulate reads them
        self._recorder = Recorder(sim, 1)
        self._lock = threading.Lock()
        self._pending: list = []
        #: wall seconds spent advancing the solvers, and on the rest of a frame (checks, read-back, record)
        self.seconds = {"advance": 0.0, "frame_other": 0.0}
        # the preview's guard watches speed and finiteness only (the hand's work is not known)
        self.run = GuardedRun(self.stepper, self.base_plan, capture=capture, tolerance=math.inf, give_up=False)
        self._reset_counters()

    # --- reading the scene ------------------------------------------------------------------------
    @staticmethod
    def _scene_gravity(stage) -> float:
        from pxr import UsdPhysics

        scene = next((p for p in stage.Traverse() if p.IsA(UsdPhysics.Scene)), None)
        g = UsdPhysics.Scene(scene).GetGravityMagnitudeAttr().Get() if scene else None
        return float(g) if g is not None and g >= 0 else 9.81

    def _live_objects(self, objects) -> list[LiveObject]:
        from ..usd.contract import bound_material

        out = []
        for o in objects:
            mat = bound_material(o.prim)
            body = self.sim.path_body.get(o.path)
            params = {"density": float(o.params.get("density") or 1000.0)}
            if o.family == "rigid":
                params["friction"] = float(o.params.get("dynamic_friction", 0.5))
                params["restitution"] = float(o.params.get("restitution", 0.0))
            out.append(LiveObject(o.name, o.path, o.family, o.kind, str(mat.GetPath()) if mat else None, body,
                                  dict(params), dict(params)))
        return out

    @property
    def fps(self) -> float:
        return float(self.cfg.fps)

    @property
    def body_paths(self) -> dict:
        """Object prim path → rigid body index."""
        return dict(self.sim.path_body)

    # --- the loop ---------------------------------------------------------------------------------
    @property
    def plan(self):
        return self.run.plan

    @property
    def frame(self) -> int:
        return self.run.frame

    @property
    def t(self) -> float:
        return self.run.t

    @property
    def captured_frames(self) -> int:
        return self.run.graphs.captured_frames

    @property
    def captures(self) -> int:
        return self.run.graphs.captures

    @property
    def capture_error(self) -> str | None:
        return self.run.graphs.error

    def _reset_counters(self) -> None:
        self.take_body_q: list[np.ndarray] = []
        self.take_surfaces: dict[str, list[np.ndarray]] = {}
        self.take_mpm: list[np.ndarray] = []
        self.take_full = False
        self._record()

    def step(self) -> None:
        """Advance one frame (1/fps seconds of simulated time) and record it in the take; where the guard
        sends the run back a few frames, the take goes back with it."""
        t0 = time.perf_counter()
        self._apply_pending()
        t1 = time.perf_counter()
        ok = self.run.advance()
        t2 = time.perf_counter()
        self.seconds["advance"] += t2 - t1
        if not ok:
            self._truncate(self.run.frame + 1)
        else:
            self._record()
        self.seconds["frame_other"] += time.perf_counter() - t0 - (t2 - t1)

    def _truncate(self, frames: int) -> None:
        del self.take_body_q[frames:]
        for v in self.take_surfaces.values():
            del v[frames:]
        del self.take_mpm[frames:]
        self.take_full = len(self.take_body_q) >= MAX_TAKE_FRAMES

    def body_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Rigid bodies' poses (B, 7: x, y, z, qx, qy, qz, qw) and velocities (B, 6)."""
        s = self.stepper.state
        if not self.sim.model.body_count:
            return np.zeros((0, 7), np.float32), np.zeros((0, 6), np.float32)
        return s.body_q.numpy(), s.body_qd.numpy()

    def surfaces(self) -> dict[str, np.ndarray]:
        """World points (N, 3) of every deformable surface (cloth, soft bodies, MPM objects bound to a mesh)."""
        return {k: v[-1] for k, v in self.take_surfaces.items()} if self.take_surfaces else {}

    def particles(self) -> dict[str, np.ndarray]:
        """MPM particles (P, 3) per object name."""
        if not self.sim.mpm:
            return {}
        x = self.take_mpm[-1] if self.take_mpm else self.sim.mpm.state.particle_q.numpy()
        return {o.obj.name: x[o.start:o.start + o.count] for o in self.sim.mpm.objects}

    def _record(self) -> None:
        if len(self.take_body_q) >= MAX_TAKE_FRAMES:
            self.take_full = True
            return
        rec = self._recorder
        rec.record(0)
        self.take_body_q.append(rec.body_q[0].copy())
        for p, a in rec.surfaces.items():
            self.take_surfaces.setdefault(p, []).append(a[0].copy())
        if rec.mpm_points is not None:
            self.take_mpm.append(rec.mpm_points[0].copy())

    def world_surface(self, path: str, local: np.ndarray) -> np.ndarray:
        o = next(o for o in self.scene_objects if o.path == path)
        return local @ o.matrix[:3, :3] + o.matrix[3, :3]

    # --- changes, applied between frames ------------------------------------------------------------
    def _later(self, fn, *args) -> None:
        with self._lock:
            self._pending.append((fn, args))

    def _apply_pending(self) -> bool:
        with self._lock:
            todo, self._pending = self._pending, []
        for fn, args in todo:
            fn(*args)
        return bool(todo)

    def sync(self) -> bool:
        """Apply the changes asked for since the last frame without stepping (while paused); whether any."""
        return self._apply_pending()

    def grab(self, body: int, point: np.ndarray) -> None:
        """Take hold of ``body`` at the world ``point`` (m); the grab point moves with the body."""
        self._later(self._grab, int(body), np.asarray(point, float))

    def _grab(self, body: int, point: np.ndarray) -> None:
        q = self.stepper.state.body_q.numpy()[body]
        from scipy.spatial.transform import Rotation

        local = Rotation.from_quat(q[3:7]).inv().apply(point - q[:3])
        self.hand.grab.assign(np.asarray([local], np.float32))
        self.hand.target.assign(np.asarray([point], np.float32))
        self.hand.body.assign(np.asarray([body], np.int32))

    def pull_to(self, target: np.ndarray) -> None:
        """Move the hand to the world point ``target`` (m)."""
        self._later(lambda t: self.hand.target.assign(np.asarray([t], np.float32)), np.asarray(target, float))

    def release(self) -> None:
        self._later(lambda: self.hand.body.assign(np.asarray([-1], np.int32)))

    def set_field(self, index: int, enabled: bool | None = None, strength: float | None = None) -> None:
        """Switch force field ``index`` on or off, or change its strength (m/s²)."""
        f = self.field_list[index]
        changes = {}
        if enabled is not None:
            changes["enabled"] = bool(enabled)
        if strength is not None:
            changes["strength"] = float(strength)
        self.field_list[index] = replace(f, **changes)
        self._later(self._rebuild_fields)

    def _rebuild_fields(self) -> None:
        fs = FieldSet(self.field_list, self.device)
        if self._samples is not None:
            fs.set_body_samples(self._samples)
        self.sim.fields = self.stepper.fields = fs
        self.run.graphs.graphs.clear()

    def set_gravity(self, magnitude: float) -> None:
        """Gravity along −Z, m/s²."""
        self.gravity = float(magnitude)
        self._later(self._apply_gravity, self.gravity)

    def _apply_gravity(self, g: float) -> None:
        from newton import ModelFlags

        for model in [self.sim.model] + ([self.sim.mpm.model] if self.sim.mpm else []):
            model.set_gravity((0.0, 0.0, -g))
        if self.stepper.solver is not None:
            self.stepper.solver.notify_model_changed(ModelFlags.MODEL_PROPERTIES)
        self.run.graphs.graphs.clear()

    def set_param(self, name: str, key: str, value: float) -> None:
        """Change a rigid object's density (kg/m³), friction or restitution while it runs."""
        obj = next(o for o in self.objects if o.name == name)
        if key not in obj.params:
            raise KeyError(f"{name} has no live {key}")
        obj.params[key] = float(value)
        self._later(self._apply_params, obj)

    def _apply_params(self, obj: LiveObject) -> None:
        from newton import ModelFlags

        m, b = self.sim.model, obj.body
        if b is None or not m.body_count:
            return
        if self._mass0[b] > 0:
            s = obj.params["density"] / obj.initial["density"]
            mass, inertia = m.body_mass.numpy(), m.body_inertia.numpy()
            inv_mass, inv_inertia = m.body_inv_mass.numpy(), m.body_inv_inertia.numpy()
            mass[b], inertia[b] = self._mass0[b] * s, self._inertia0[b] * s
            inv_mass[b] = 1.0 / mass[b]
            inv_inertia[b] = np.linalg.inv(inertia[b])
            for arr, val in ((m.body_mass, mass), (m.body_inertia, inertia), (m.body_inv_mass, inv_mass),
                             (m.body_inv_inertia, inv_inertia)):
                arr.assign(val)
        shapes = np.flatnonzero(self._shape_body == b)
        flags = ModelFlags.BODY_INERTIAL_PROPERTIES
        if len(shapes):
            mu = m.shape_material_mu.numpy()
            mu[shapes] = obj.params["friction"]
            m.shape_material_mu.assign(mu)
            if obj.params["restitution"] != obj.initial["restitution"] and m.shape_material_restitution is not None:
                e = m.shape_material_restitution.numpy()
                e[shapes] = obj.params["restitution"]
                m.shape_material_restitution.assign(e)
            flags |= ModelFlags.SHAPE_PROPERTIES
        self.stepper.solver.notify_model_changed(flags)
        self.run.graphs.graphs.clear()

    def reset(self) -> None:
        """Back to frame 0 (the changed parameters stay); the take starts again."""
        self._later(self._reset)

    def _reset(self) -> None:
        self.run.reset()  # the graphs stay: they read the same arrays, restored in place
        self.hand.body.assign(np.asarray([-1], np.int32))
        self._reset_counters()

    # --- keeping --------------------------------------------------------------------------------
    def changed_settings(self) -> list[tuple[str, str, object]]:
        """(prim path, attribute, value) for every parameter that differs from the stage's."""
        out = []
        for o in self.objects:
            for key, value in o.params.items():
                if o.material and not math.isclose(value, o.initial[key], rel_tol=1e-6, abs_tol=1e-9):
                    out += [(o.material, attr, float(value)) for attr in LIVE_PARAMS[key]]
        for f, f0 in zip(self.field_list, self.initial_fields):
            if f.enabled != f0.enabled:
                out.append((f.path, "physomni:enabled", bool(f.enabled)))
            if not math.isclose(f.strength, f0.strength, rel_tol=1e-6):
                out.append((f.path, "physomni:strength", float(f.strength)))
        if not math.isclose(self.gravity, self.initial_gravity, rel_tol=1e-6):
            scene = "/World/PhysicsScene"
            out.append((scene, "physics:gravityMagnitude", float(self.gravity)))
        return out

    def check_writable(self) -> None:
        """Refuse (one line naming the file) a take that could not be written, before any work."""
        check_writable([self.folder / layers.SIM, self.folder / layers.SHOT])

    def write_take(self) -> dict:
        """Write the take (frame 0 to now) to ``sim.usdc`` by ``simulate``'s writer: samples only for prims
        that moved, the previous layer replaced only once the new one is complete. The layer and the shot's
        frame range are written together or not at all, under the shot's lock, never through a link."""
        plan = self.plan
        frames = len(self.take_body_q)
        seconds = max(frames - 1, 0) / plan.fps
        take = Take(plan, np.stack(self.take_body_q), {p: np.stack(v) for p, v in self.take_surfaces.items()},
                    np.stack(self.take_mpm) if self.take_mpm else None, seconds)
        with all_or_nothing(), folder_lock(self.folder):
            self.check_writable()
            moved = write_take(self.folder, self.sim, take, metadata={"physomni:source": "preview"})
        return {"frames": frames, "seconds": seconds, "moving_prims": moved, "path": str(self.folder / layers.SIM)}


def field_label(f: ForceField) -> str:
    return f"{f.path.rsplit('/', 1)[-1]} ({f.kind})"
