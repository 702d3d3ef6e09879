"""The Newton models of one shot, assembled from the composed stage: rigid bodies through Newton's USD
import (plus stand-ins for objects switched to rigid by a layer), cloth and soft bodies, the MPM
scene, fixed bodies, pushes and force fields, and the :class:`~.stepping.Stepper` that advances them;
:func:`shot_models` keeps the last one built, so that a process simulating the same composed stage again
(a bench, a batch, a script calling ``simulate_shot`` twice) reuses its model and its captured graphs."""

from __future__ import annotations

import re
import time
import warnings

import numpy as np
from pxr import Usd, UsdGeom

from .._warp import load_newton, load_warp, pick_device
from ..rotations import to_wxyz
from ..settings import SimulateSettings
from ..usd import layers
from ..usd.author import OBJECTS
from .cloth import AirDrag, ShapeDamping, add_cloth, add_soft_body
from .controls import particle_pushes, read_controls
from .depenetration import lift_out
from ..fields import FIELD_KIND, read_force_fields
from .forces import FieldSet, body_samples
from .mpm import bind_surface, build_mpm_scene
from .objects import SimObject
from .params import ParticleValues, particle_values
from .pieces import add_decomposed, is_decomposed
from .stability import SceneConfig
from .stepping import FrameGraphs, Stepper, contact_pipeline, xpbd_solver
from .round import round_balls
from .support import add_hidden_support

#: Newton simplifies convex hulls to this many vertices; its default (64) cuts the corners of
#: lofted meshes by centimetres, which shows as objects sinking into the ground. A lifted sphere's hull has
#: 629: cut to 256, it kept 4 of the 10 vertices of the flat foot the build gives it (``physics.support.
#: flat_foot``), its centre of mass on that patch's edge, and a lemon alone on the table rolled 25 mm.
MAX_HULL_VERTICES = 1024


class ShotModels:
    """The Newton models of one shot and the stepper that advances them, built as Newton's own examples
    build a scene: a model builder filled (rigid bodies, cloth and soft bodies, controls, force fields),
    finalized into a model, its solvers made, and a stepper over its states."""

    def __init__(self, stage: Usd.Stage, objects: list[SimObject], cfg: SceneConfig, settings: SimulateSettings,
                 shared: ParticleValues | None = None):
        """``shared``: :func:`~.params.particle_values` of ``objects``, when the caller has them already."""
        self.stage = stage
        self.shared = shared or particle_values(objects)
        t0 = time.perf_counter()
        wp, newton = load_warp(), load_newton()
        self.wp, self.newton = wp, newton
        self.cfg, self.objects = cfg, objects
        self.device = str(pick_device(settings.device))
        builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
        self._add_rigid_bodies(builder)
        self._add_deformables(builder, settings.substeps)
        pushes = self._add_controls(builder)
        self._add_fields(builder)
        with wp.ScopedDevice(self.device), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = self.model = self._finalize(builder)
            solver = self._add_solvers(model, settings)
            self._add_stepper(model, solver, pushes)
        self.notes = [str(w.message) for w in caught]
        self.notes += [f"{path.rsplit('/', 1)[-1]} started inside what it touches: moved out by {d * 1000:.1f} mm, "
                       "as a whole, before the first step" for path, d in self.lifted.items()]
        masses = model.particle_mass.numpy() if model.particle_count else np.zeros(0)
        cloth_idx = [np.arange(s, s + n) for p, (s, n) in self.ranges.items()]
        self.cloth_masses = masses[np.concatenate(cloth_idx)] if cloth_idx else None
        # the stiffest spring on each cloth particle
        stiffest = np.zeros(len(masses))
        if model.spring_count:
            ends = model.spring_indices.numpy().reshape(-1, 2)
            k = model.spring_stiffness.numpy()
            np.maximum.at(stiffest, ends[:, 0], k)
            np.maximum.at(stiffest, ends[:, 1], k)
        self.cloth_stiffness = stiffest[np.concatenate(cloth_idx)] if cloth_idx else 0.0
        self.t_model = time.perf_counter() - t0
        self.t_built = time.perf_counter()
        with wp.ScopedDevice(self.device):
            self._start = self.stepper.checkpoint()
        self._buffers = (self.stepper.state, self.stepper.state_next)
        self._graphs = None
        self.reused = False

    def _add_rigid_bodies(self, builder) -> None:
        """The stage's rigid bodies through Newton's USD import, hollow ones cut into convex pieces,
        stand-ins for objects a layer switched to rigid, and hidden feet where needed (``path_body``:
        object path → body index; ``supported``: the objects given feet)."""
        stage, objects, newton, wp = self.stage, self.objects, self.newton, self.wp
        # objects whose material now says otherwise (switched by a layer over the build) are left to
        # their own solver
        not_rigid = [o.path for o in objects if o.family != "rigid" and o.is_body]
        # hollow bodies (a bowl) are cut into convex pieces here, not by Newton's importer (see pieces.py)
        hollow = [o for o in objects if o.family == "rigid" and o.is_body and is_decomposed(o.prim)]
        # Every pattern holds '.*': Newton matches such a pattern as a regular expression only, and hands any
        # other to USD's physics parser as a prim path, where '...$' is an ill-formed path that USD prints a
        # raw warning about. '(/.*)?$' ends the match at the prim (cup_1 does not take cup_10) or its children.
        result = builder.add_usd(stage, load_visual_shapes=False, load_sites=False, verbose=False,
                                 mesh_maxhullvert=MAX_HULL_VERTICES,
                                 ignore_paths=[re.escape(p) + "(/.*)?$" for p in not_rigid + [o.path for o in hollow]]
                                 or None)
        self.path_body = {p: b for p, b in result["path_body_map"].items() if p.startswith(OBJECTS + "/")}
        own = add_decomposed(builder, hollow, newton, wp)
        own.update(_add_stand_ins(builder, [o for o in objects if o.family == "rigid" and not o.is_body], newton, wp))
        self.path_body.update(own)
        self.own_bodies = set(own)  # bodies Newton's importer did not build, so did not give their velocity
        # feet for objects whose visible geometry cannot stand where the photo shows them standing
        self.supported = add_hidden_support(builder, objects, self.path_body, _ground_height(stage), newton, wp)
        self.rounded = round_balls(builder, objects, self.path_body, newton, wp)

    def _add_deformables(self, builder, substeps: int | None = None) -> None:
        """Cloths and soft bodies as particles of the builder, with what their surfaces follow; ``substeps``:
        the user's substeps per frame, which the cloths' springs are softened to resolve (None: the cap)."""
        wp = self.wp
        self.ranges = {}  # cloth / soft body path → (first particle, count)
        self.cloth_sheets = {}  # cloth path → its cloth.ClothSheet (how its surface follows its particles)
        self.soft_bindings = {}  # soft body path → its surface's binding to the tetrahedra
        self.soft_rest = {}  # soft body path → its particles' rest positions (P, 3)
        self.soft_dt = None
        for o in self.objects:
            if o.family == "cloth":
                start, count, self.cloth_sheets[o.path] = add_cloth(builder, o, wp, self.cfg.fps, substeps)
                self.ranges[o.path] = (start, count)
            elif o.family == "soft":
                start, count, rest, dt_soft = add_soft_body(builder, o, wp)
                self.soft_dt = min(self.soft_dt or dt_soft, dt_soft)
                self.ranges[o.path] = (start, count)
                self.soft_bindings[o.path] = bind_surface(o.points, rest)
                self.soft_rest[o.path] = rest

    def _add_controls(self, builder) -> list:
        """Fixed bodies made kinematic; returns the pushes of bodies and particles (MPM's come later)."""
        fixed, pushes = read_controls(self.stage, self.path_body, self.own_bodies)
        pushes += particle_pushes(self.stage, self.ranges)
        for b in fixed:
            # a kinematic body with no velocity stays put and still collides with everything else
            builder.body_flags[b] = int(self.newton.BodyFlags.KINEMATIC)
            builder.body_qd[b] = self.wp.spatial_vector(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        return pushes

    def _add_fields(self, builder) -> None:
        """The stage's force fields, sampled over each body's mesh."""
        fields = read_force_fields(self.stage)
        self.fields = FieldSet(fields, self.device)
        if self.fields:
            points = [np.zeros((1, 3))] * builder.body_count
            for path, b in self.path_body.items():
                mesh = UsdGeom.Mesh(self.stage.GetPrimAtPath(path))
                points[b] = np.asarray(mesh.GetPointsAttr().Get(), float) if mesh else np.zeros((1, 3))
            self.fields.set_body_samples(body_samples(points))

    def _finalize(self, builder):
        """The builder's model on the device, its particle contacts set as the materials need."""
        model = builder.finalize(device=self.device)
        # no particle–particle contact: a lofted surface has vertices closer than their radii (near
        # its poles), and pushing those apart threw cloths up; cloth and soft bodies still collide
        # with the ground and the rigid bodies
        model.particle_max_radius = 0.0
        model.particle_grid = None
        if self.shared.friction is not None:
            model.soft_contact_mu = self.shared.friction
        return model

    def _add_solvers(self, model, settings: SimulateSettings):
        """XPBD for the model's bodies and particles (returned; None where it has neither) and the MPM
        scene for MPM objects (``mpm``); ``solvers`` names them."""
        self.solvers = []
        solver = None
        if model.body_count or model.particle_count:
            solver = xpbd_solver(model, self.cfg.iterations)
            if self.shared.relaxation is not None:
                solver.soft_body_relaxation = self.shared.relaxation
            self.solvers.append("xpbd")
        mpm_objects = [o for o in self.objects if o.family == "mpm"]
        self.mpm = build_mpm_scene(mpm_objects, model, self.device, settings.particle_spacing) \
            if mpm_objects else None
        self.mpm_objects = {m.obj.path: m for m in self.mpm.objects} if self.mpm else {}
        if self.mpm:
            self.solvers.append("implicit_mpm")
        return solver

    def _add_stepper(self, model, solver, pushes: list) -> None:
        """The :class:`~.stepping.Stepper` over the model's states, its start overlaps bounded, and the
        contacts searched once (``lifted``: soft bodies moved out of what they started inside, path → m)."""
        objects, stage = self.objects, self.stage
        air = AirDrag.of(objects, self.ranges, model.particle_count, self.device)
        if self.mpm:
            pushes += particle_pushes(stage, {o.obj.path: (o.start, o.count) for o in self.mpm.objects}, mpm=True)
        pipeline, contacts = contact_pipeline(model) if solver else (None, None)
        self.stepper = Stepper(model, solver, pipeline=pipeline, contacts=contacts, fields=self.fields,
                               mpm=self.mpm, pushes=pushes, air=air,
                               damping=ShapeDamping.of(objects, self.ranges, model.particle_count, self.device))
        # start overlaps of cloth are held to the separation bound; a soft body is moved out whole
        # (bounding its particles would clip its own elastic motion), or what lies on it is lifted
        cloth = [np.arange(s, s + n) for o in objects if o.family == "cloth" for s, n in [self.ranges[o.path]]]
        self.stepper.separating_particles = np.concatenate(cloth) if cloth else np.zeros(0, int)
        soft = {o.path: self.ranges[o.path] for o in objects if o.family == "soft"}
        bodies = {int(b): p for p, b in self.path_body.items()}
        fixed_soft = {o.path for o in objects if o.family == "soft" and o.fixed}
        self.lifted = lift_out(self.stepper, soft, bodies, fixed_soft) if pipeline and soft else {}
        if pipeline:
            # Newton builds the narrow phase's kernels per pipeline, so warp hashes its module again
            # on the first search (~0.5 s here): pay it while setting up, not in the first frame
            pipeline.collide(self.stepper.state, contacts)

    def frame_graphs(self, enabled: bool = True) -> FrameGraphs:
        """The stepper's captured frames, kept with the model: a run of the same schedule replays them."""
        if self._graphs is None or self._graphs.enabled != (enabled and FrameGraphs.supported(self.stepper)):
            self._graphs = FrameGraphs(self.stepper, enabled=enabled)
        return self._graphs

    @property
    def reusable(self) -> bool:
        """Whether a rewound model steps exactly as a new one: rigid bodies only, no noise field (whose
        random state moves on), nothing changed by hand (the preview builds its own)."""
        return (self.mpm is None and not self.model.particle_count
                and not any(FIELD_KIND[f.kind].draws_each_step for f in self.fields.fields))

    def rewind(self) -> None:
        """Back to the state as built: poses, velocities, pending pushes, and the contacts found at the start
        (searched twice, as a new model's are, so that sticky contact matching starts alike)."""
        self.t_built = time.perf_counter()
        self.t_model = 0.0
        with self.wp.ScopedDevice(self.device):
            # the run starts from the buffer it first started from, as the graphs captured then expect
            self.stepper.state, self.stepper.state_next = self._buffers
            self.stepper.restore(self._start)
            if self.stepper.pipeline is not None:
                for _ in range(2):
                    self.stepper.pipeline.collide(self.stepper.state, self.stepper.contacts)
        self.reused = True


    def field_acceleration(self, seconds: float) -> float:
        """Largest acceleration (m/s²) the force fields give at the objects' centres over the run."""
        if not self.fields:
            return 0.0
        centres = np.array([o.points.mean(axis=0) for o in self.objects])
        times = np.linspace(0.0, seconds, 9)
        return max(float(np.linalg.norm(self.fields.acceleration(centres, np.zeros_like(centres), t), axis=1).max())
                   for t in times)


def _ground_height(stage: Usd.Stage) -> float:
    """The ground plane's height (m); 0 where the stage has none."""
    ground = stage.GetPrimAtPath("/World/Ground")
    if not ground or not ground.IsA(UsdGeom.Xformable):
        return 0.0
    return float(UsdGeom.Xformable(ground).ComputeLocalToWorldTransform(Usd.TimeCode.Default()).ExtractTranslation()[2])


def _add_stand_ins(builder, objects: list[SimObject], newton, wp) -> dict:
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


#: The last shot's models, by the composed stage's content and the settings that shape them.
_LAST: dict = {}


def shot_models(stage: Usd.Stage, objects: list[SimObject], cfg: SceneConfig, settings: SimulateSettings,
                digest: str | None = None, shared: ParticleValues | None = None) -> ShotModels:
    """The :class:`ShotModels` of ``stage``: the last one built, rewound, when the composed stage (every
    layer's content, ``digest`` where the caller has it: :func:`~..usd.layers.content_digest`) and the
    settings are the same and the model can be rewound exactly; else a new one."""
    digest = digest or layers.content_digest(stage)
    key = (digest, cfg, settings.device, settings.particle_spacing)
    models = _LAST.get(key)
    if models is not None and models.reusable:
        models.rewind()
        return models
    _LAST.clear()
    models = ShotModels(stage, objects, cfg, settings, shared)
    if models.reusable:
        _LAST[key] = models
    return models
