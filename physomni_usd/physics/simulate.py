"""Simulation of a shot with Newton: each object routed to its material's solver (rigid bodies, cloth
and soft bodies on XPBD, MPM materials on the implicit MPM solver, coupled two-way), steps chosen from
the materials, every frame checked by the stability guard, recorded as one sample per video frame."""

from __future__ import annotations

import re
import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdPhysics

from .._warp import load_warp, pick_device
from ..errors import InputError, PhysOmniError
from ..metrics.geometry import max_penetration, world_meshes
from ..report import update_report
from ..rotations import to_wxyz
from ..settings import SimulateSettings
from ..usd import layers
from ..usd.author import OBJECTS, PARTICLES, author_particle_prims, write_sim_layer
from .checks import check_rigid_inputs
from .cloth import add_cloth, add_soft_body
from .forces import FieldSet, body_samples, read_force_fields
from .mpm import SURFACE_TYPES, add_particle_forces, bind_surface, build_mpm_scene, deform_surface, \
    particle_gradients, step_particles
from .objects import SceneObject, scene_objects
from .stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS, Guard, StepPlan, body_energy, particle_energy, \
    plan_steps

SUPPORTED_SOLVERS = ("xpbd",)
#: Newton simplifies convex hulls to this many vertices; its default (64) cuts the corners of
#: lofted meshes by centimetres, which shows as objects sinking into the ground.
MAX_HULL_VERTICES = 256
#: How often a diverging frame is rolled back and redone, each time with half the step.
MAX_RETRIES = 4
#: Motion below these (1 mm, 0.11°; solver creep of a resting body stays under them) is "did not
#: move": such prims get no time samples.
STILL_METRES = 1e-3
STILL_RADIANS = 2e-3


def scene_settings(stage: Usd.Stage, settings: SimulateSettings) -> dict:
    """Solver, substeps, iterations and fps: the command line's where given, else the stage's."""
    scene = next((p for p in stage.Traverse() if p.IsA(UsdPhysics.Scene)), None)

    def attr(name, default):
        a = scene.GetAttribute(name) if scene else None
        v = a.Get() if a and a.HasAuthoredValue() else None
        return default if v is None else v

    fps = settings.fps or stage.GetTimeCodesPerSecond() or 30.0
    out = {
        "solver": str(attr("physomni:solver", "xpbd")),
        "substeps": int(settings.substeps or attr("physomni:substeps", DEFAULT_SUBSTEPS)),
        "iterations": int(settings.iterations or attr("physomni:iterations", DEFAULT_ITERATIONS)),
        "fps": float(fps),
    }
    if out["solver"] not in SUPPORTED_SOLVERS:
        raise InputError(f"physomni:solver = {out['solver']!r} is not available; use one of {SUPPORTED_SOLVERS}")
    if not 1 <= out["substeps"] <= 1000 or not 1 <= out["iterations"] <= 100:
        raise InputError("physomni:substeps must be in [1, 1000] and physomni:iterations in [1, 100]")
    return out


def simulate_shot(shot, settings: SimulateSettings = SimulateSettings(), progress=None, echo=lambda m: None) -> dict:
    """Simulate the composed stage of ``shot`` and write ``sim.usdc`` beside it; returns the report section."""
    t_start = time.perf_counter()
    folder = layers.shot_folder(shot)
    stage = layers.open_shot(shot, mute_sim=True)
    cfg = scene_settings(stage, settings)
    objects = scene_objects(stage)
    if not objects:
        raise InputError(f"{shot}: no objects to simulate under {OBJECTS}")
    check_rigid_inputs(stage, [o.prim for o in objects if o.family == "rigid" and o.is_body])
    frames = int(round(settings.seconds * cfg["fps"])) + 1

    sim = _Simulation(stage, objects, cfg, settings)
    plan = plan_steps(objects, cfg["fps"], cfg["substeps"], base_iterations=cfg["iterations"], mpm=sim.mpm,
                      acceleration=sim.field_acceleration(settings.seconds), cloth_masses=sim.cloth_masses,
                      field_kinds=[f.kind for f in sim.fields.fields], particles=bool(sim.model.particle_count),
                      cloth_stiffness=sim.cloth_stiffness, soft_dt=sim.soft_dt, fixed_substeps=settings.substeps is not None,
                      mpm_steps=settings.mpm_steps)
    echo(f"simulate: solvers {', '.join(sim.solvers)}; {plan.substeps} substeps per frame"
         + (f", {plan.mpm_steps} MPM steps per frame ({sim.mpm.model.particle_count} particles, "
            f"spacing {sim.mpm.spacing * 1000:.1f} mm)" if sim.mpm else ""))
    run = sim.run(plan, frames, progress, echo)

    t_write = time.perf_counter()
    plan = run["plan"]
    tracks, moved = {}, []
    q = run["body_q"]  # (F, B, 7): x, y, z, qx, qy, qz, qw
    for path, b in sim.path_body.items():
        pos = q[:, b, :3].astype(np.float64)
        quat = q[:, b, [6, 3, 4, 5]].astype(np.float64)  # → w, x, y, z
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        if _moved(pos, quat):
            tracks[path] = (pos, quat)
            moved.append(path)
    point_tracks = {}
    for path, pts in run["surfaces"].items():
        if np.abs(pts - pts[0]).max() > STILL_METRES:
            point_tracks[path] = pts
            moved.append(path)
    particles = {}
    if sim.mpm:
        for o in sim.mpm.objects:
            pts = run["mpm_points"][:, o.start:o.start + o.count]
            particles[o.obj.name] = {"points": pts, "show": o.binding is None, "mesh": o.obj.path,
                                     "colour": o.colour, "width": sim.mpm.spacing}
            moved.append(f"{PARTICLES}/{o.obj.name}")
        author_particle_prims(folder / layers.PHYSICS, {k: (v["colour"], v["width"]) for k, v in particles.items()})
    meta = {"physomni:solver": cfg["solver"], "physomni:substeps": plan.substeps, "physomni:dt": plan.dt,
            "physomni:iterations": plan.iterations, "physomni:seconds": settings.seconds,
            "physomni:solvers": ", ".join(sim.solvers)}
    if plan.mpm_steps:
        meta |= {"physomni:mpmSteps": plan.mpm_steps, "physomni:mpmDt": plan.mpm_dt,
                 "physomni:particleSpacing": sim.mpm.spacing}
    write_sim_layer(folder / layers.SIM, fps=cfg["fps"], frames=frames, tracks=tracks, metadata=meta,
                    point_tracks=point_tracks, particles=particles)
    layers.set_shot_time(folder, cfg["fps"], frames)
    checks = _checks(layers.open_shot(folder), frames)
    t_end = time.perf_counter()

    section = {
        "solver": cfg["solver"], "solvers": list(sim.solvers), "device": sim.device, "fps": cfg["fps"],
        "frames": frames, "substeps": plan.substeps, "dt": plan.dt, "iterations": plan.iterations,
        "steps": plan.as_dict(), "simulated_seconds": settings.seconds,
        "bodies": len(sim.path_body), "moving_prims": moved,
        "objects": {o.name: {"material": o.kind, "solver": o.family} for o in objects},
        "cloths": {o.name: {"particles": sim.ranges[o.path][1]} for o in objects if o.family == "cloth"},
        "soft_bodies": {o.name: {"particles": sim.ranges[o.path][1]} for o in objects if o.family == "soft"},
        "mpm": ({"particles": sim.mpm.model.particle_count, "spacing_m": sim.mpm.spacing,
                 "voxel_m": sim.mpm.solver.voxel_size,
                 "objects": {o.obj.name: o.count for o in sim.mpm.objects}} if sim.mpm else None),
        "guard": run["guard"], "retries": len(run["guard"]["rollbacks"]), "newton_notes": run["notes"],
        "force_fields": [f"{x.kind} {x.path}" for x in sim.fields.fields],
        "max_speed_m_s": run["max_speed"], **checks,
        "modules": {"torch": "torch" in sys.modules},
        "seconds": {"read": round(sim.t_built - t_start - sim.t_model, 4), "build_model": round(sim.t_model, 4),
                    "step": round(run["t_step"], 4), "write": round(t_end - t_write, 4)},
        "total_seconds": round(t_end - t_start, 4),
        "seconds_per_simulated_second": round(run["t_step"] / max(settings.seconds, 1e-9), 4),
    }
    update_report(folder, simulate=section)
    return section


class _Simulation:
    """The Newton models of one shot and how to advance them a frame at a time."""

    def __init__(self, stage: Usd.Stage, objects: list[SceneObject], cfg: dict, settings: SimulateSettings):
        t0 = time.perf_counter()
        wp = load_warp()
        import newton

        self.wp, self.newton = wp, newton
        self.cfg, self.objects = cfg, objects
        self.device = str(pick_device(settings.device))
        builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
        # the stage's rigid bodies come through Newton's USD import; objects whose material now says
        # otherwise (switched by a layer over the build) are left to their own solver
        not_rigid = [o.path for o in objects if o.family != "rigid" and o.is_body]
        result = builder.add_usd(stage, load_visual_shapes=False, load_sites=False, verbose=False,
                                 mesh_maxhullvert=MAX_HULL_VERTICES,
                                 ignore_paths=[re.escape(p) + "$" for p in not_rigid] or None)
        self.path_body = {p: b for p, b in result["path_body_map"].items() if p.startswith(OBJECTS + "/")}
        self.path_body.update(_add_stand_ins(builder, [o for o in objects if o.family == "rigid"
                                                       and not o.is_body], newton, wp))
        self.ranges = {}  # cloth / soft body path → (first particle, count)
        self.soft_bindings = {}  # soft body path → its surface's binding to the tetrahedra
        self.soft_dt = None
        for o in objects:
            if o.family == "cloth":
                self.ranges[o.path] = add_cloth(builder, o, wp)
            elif o.family == "soft":
                start, count, rest, dt_soft = add_soft_body(builder, o, wp)
                self.soft_dt = min(self.soft_dt or dt_soft, dt_soft)
                self.ranges[o.path] = (start, count)
                self.soft_bindings[o.path] = bind_surface(o.points, rest)
        fixed, pushes = read_controls(stage, self.path_body)
        pushes += particle_pushes(stage, self.ranges)
        for b in fixed:
            # a kinematic body with no velocity stays put and still collides with everything else
            builder.body_flags[b] = int(newton.BodyFlags.KINEMATIC)
            builder.body_qd[b] = wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self.fields = FieldSet(read_force_fields(stage), self.device)
        if self.fields:
            points = [np.zeros((1, 3))] * builder.body_count
            for path, b in self.path_body.items():
                mesh = UsdGeom.Mesh(stage.GetPrimAtPath(path))
                points[b] = np.asarray(mesh.GetPointsAttr().Get(), float) if mesh else np.zeros((1, 3))
            self.fields.set_body_samples(body_samples(points))
        with wp.ScopedDevice(self.device), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = builder.finalize(device=self.device)
            # no particle–particle contact: a lofted surface has vertices closer than their radii (near
            # its poles), and pushing those apart threw cloths up; cloth and soft bodies still collide
            # with the ground and the rigid bodies
            model.particle_max_radius = 0.0
            model.particle_grid = None
            self.model = model
            self.solvers = []
            self.solver = None
            if model.body_count or model.particle_count:
                self.solver = newton.solvers.SolverXPBD(model, iterations=cfg["iterations"])
                self.solvers.append("xpbd")
            mpm_objects = [o for o in objects if o.family == "mpm"]
            self.mpm = build_mpm_scene(mpm_objects, model, self.device, settings.particle_spacing) \
                if mpm_objects else None
            self.mpm_objects = {m.obj.path: m for m in self.mpm.objects} if self.mpm else {}
            if self.mpm:
                self.solvers.append("implicit_mpm")
                pushes += particle_pushes(stage, {o.obj.path: (o.start, o.count) for o in self.mpm.objects},
                                          mpm=True)
            self.state, self.state_next = model.state(), model.state()
            self.control = model.control()
            # sticky contact matching keeps a resting hull's contact points from frame to frame;
            # without it XPBD lets flat-based hulls creep by millimetres per second
            self.pipeline = newton.CollisionPipeline(model, contact_matching="sticky") if self.solver else None
            self.contacts = self.pipeline.contacts() if self.pipeline else None
            if self.pipeline:
                # Newton builds the narrow phase's kernels per pipeline, so warp hashes its module again
                # on the first search (~0.5 s here): pay it while setting up, not in the first frame
                self.pipeline.collide(self.state, self.contacts)
        self.notes = [str(w.message) for w in caught]
        self.pending = sorted(pushes, key=lambda p: p.at)
        masses = model.particle_mass.numpy() if model.particle_count else np.zeros(0)
        cloth_idx = [np.arange(s, s + n) for p, (s, n) in self.ranges.items()]
        self.cloth_masses = masses[np.concatenate(cloth_idx)] if cloth_idx else None
        self.cloth_stiffness = max((float(model.spring_stiffness.numpy().max()) if model.spring_count else 0.0), 0.0)
        self.t_model = time.perf_counter() - t0
        self.t_built = time.perf_counter()

    def field_acceleration(self, seconds: float) -> float:
        """Largest acceleration (m/s²) the force fields give at the objects' centres over the run."""
        if not self.fields:
            return 0.0
        centres = np.array([o.points.mean(axis=0) for o in self.objects])
        times = np.linspace(0.0, seconds, 9)
        return max(float(np.linalg.norm(self.fields.acceleration(centres, np.zeros_like(centres), t), axis=1).max())
                   for t in times)

    # --- state -------------------------------------------------------------------------------------
    def energy(self) -> tuple[float, float, bool]:
        e_b, v_b = body_energy(self.model, self.state)
        e_p, v_p = particle_energy(self.model, self.state)
        e_m, v_m = particle_energy(self.mpm.model, self.mpm.state) if self.mpm else (0.0, 0.0)
        finite = all(np.isfinite(a.numpy()).all() for a in self._arrays())
        return e_b + e_p + e_m, max(v_b, v_p, v_m), finite

    def _arrays(self):
        s = self.state
        out = [a for a in (s.body_q, s.body_qd, s.particle_q, s.particle_qd) if a is not None and a.shape[0]]
        if self.mpm:
            out += [self.mpm.state.particle_q, self.mpm.state.particle_qd]
        return out

    def checkpoint(self):
        snaps = [_snapshot(self.state)]
        if self.mpm:
            snaps += [_snapshot(self.mpm.state), {"": self.wp.clone(self.mpm.body_force)}]
        return snaps, list(self.pending)

    def restore(self, saved) -> None:
        snaps, self.pending = saved
        _restore(self.state, snaps[0])
        if self.mpm:
            _restore(self.mpm.state, snaps[1])
            self.mpm.body_force.assign(snaps[2][""])

    # --- stepping ----------------------------------------------------------------------------------
    def advance(self, plan: StepPlan, t0: float, step0: int, guard: Guard, speed: float = 0.0) -> None:
        """One frame from time ``t0``, the fastest body moving at ``speed`` m/s at its start."""
        for p in self.pending:  # a push due in this frame counts as the speed it gives
            if p.at < t0 + 1.0 / plan.fps and p.linear is not None:
                speed = max(speed, float(np.linalg.norm(p.linear)))
        collide_every = plan.collide_interval(speed)
        if self.solver is not None and plan.iterations:
            self.solver.iterations = plan.iterations
        groups = plan.mpm_steps or 1
        per = plan.substeps // groups
        dt = plan.dt
        step = step0
        for _ in range(groups):
            for _ in range(per):
                t = t0 + (step - step0) * dt
                if self.pending and self.pending[0].at <= t + 1e-9:
                    self._give_velocities(t, guard)
                if self.solver is not None:
                    self.state.clear_forces()
                    self.fields.apply(self.model, self.state, t, step)
                    if self.mpm:
                        add_particle_forces(self.mpm, self.state)
                    if (step - step0) % collide_every == 0:
                        self.pipeline.collide(self.state, self.contacts)
                    self.solver.step(self.state, self.state_next, self.control, self.contacts, dt)
                    self.state, self.state_next = self.state_next, self.state
                step += 1
            if self.mpm:
                t = t0 + (step - step0) * dt
                self.mpm.state.clear_forces()
                self.fields.apply(self.mpm.model, self.mpm.state, t, step)
                step_particles(self.mpm, self.model, self.state, plan.mpm_dt)
        if self.fields:
            guard.add_work(self._field_work(t0, step0, 1.0 / plan.fps))

    def _field_work(self, t: float, step: int, seconds: float) -> float:
        """Work (J, signed) the force fields did over the last frame, from the end-of-frame velocities."""
        work = 0.0
        m = self.model
        if m.body_count:
            q, qd = self.state.body_q.numpy(), self.state.body_qd.numpy()
            a = self.fields.acceleration(q[:, :3], qd[:, :3], t, step)
            work += float((m.body_mass.numpy() * np.einsum("ij,ij->i", a, qd[:, :3])).sum()) * seconds
        for model, state in ((m, self.state), (self.mpm.model, self.mpm.state) if self.mpm else (None, None)):
            if model is None or not model.particle_count:
                continue
            x, v = state.particle_q.numpy(), state.particle_qd.numpy()
            a = self.fields.acceleration(x, v, t, step)
            work += float((model.particle_mass.numpy() * np.einsum("ij,ij->i", a, v)).sum()) * seconds
        return work

    def _give_velocities(self, t: float, guard: Guard) -> None:
        """Give the pushes due at ``t``; the kinetic energy they add counts as work for the guard."""
        due = [p for p in self.pending if p.at <= t + 1e-9]
        self.pending = [p for p in self.pending if p.at > t + 1e-9]
        before = self.energy()[0]
        give_velocities(due, self.state, self.mpm.state if self.mpm else None)
        guard.add_work(self.energy()[0] - before)

    def run(self, plan: StepPlan, frames: int, progress, echo) -> dict:
        """Step ``frames − 1`` frames under the guard; a failed frame is rolled back and redone at half the
        step. Returns what the writer needs."""
        wp = self.wp
        guard = Guard()
        rollbacks = []
        n_b = self.model.body_count
        body_q = np.zeros((frames, n_b, 7), np.float32)
        surfaces = {o.path: np.zeros((frames, len(o.points), 3)) for o in self.objects
                    if o.family in ("cloth", "soft") or (self.mpm and o.family == "mpm" and o.kind in SURFACE_TYPES)}
        mpm_points = np.zeros((frames, self.mpm.model.particle_count, 3), np.float32) if self.mpm else None
        with wp.ScopedDevice(self.device):
            energy, speed, finite = self.energy()
            guard.check(energy, speed, finite)
            self._record(0, body_q, surfaces, mpm_points)
            max_speed = speed
            t1 = time.perf_counter()
            t, step, f = 0.0, 0, 1
            while f < frames:
                saved = self.checkpoint()
                work = guard.work
                self.advance(plan, t, step, guard, speed)
                before = speed
                energy, speed, finite = self.energy()
                why = guard.check(energy, speed, finite)
                if why is not None:
                    if len(rollbacks) >= MAX_RETRIES:
                        raise PhysOmniError(f"simulation diverged at frame {f}: {why}, even at {plan.substeps} "
                                            "substeps per frame; check the masses, speeds and stiffness in the shot")
                    self.restore(saved)
                    guard.work = work
                    speed = before
                    plan = plan.refined()
                    rollbacks.append({"frame": f, "why": why, "substeps": plan.substeps, "mpm_steps": plan.mpm_steps})
                    echo(f"simulate: frame {f}: {why}; going back to frame {f - 1} with {plan.substeps} "
                         "substeps per frame")
                    continue
                step += plan.substeps
                t = f / plan.fps
                max_speed = max(max_speed, speed)
                self._record(f, body_q, surfaces, mpm_points)
                if progress:
                    progress(f, frames - 1)
                f += 1
            t_step = time.perf_counter() - t1
        return {"plan": plan, "body_q": body_q, "surfaces": surfaces, "mpm_points": mpm_points,
                "t_step": t_step, "max_speed": round(max_speed, 4), "notes": sorted(set(self.notes)),
                "guard": {"energy_initial_j": guard.initial, "energy_final_j": guard.last_energy,
                          "work_j": guard.work, "tolerance": guard.tolerance, "rollbacks": rollbacks}}

    def _record(self, f: int, body_q, surfaces, mpm_points) -> None:
        if self.model.body_count:
            body_q[f] = self.state.body_q.numpy()
        x = self.state.particle_q.numpy() if self.model.particle_count else None
        # deformation gradients only move surfaces bound to particles (elastic kinds); sand and liquid have none
        bound = self.mpm and any(m.binding is not None for m in self.mpm.objects)
        grads = particle_gradients(self.mpm) if bound else None
        if self.mpm:
            mpm_points[f] = self.mpm.state.particle_q.numpy()
        for o in self.objects:
            if o.path not in surfaces:
                continue
            if o.family == "cloth":
                start, count = self.ranges[o.path]
                world = x[start:start + count].astype(np.float64)
                # add_cloth starts the particles lifted clear of the ground for contact; drawn without that lift,
                # frame 0 is the surface as built (the photo) and the cloth rests on what it touches
                lifts = self.__dict__.setdefault("_cloth_lift", {})
                if f == 0:
                    lifts[o.path] = np.median(world - o.points, axis=0)
                world = world - lifts.get(o.path, 0.0)
            elif o.family == "soft":
                start, count = self.ranges[o.path]
                world = deform_surface(self.soft_bindings[o.path], x[start:start + count].astype(np.float64),
                                       None)
            else:
                mo = self.mpm_objects[o.path]
                pts = mpm_points[f, mo.start:mo.start + mo.count].astype(np.float64)
                g = grads[mo.start:mo.start + mo.count] if grads is not None else None
                world = deform_surface(mo.binding, pts, g)
            surfaces[o.path][f] = o.to_local(world)


def _snapshot(state) -> dict:
    """Copies of every warp array a Newton state holds, namespaced ones (``state.mpm.*``) included."""
    import warp as wp

    out = {}
    for name, value in vars(state).items():
        if isinstance(value, wp.array):
            out[name] = wp.clone(value)
        elif hasattr(value, "__dict__") and not callable(value):
            for sub, arr in vars(value).items():
                if isinstance(arr, wp.array):
                    out[f"{name}.{sub}"] = wp.clone(arr)
    return out


def _restore(state, snapshot: dict) -> None:
    for key, arr in snapshot.items():
        owner = state
        *ns, name = key.split(".")
        for part in ns:
            owner = getattr(owner, part)
        getattr(owner, name).assign(arr)


def _add_stand_ins(builder, objects: list[SceneObject], newton, wp) -> dict:
    """Rigid bodies (convex hulls, the material's density and friction) for rigid objects the stage does
    not make UsdPhysics bodies — ones switched to ``rigid`` by a layer over the build."""
    import trimesh

    out = {}
    for o in objects:
        m = o.matrix
        scale = np.linalg.norm(m[:3, :3], axis=1)
        rot = m[:3, :3] / scale[:, None]
        q = to_wxyz(rot.T)
        local = o.to_local(o.points) * scale
        hull = trimesh.convex.convex_hull(local)
        cfg = newton.ModelBuilder.ShapeConfig()
        cfg.density = float(o.params.get("density") or 1000.0)
        cfg.mu = float(o.params.get("dynamic_friction", 0.5))
        body = builder.add_body(xform=wp.transform(tuple(m[3, :3]), wp.quat(q[1], q[2], q[3], q[0])), label=o.path)
        builder.add_shape_convex_hull(body, mesh=newton.Mesh(hull.vertices.astype(np.float32),
                                                             hull.faces.ravel().astype(np.int32)), cfg=cfg)
        out[o.path] = body
    return out


def _moved(pos: np.ndarray, quat: np.ndarray) -> bool:
    if np.abs(pos - pos[0]).max() > STILL_METRES:
        return True
    dots = np.abs(quat @ quat[0])
    return float(2 * np.arccos(np.clip(dots.min(), -1, 1))) > STILL_RADIANS


@dataclass
class Push:
    """A velocity given at ``at`` seconds to a rigid body (``body``) or to a range of particles
    (``particles`` = (first, count), of the MPM model when ``mpm``)."""
    at: float
    linear: np.ndarray | None  # m/s
    angular: np.ndarray | None = None  # rad/s, bodies only
    body: int | None = None
    particles: tuple[int, int] | None = None
    mpm: bool = False


def read_controls(stage: Usd.Stage, path_body: dict) -> tuple[set, list[Push]]:
    """Fixed bodies, and the velocities ``physomni:initialVelocity`` / ``initialAngularVelocity`` give them."""
    fixed, pushes = set(), []
    for path, b in path_body.items():
        prim = stage.GetPrimAtPath(path)
        if prim.GetAttribute("physomni:fixed").Get():
            fixed.add(b)
            continue
        push = _initial_velocity(prim)
        if push is not None:
            push.body = b
            pushes.append(push)
    return fixed, pushes


def particle_pushes(stage: Usd.Stage, ranges: dict, mpm: bool = False) -> list[Push]:
    """The same for objects made of particles: path → (first particle, count)."""
    pushes = []
    for path, rng in ranges.items():
        push = _initial_velocity(stage.GetPrimAtPath(path))
        if push is not None and push.linear is not None:
            push.particles, push.mpm = rng, mpm
            pushes.append(push)
    return pushes


def _initial_velocity(prim: Usd.Prim) -> Push | None:
    lin = prim.GetAttribute("physomni:initialVelocity")
    ang = prim.GetAttribute("physomni:initialAngularVelocity")
    lin = np.asarray(lin.Get(), float) if lin and lin.HasAuthoredValue() else None
    ang = np.radians(np.asarray(ang.Get(), float)) if ang and ang.HasAuthoredValue() else None
    if lin is None and ang is None:
        return None
    at = prim.GetAttribute("physomni:velocityStartTime")
    return Push(max(float(at.Get() or 0.0) if at else 0.0, 0.0), lin, ang)


def give_velocities(pushes: list[Push], state, mpm_state=None) -> None:
    """Set each push's velocity: bodies in ``state``, particles in ``state`` or (MPM) ``mpm_state``."""
    bodies = [p for p in pushes if p.body is not None]
    if bodies:
        qd = state.body_qd.numpy()
        for p in bodies:
            if p.linear is not None:
                qd[p.body, :3] = p.linear
            if p.angular is not None:
                qd[p.body, 3:] = p.angular
        state.body_qd.assign(qd)
    for target, mine in ((state, [p for p in pushes if p.particles and not p.mpm]),
                         (mpm_state, [p for p in pushes if p.particles and p.mpm])):
        if mine:
            v = target.particle_qd.numpy()
            for p in mine:
                start, count = p.particles
                v[start:start + count] = p.linear
            target.particle_qd.assign(v)


def _checks(stage, frames: int) -> dict:
    """What a user asks of a finished run: where objects end up, and whether meshes ever overlap."""
    final = world_meshes(stage, frames - 1)
    return {
        "final_lowest_z_m": {name: round(float(m.vertices[:, 2].min()), 5) for name, m in final.items()},
        "max_penetration_m": round(max(max_penetration(world_meshes(stage, t)) for t in range(frames)), 5),
    }
