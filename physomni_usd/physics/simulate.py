"""Rigid-body simulation of a shot with Newton, recorded as one sample per video frame."""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
from pxr import Usd, UsdGeom, UsdPhysics

from .._warp import load_warp, pick_device
from ..errors import InputError, PhysOmniError
from ..metrics.geometry import max_penetration, world_meshes
from ..report import update_report
from ..rotations import to_wxyz
from ..settings import SimulateSettings
from ..usd import layers
from ..usd.author import OBJECTS, write_sim_layer
from .checks import MAX_SPEED, check_rigid_inputs
from .forces import FieldSet, body_samples, read_force_fields

SUPPORTED_SOLVERS = ("xpbd",)
#: Newton simplifies convex hulls to this many vertices; its default (64) cuts the corners of
#: lofted meshes by centimetres, which shows as objects sinking into the ground.
MAX_HULL_VERTICES = 256
#: How often a diverging run is retried, each time with twice the substeps.
MAX_RETRIES = 2
#: Motion below these (1 mm, 0.11°; solver creep of a resting body stays under them) is "did not
#: move": such prims get no time samples.
STILL_METRES = 1e-3
STILL_RADIANS = 2e-3


def rigid_bodies(stage: Usd.Stage) -> list[Usd.Prim]:
    """Prims under /World/Objects that carry PhysicsRigidBodyAPI, in stage order."""
    root = stage.GetPrimAtPath(OBJECTS)
    if not root:
        return []
    return [p for p in Usd.PrimRange(root) if p.HasAPI(UsdPhysics.RigidBodyAPI)]


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
        "substeps": int(settings.substeps or attr("physomni:substeps", 10)),
        "iterations": int(settings.iterations or attr("physomni:iterations", 5)),
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
    bodies = rigid_bodies(stage)
    deformables = deformable_objects(stage)
    # objects that are rigid bodies in USD already move as such; the others need a stand-in
    free = [d for d in deformables if not d[0].HasAPI(UsdPhysics.RigidBodyAPI)]
    cloths = [d for d in free if d[1] == "pbd_cloth"]
    standins = [d for d in free if d[1] != "pbd_cloth"]
    if not bodies and not free:
        raise InputError(f"{shot}: no objects to simulate under {OBJECTS}")
    check_rigid_inputs(stage, bodies)
    for prim, kind, _ in [d for d in deformables if d not in cloths]:
        echo(f"simulate: {prim.GetName()} is {kind}; its solver is not in this version, so it moves as a rigid "
             "stand-in (convex hull, its density and friction)")
    frames = int(round(settings.seconds * cfg["fps"])) + 1

    substeps = cfg["substeps"]
    for attempt in range(MAX_RETRIES + 1):
        run = _run(stage, cfg | {"substeps": substeps}, frames, settings.device, progress, standins, cloths)
        if run["ok"]:
            break
        if attempt == MAX_RETRIES:
            raise PhysOmniError(f"simulation diverged at frame {run['frame']} even with {substeps} substeps per "
                                "frame; check the masses, speeds and friction in the shot")
        echo(f"simulate: diverged at frame {run['frame']}; restarting with {substeps * 2} substeps per frame")
        substeps *= 2

    t_write = time.perf_counter()
    q = run["body_q"]  # (F, B, 7): x, y, z, qx, qy, qz, qw
    tracks, moved = {}, []
    for path, b in run["path_body"].items():
        pos = q[:, b, :3].astype(np.float64)
        quat = q[:, b, [6, 3, 4, 5]].astype(np.float64)  # → w, x, y, z
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        if _moved(pos, quat):
            tracks[path] = (pos, quat)
            moved.append(path)
    dt = 1.0 / (cfg["fps"] * substeps)
    meta = {"physomni:solver": cfg["solver"], "physomni:substeps": substeps, "physomni:dt": dt,
            "physomni:iterations": cfg["iterations"], "physomni:seconds": settings.seconds}
    point_tracks = {}
    for path, (start, count, origin) in run["cloth_ranges"].items():
        pts = run["particles"][:, start:start + count].astype(np.float64) - origin
        if np.abs(pts - pts[0]).max() > STILL_METRES:
            point_tracks[path] = pts
            moved.append(path)
    write_sim_layer(folder / layers.SIM, fps=cfg["fps"], frames=frames, tracks=tracks, metadata=meta,
                    point_tracks=point_tracks)
    layers.set_shot_time(folder, cfg["fps"], frames)
    checks = _checks(layers.open_shot(folder), frames)
    t_end = time.perf_counter()

    section = {
        "solver": cfg["solver"], "device": run["device"], "fps": cfg["fps"], "frames": frames,
        "substeps": substeps, "dt": dt, "iterations": cfg["iterations"], "simulated_seconds": settings.seconds,
        "bodies": len(run["path_body"]), "moving_prims": moved,
        "rigid_stand_ins": {prim.GetName(): kind for prim, kind, _ in deformables if kind != "pbd_cloth"
                            or prim.HasAPI(UsdPhysics.RigidBodyAPI)},
        "cloths": {prim.GetName(): {"particles": run["cloth_ranges"][str(prim.GetPath())][1]} for prim, _, _ in
                   cloths}, "retries": attempt, "newton_notes": run["notes"],
        "force_fields": run["fields"],
        "max_speed_m_s": run["max_speed"], **checks,
        "modules": {"torch": "torch" in sys.modules},
        "seconds": {"read": round(run["t_build"] - t_start, 4), "build_model": round(run["t_model"], 4),
                    "step": round(run["t_step"], 4), "write": round(t_end - t_write, 4)},
        "total_seconds": round(t_end - t_start, 4),
        "seconds_per_simulated_second": round(run["t_step"] / max(settings.seconds, 1e-9), 4),
    }
    update_report(folder, simulate=section)
    return section


def deformable_objects(stage: Usd.Stage) -> list[tuple[Usd.Prim, str, Usd.Prim | None]]:
    """Objects whose material needs a solver this version does not build: (prim, material type, material)."""
    from ..materials.report import bound_material, object_prims

    out = []
    for prim in object_prims(stage):
        mat = bound_material(prim)
        kind = mat.GetAttribute("physomni:materialType").Get() if mat else "rigid"
        if kind and kind != "rigid":
            out.append((prim, kind, mat))
    return out


def _add_stand_ins(builder, stage: Usd.Stage, standins, newton, wp) -> dict:
    """Rigid bodies (convex hulls, the material's density and friction) for objects whose deformable
    solver is not built yet, so that the shot still moves; returns their path → body map."""
    import trimesh

    out = {}
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for prim, _kind, mat in standins:
        pts = np.asarray(UsdGeom.Mesh(prim).GetPointsAttr().Get(), float)
        m = np.array(cache.GetLocalToWorldTransform(prim))
        pos = m[3, :3]
        rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=1, keepdims=True)
        q = to_wxyz(rot.T)
        hull = trimesh.convex.convex_hull(pts * np.linalg.norm(m[:3, :3], axis=1))
        cfg = newton.ModelBuilder.ShapeConfig()
        density = mat.GetAttribute("physics:density").Get() if mat else None
        friction = mat.GetAttribute("physics:dynamicFriction").Get() if mat else None
        cfg.density = float(density or 1000.0)
        cfg.mu = float(friction if friction is not None else 0.5)
        body = builder.add_body(xform=wp.transform(tuple(pos), wp.quat(q[1], q[2], q[3], q[0])),
                                label=str(prim.GetPath()))
        builder.add_shape_convex_hull(body, mesh=newton.Mesh(hull.vertices.astype(np.float32),
                                                             hull.faces.ravel().astype(np.int32)), cfg=cfg)
        out[str(prim.GetPath())] = body
    return out


#: XPBD cloth: stiffness is the inverse of the material's compliance, clamped to what the
#: solver keeps stable at our steps (spring N/m, bending N·m).
CLOTH_SPRING_KE = (1e1, 1e2)
CLOTH_BEND_KE = (1e-2, 1e1)


def add_cloths(builder, stage: Usd.Stage, cloths, newton, wp) -> dict:
    """Cloth from each object's own surface (XPBD springs + bending), the highest ``physomni:fixTopRatio``
    of its particles pinned (all of them for a fixed object). Returns path → (first particle, count,
    prim origin in world)."""
    out = {}
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for prim, _kind, mat in cloths:
        mesh = UsdGeom.Mesh(prim)
        pts = np.asarray(mesh.GetPointsAttr().Get(), float)
        faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64).reshape(-1, 3)
        m = np.array(cache.GetLocalToWorldTransform(prim))
        world = pts @ m[:3, :3] + m[3, :3]

        def value(name, default, mat=mat):
            a = mat.GetAttribute(name) if mat else None
            v = a.Get() if a and a.HasAuthoredValue() else None
            return default if v is None else float(v)

        areal = value("physics:density", 4.0)
        stretch = np.clip(1.0 / max(value("physomni:stretchCompliance", 1e-7), 1e-12), *CLOTH_SPRING_KE)
        bend = np.clip(1.0 / max(value("physomni:bendingCompliance", 1e-5), 1e-12), *CLOTH_BEND_KE)
        edges = np.linalg.norm(world[faces[:, 0]] - world[faces[:, 1]], axis=1)
        start = builder.particle_count
        builder.add_cloth_mesh(pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0,
                               vel=wp.vec3(0.0, 0.0, 0.0), vertices=[wp.vec3(*p) for p in world],
                               indices=faces.ravel().tolist(), density=areal, edge_ke=float(bend),
                               add_springs=True, spring_ke=float(stretch), spring_kd=1.0,
                               particle_radius=float(0.25 * np.median(edges)), label=str(prim.GetPath()))
        ratio = 1.0 if prim.GetAttribute("physomni:fixed").Get() else prim.GetAttribute("physomni:fixTopRatio").Get()
        ratio = ratio or 0.0
        if ratio > 0:
            z = world[:, 2]
            cut = z.max() - min(ratio, 1.0) * (z.max() - z.min()) - 1e-9 * (1.0 + abs(z.max()))
            pinned = np.nonzero(z >= cut)[0]
            for i in pinned:
                builder.particle_mass[start + int(i)] = 0.0
        out[str(prim.GetPath())] = (start, len(world), m[3, :3].copy())
    return out


def _moved(pos: np.ndarray, quat: np.ndarray) -> bool:
    if np.abs(pos - pos[0]).max() > STILL_METRES:
        return True
    dots = np.abs(quat @ quat[0])
    return float(2 * np.arccos(np.clip(dots.min(), -1, 1))) > STILL_RADIANS


def _run(stage, cfg, frames, device, progress, standins=(), cloths=()) -> dict:
    """One attempt: build the model, step it, record ``body_q`` each frame; stop at the first non-finite state."""
    t0 = time.perf_counter()
    wp = load_warp()
    device = pick_device(device)
    import newton

    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    result = builder.add_usd(stage, load_visual_shapes=False, load_sites=False, verbose=False,
                             mesh_maxhullvert=MAX_HULL_VERTICES)
    path_body = {p: b for p, b in result["path_body_map"].items() if p.startswith(OBJECTS + "/")}
    path_body.update(_add_stand_ins(builder, stage, standins, newton, wp))
    cloth_ranges = add_cloths(builder, stage, cloths, newton, wp)
    fixed, delayed = read_controls(stage, path_body)
    delayed += [(rng, t, lin, None) for rng, t, lin in cloth_velocities(stage, cloth_ranges)]
    for b in fixed:
        # a kinematic body with no velocity stays put and still collides with everything else
        builder.body_flags[b] = int(newton.BodyFlags.KINEMATIC)
        builder.body_qd[b] = wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    fields = FieldSet(read_force_fields(stage), device)
    if fields:
        points = [np.zeros((1, 3))] * builder.body_count
        for path, b in path_body.items():
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath(path))
            points[b] = np.asarray(mesh.GetPointsAttr().Get(), float) if mesh else np.zeros((1, 3))
        fields.set_body_samples(body_samples(points))
    with wp.ScopedDevice(device), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = builder.finalize(device=device)
        solver = newton.solvers.SolverXPBD(model, iterations=cfg["iterations"])
        state_a, state_b = model.state(), model.state()
        control = model.control()
        # sticky contact matching keeps a resting hull's contact points from frame to frame;
        # without it XPBD lets flat-based hulls creep by millimetres per second
        pipeline = newton.CollisionPipeline(model, contact_matching="sticky")
        contacts = pipeline.contacts()
        t_model = time.perf_counter() - t0
        dt = 1.0 / (cfg["fps"] * cfg["substeps"])
        n_bodies = model.body_count
        record = np.zeros((frames, n_bodies, 7), np.float32)
        no_bodies = np.zeros((0, 7), np.float32)
        record[0] = state_a.body_q.numpy() if n_bodies else no_bodies
        particles = np.zeros((frames, model.particle_count, 3), np.float32) if cloth_ranges else None
        if particles is not None:
            particles[0] = state_a.particle_q.numpy()
        max_speed = float(np.linalg.norm(state_a.body_qd.numpy()[:, :3], axis=1).max()) if n_bodies else 0.0
        t1 = time.perf_counter()
        step = 0
        pending = sorted(delayed, key=lambda d: d[1])
        for f in range(1, frames):
            for _ in range(cfg["substeps"]):
                if pending and pending[0][1] <= step * dt + 1e-9:
                    pending = _give_velocities(state_a, pending, step * dt)
                state_a.clear_forces()
                fields.apply(model, state_a, step * dt, step)
                step += 1
                pipeline.collide(state_a, contacts)
                solver.step(state_a, state_b, control, contacts, dt)
                state_a, state_b = state_b, state_a
            q = state_a.body_q.numpy() if n_bodies else no_bodies
            qd = state_a.body_qd.numpy() if n_bodies else np.zeros((0, 6), np.float32)
            speed = float(np.linalg.norm(qd[:, :3], axis=1).max()) if n_bodies else 0.0
            if particles is not None:
                particles[f] = state_a.particle_q.numpy()
                pv = state_a.particle_qd.numpy()
                speed = max(speed, float(np.linalg.norm(pv, axis=1).max()) if len(pv) else 0.0)
                if not (np.isfinite(particles[f]).all() and np.isfinite(pv).all()):
                    return {"ok": False, "frame": f}
            if not (np.isfinite(q).all() and np.isfinite(qd).all()) or speed > MAX_SPEED:
                return {"ok": False, "frame": f}
            max_speed = max(max_speed, speed)
            record[f] = q
            if progress:
                progress(f, frames - 1)
        t_step = time.perf_counter() - t1
    notes = sorted({str(w.message) for w in caught})
    return {"ok": True, "particles": particles, "cloth_ranges": cloth_ranges, "notes": notes, "fields": [f"{x.kind} {x.path}" for x in fields.fields], "body_q": record, "path_body": path_body, "device": str(device), "t_build": t0,
            "t_model": t_model, "t_step": t_step, "max_speed": round(max_speed, 4)}


def read_controls(stage: Usd.Stage, path_body: dict) -> tuple[set, list]:
    """Fixed bodies, and velocities given after t = 0: ``(body, seconds, linear m/s, angular rad/s)``."""
    fixed, delayed = set(), []
    for path, b in path_body.items():
        prim = stage.GetPrimAtPath(path)
        attr = prim.GetAttribute("physomni:fixed")
        if attr and attr.Get():
            fixed.add(b)
            continue
        lin = prim.GetAttribute("physomni:initialVelocity")
        ang = prim.GetAttribute("physomni:initialAngularVelocity")
        lin = lin.Get() if lin and lin.HasAuthoredValue() else None
        ang = ang.Get() if ang and ang.HasAuthoredValue() else None
        if lin is None and ang is None:
            continue
        at = prim.GetAttribute("physomni:velocityStartTime")
        at = float(at.Get() or 0.0) if at else 0.0
        spin = np.radians(np.asarray(ang, float)) if ang is not None else None
        delayed.append((b, max(at, 0.0), None if lin is None else np.asarray(lin, float), spin))
    return fixed, delayed


def cloth_velocities(stage: Usd.Stage, cloth_ranges: dict) -> list:
    """``physomni:initialVelocity`` of cloths: ((first particle, count), seconds, m/s)."""
    out = []
    for path, (start, count, _) in cloth_ranges.items():
        prim = stage.GetPrimAtPath(path)
        lin = prim.GetAttribute("physomni:initialVelocity")
        if lin and lin.HasAuthoredValue():
            at = prim.GetAttribute("physomni:velocityStartTime").Get() or 0.0
            out.append(((start, count), max(float(at), 0.0), np.asarray(lin.Get(), float)))
    return out


def _give_velocities(state, pending: list, t: float) -> list:
    """Set the velocities that are due at ``t`` (bodies by index, cloths by particle range);
    returns those still pending."""
    due = [d for d in pending if d[1] <= t + 1e-9]
    if any(isinstance(d[0], int) for d in due):
        qd = state.body_qd.numpy()
        for b, _, lin, ang in (d for d in due if isinstance(d[0], int)):
            if lin is not None:
                qd[b, :3] = lin
            if ang is not None:
                qd[b, 3:] = ang
        state.body_qd.assign(qd)
    if any(not isinstance(d[0], int) for d in due):
        pqd = state.particle_qd.numpy()
        for (start, count), _, lin, _ in (d for d in due if not isinstance(d[0], int)):
            pqd[start:start + count] = lin
        state.particle_qd.assign(pqd)
    return [d for d in pending if d[1] > t + 1e-9]


def _checks(stage, frames: int) -> dict:
    """What a user asks of a finished run: where objects end up, and whether meshes ever overlap."""
    final = world_meshes(stage, frames - 1)
    return {
        "final_lowest_z_m": {name: round(float(m.vertices[:, 2].min()), 5) for name, m in final.items()},
        "max_penetration_m": round(max(max_penetration(world_meshes(stage, t)) for t in range(frames)), 5),
    }
