"""Authoring helpers: the one place that turns arrays into USD prims and layers.

Each ``write_*_layer`` function builds one stage layer in memory and saves it
with :func:`~physomni_usd.usd.layers.save_layer` (temporary file + rename).
"""

from __future__ import annotations

import pathlib
from dataclasses import dataclass

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

from . import layers

OBJECTS = "/World/Objects"
PHYSICS_MATERIALS = "/World/Materials/Physics"
LOOKS = "/World/Materials/Looks"
FORCE_FIELDS = "/World/ForceFields"
#: MPM objects' particles: one Points prim per object, named like the object.
PARTICLES = "/World/Particles"


@dataclass
class SceneObject:
    """What the scene layer holds of one object (all arrays in metres, local to ``translate``)."""

    name: str
    label: str
    mask_index: int
    points: np.ndarray  # (N, 3) local
    faces: np.ndarray  # (M, 3)
    normals: np.ndarray  # (N, 3)
    st: np.ndarray  # (N, 2)
    translate: np.ndarray  # (3,) world position of the prim's origin
    texture: str  # path relative to the layer
    shape: str = "round"
    texture_origin: tuple[int, int] | None = None  # (x0, y0): the texture's top-left pixel in the photo
    st_per_corner: bool = False  # st is (M·3, 2), one per triangle corner (faceVarying), not one per point


@dataclass
class PhysicsObject:
    """What the physics layer holds of one object: its material and its controls."""

    name: str
    material_type: str
    params: dict  # canonical catalog keys → values (see materials.catalog)
    source: str = "rules"
    velocity: tuple[float, float, float] | None = None
    angular_velocity: tuple[float, float, float] | None = None  # degrees/s, as UsdPhysics
    fixed: bool = False
    delayed_velocity: tuple | None = None  # ((vx, vy, vz), seconds): given at that time, not at 0
    delayed_angular_velocity: tuple | None = None  # (wx, wy, wz) degrees/s, at the same time


def _new_stage(fps: float, frames: int | None = None) -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    layers.set_stage_metadata(stage.GetRootLayer(), fps, frames)
    return stage


def _texture_material(stage: Usd.Stage, path: str, texture: str, opacity_from_alpha: bool) -> UsdShade.Material:
    """A UsdPreviewSurface material whose colour (and cut-out alpha) comes from ``texture`` via ``st``."""
    mat = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.8)
    reader = UsdShade.Shader.Define(stage, f"{path}/st")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    tex = UsdShade.Shader.Define(stage, f"{path}/Texture")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(texture))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
    rgb = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rgb)
    if opacity_from_alpha:
        a = tex.CreateOutput("a", Sdf.ValueTypeNames.Float)
        shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(a)
        shader.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    else:
        shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rgb)
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return mat


def _bind(prim: Usd.Prim, material: UsdShade.Material, purpose: str = UsdShade.Tokens.allPurpose) -> None:
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material, UsdShade.Tokens.weakerThanDescendants, purpose)


def write_scene_layer(path: pathlib.Path, *, fps: float, image_size: tuple[int, int], camera,
                      plate: str, objects: list[SceneObject], ground_size: float, extra: dict | None = None,
                      photo: str | None = None, wide_plate: tuple[str, tuple] | None = None) -> None:
    """``scene.usda``: camera, ground, background card and one textured mesh per object.

    ``camera`` is a :class:`~physomni_usd.geometry.camera.PinholeCamera`. ``photo`` (a path relative to the
    layer) is recorded on the background card as ``physomni:photo`` custom data, and each object's
    ``texture_origin`` as ``physomni:textureOrigin``: together they let a renderer show the photo itself
    wherever nothing has moved. ``wide_plate`` (a path relative to the layer, and its margins (top, bottom,
    left, right) in pixels around the plate) is recorded as ``physomni:widePlate`` and
    ``physomni:widePlateMargins``: the world a moving camera sees beyond the photo's frame.
    """
    stage = _new_stage(fps)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    scene = UsdPhysics.Scene.Define(stage, "/World/PhysicsScene")
    scene.CreateGravityDirectionAttr(Gf.Vec3f(0, 0, -1))
    scene.CreateGravityMagnitudeAttr(9.81)

    cam = UsdGeom.Camera.Define(stage, "/World/Camera")
    focal, h_ap, v_ap = camera.usd_apertures()
    cam.CreateFocalLengthAttr(focal)
    cam.CreateHorizontalApertureAttr(h_ap)
    cam.CreateVerticalApertureAttr(v_ap)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 10000.0))
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.AddTransformOp().Set(Gf.Matrix4d(*camera.usd_matrix().ravel().tolist()))
    cam_prim = cam.GetPrim()
    cam_prim.SetCustomDataByKey("physomni:imageSize", Gf.Vec2i(*image_size))
    cam_prim.SetCustomDataByKey("physomni:pitchDegrees", float(camera.pitch_deg))

    ground = UsdGeom.Plane.Define(stage, "/World/Ground")
    ground.CreateAxisAttr(UsdGeom.Tokens.z)
    ground.CreateWidthAttr(ground_size)
    ground.CreateLengthAttr(ground_size)
    ground.CreatePurposeAttr(UsdGeom.Tokens.guide)
    half = 0.5 * ground_size
    ground.CreateExtentAttr([(-half, -half, 0.0), (half, half, 0.0)])
    UsdPhysics.CollisionAPI.Apply(ground.GetPrim())

    _background_card(stage, camera, plate)
    if wide_plate:
        card = stage.GetPrimAtPath("/World/Background")
        card.SetCustomDataByKey("physomni:widePlate", wide_plate[0])
        card.SetCustomDataByKey("physomni:widePlateMargins", Gf.Vec4i(*map(int, wide_plate[1])))
    if photo:
        stage.GetPrimAtPath("/World/Background").SetCustomDataByKey("physomni:photo", photo)

    UsdGeom.Scope.Define(stage, "/World/Materials")
    UsdGeom.Scope.Define(stage, LOOKS)
    UsdGeom.Xform.Define(stage, OBJECTS)
    for obj in objects:
        mesh = UsdGeom.Mesh.Define(stage, f"{OBJECTS}/{obj.name}")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(obj.points, np.float32)))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(obj.faces), 3, np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(obj.faces.ravel(), np.int32)))
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(obj.normals, np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateExtentAttr(UsdGeom.PointBased.ComputeExtent(mesh.GetPointsAttr().Get()))
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                      UsdGeom.Tokens.faceVarying if obj.st_per_corner
                                                      else UsdGeom.Tokens.vertex)
        st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(obj.st, np.float32)))
        mesh.AddTranslateOp().Set(Gf.Vec3d(*map(float, obj.translate)))
        mesh.AddOrientOp().Set(Gf.Quatf(1.0, 0.0, 0.0, 0.0))
        prim = mesh.GetPrim()
        prim.ApplyAPI("PhysOmniObjectAPI")
        prim.GetAttribute("physomni:label").Set(obj.label)
        prim.GetAttribute("physomni:maskIndex").Set(int(obj.mask_index))
        prim.SetCustomDataByKey("physomni:liftedShape", obj.shape)
        if obj.st_per_corner:  # the texture holds [photo crop | unseen sides] side by side (texture/sides.py)
            prim.SetCustomDataByKey("physomni:unseenSides", "right half")
        if obj.texture_origin is not None:
            prim.SetCustomDataByKey("physomni:textureOrigin", Gf.Vec2i(*map(int, obj.texture_origin)))
        look = _texture_material(stage, f"{LOOKS}/{obj.name}", obj.texture, opacity_from_alpha=True)
        _bind(prim, look)
    if extra:
        stage.GetRootLayer().customLayerData = extra
    layers.save_layer(stage.GetRootLayer(), path)


def _background_card(stage: Usd.Stage, camera, plate: str) -> None:
    """The plate on a card that exactly fills the camera's view, far behind the objects."""
    w, h = camera.width, camera.height
    distance = 50.0 * camera.origin[2] + 50.0
    corners = np.array([[0, h], [w, h], [w, 0], [0, 0]], float)  # bottom-left, ccw as seen
    d = camera.rays(corners[:, 0], corners[:, 1])
    fwd = camera.world_from_camera[:, 2]
    pts = camera.origin + d * (distance / (d @ fwd))[:, None]
    card = UsdGeom.Mesh.Define(stage, "/World/Background")
    card.CreatePointsAttr([Gf.Vec3f(*map(float, p)) for p in pts])
    card.CreateFaceVertexCountsAttr([4])
    card.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    card.CreateExtentAttr(UsdGeom.PointBased.ComputeExtent(card.GetPointsAttr().Get()))
    card.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    card.CreateDoubleSidedAttr(True)
    card.CreatePurposeAttr(UsdGeom.Tokens.render)
    st = UsdGeom.PrimvarsAPI(card).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)])
    look = _texture_material(stage, f"{LOOKS}/Background", plate, opacity_from_alpha=False)
    _bind(card.GetPrim(), look)


def write_physics_layer(path: pathlib.Path, scene_path: pathlib.Path, *, fps: float, objects: list[PhysicsObject],
                        ground: PhysicsObject, solver: str, substeps: int, iterations: int, forces=(),
                        force_source: str = "user", extra_forces=()) -> None:
    """``physics.usda``: physics materials, body APIs, controls, solver settings and force fields.

    Objects of material ``rigid`` become UsdPhysics rigid bodies with convex-hull
    colliders (convex decomposition for open vessels, whose hull would close them);
    other materials only bind their material (their solvers read it).
    ``extra_forces`` are ``(field, source)`` pairs kept from an earlier layer.
    """
    physics = Sdf.Layer.CreateAnonymous(".usda")
    root = Sdf.Layer.CreateAnonymous(".usda")
    root.subLayerPaths[:] = [physics.identifier, str(scene_path)]
    stage = Usd.Stage.Open(root)
    stage.SetEditTarget(Usd.EditTarget(physics))

    scene = stage.GetPrimAtPath("/World/PhysicsScene")
    scene.ApplyAPI("PhysOmniSceneAPI")
    scene.GetAttribute("physomni:solver").Set(solver)
    scene.GetAttribute("physomni:substeps").Set(int(substeps))
    scene.GetAttribute("physomni:iterations").Set(int(iterations))

    UsdGeom.Scope.Define(stage, PHYSICS_MATERIALS)
    ground_mat = _physics_material(stage, "Ground", ground.material_type, ground.params, ground.source)
    _bind(stage.GetPrimAtPath("/World/Ground"), ground_mat, "physics")

    for obj in objects:
        prim = stage.GetPrimAtPath(f"{OBJECTS}/{obj.name}")
        if obj.material_type == "rigid":
            body = UsdPhysics.RigidBodyAPI.Apply(prim)
            if obj.velocity is not None:
                body.CreateVelocityAttr(Gf.Vec3f(*map(float, obj.velocity)))
            if obj.angular_velocity is not None:
                body.CreateAngularVelocityAttr(Gf.Vec3f(*map(float, obj.angular_velocity)))
            UsdPhysics.CollisionAPI.Apply(prim)
            # an open vessel's hull would close its top: it collides as convex pieces (physics/pieces.py)
            hollow = prim.GetCustomDataByKey("physomni:liftedShape") == "vessel"
            UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(
                UsdPhysics.Tokens.convexDecomposition if hollow else UsdPhysics.Tokens.convexHull)
            UsdPhysics.MassAPI.Apply(prim)
        elif obj.velocity is not None or obj.angular_velocity is not None:
            # UsdPhysics velocities belong to rigid bodies; other materials take the PhysOmni controls
            obj.delayed_velocity = obj.delayed_velocity or (obj.velocity, 0.0)
            obj.delayed_angular_velocity = obj.delayed_angular_velocity or obj.angular_velocity
        if obj.fixed:
            prim.GetAttribute("physomni:fixed").Set(True)
        if obj.delayed_velocity is not None:
            velocity, at = obj.delayed_velocity
            if velocity is not None:
                prim.GetAttribute("physomni:initialVelocity").Set(Gf.Vec3f(*map(float, velocity)))
            if obj.delayed_angular_velocity is not None:
                prim.GetAttribute("physomni:initialAngularVelocity").Set(
                    Gf.Vec3f(*map(float, obj.delayed_angular_velocity)))
            prim.GetAttribute("physomni:velocityStartTime").Set(float(at))
        mat = _physics_material(stage, obj.name, obj.material_type, obj.params, obj.source)
        _bind(prim, mat, "physics")
    if forces:
        author_force_fields(stage, forces, force_source)
    for field_, source in extra_forces:
        author_force_fields(stage, [field_], source)
    physics.defaultPrim = "World"
    layers.set_stage_metadata(physics, fps)
    layers.save_layer(physics, path)


def author_force_fields(stage: Usd.Stage, fields, source: str = "user") -> list[str]:
    """Define ``/World/ForceFields/<kind>_<n>`` prims with PhysOmniForceFieldAPI; returns their paths.

    Only attributes that differ from the schema's fallbacks are authored, plus
    the kind, strength and direction, which a reader always wants to see.
    """
    from dataclasses import fields as dataclass_fields

    from .schema import FORCE_FIELD_ATTRS as ATTRS

    UsdGeom.Scope.Define(stage, FORCE_FIELDS)
    paths = []
    taken = {p.GetName() for p in stage.GetPrimAtPath(FORCE_FIELDS).GetChildren()}
    for f in fields:
        fallback = {d.name: d.default for d in dataclass_fields(f)}  # the field class's defaults
        n = 0
        while f"{f.kind}_{n}" in taken:
            n += 1
        name = f"{f.kind}_{n}"
        taken.add(name)
        prim = UsdGeom.Xform.Define(stage, f"{FORCE_FIELDS}/{name}").GetPrim()
        prim.ApplyAPI("PhysOmniForceFieldAPI")
        for attr_name, key in ATTRS.items():
            value = getattr(f, key)
            if key not in ("kind", "strength", "direction") and value == fallback[key]:
                continue
            attr = prim.GetAttribute(attr_name)
            attr.Set(Gf.Vec3f(*map(float, value)) if key in ("direction", "position") else value)
        prim.GetAttribute("physomni:source").Set(source)
        paths.append(str(prim.GetPath()))
    return paths


def _physics_material(stage, name: str, material_type: str, params: dict, source: str) -> UsdShade.Material:
    """A physics material: UsdPhysics attributes where they exist, ``physomni:`` ones otherwise.

    Every value carries ``physomni:source`` in its customData.
    """
    from .schema import MATERIAL_ATTRS

    mat = UsdShade.Material.Define(stage, f"{PHYSICS_MATERIALS}/{name}")
    prim = mat.GetPrim()
    UsdPhysics.MaterialAPI.Apply(prim)
    prim.ApplyAPI("PhysOmniMaterialAPI")
    prim.GetAttribute("physomni:materialType").Set(material_type)
    prim.GetAttribute("physomni:source").Set(source)
    for key, value in params.items():
        set_param(prim, MATERIAL_ATTRS[key], value, source)
    return mat


def set_param(prim: Usd.Prim, attr_name: str, value, source: str) -> None:
    """Author one material parameter on ``prim`` (through the current edit target) with its source."""
    attr = prim.GetAttribute(attr_name)
    if not attr:  # only physomni: attributes outside the schema would land here
        type_name = Sdf.ValueTypeNames.Token if isinstance(value, str) else Sdf.ValueTypeNames.Float
        attr = prim.CreateAttribute(attr_name, type_name)
    attr.Set(value if isinstance(value, str) else float(value))
    attr.SetCustomDataByKey("physomni:source", source)


def write_sim_layer(path: pathlib.Path, *, fps: float, frames: int, tracks: dict, metadata: dict,
                    point_tracks: dict | None = None, particles: dict | None = None) -> None:
    """``sim.usdc``: overs with time samples, and the Points prims of particle objects.

    ``tracks`` maps a prim path to ``(translations (F, 3), orientations (F, 4) as w, x, y, z)``; one sample
    per frame, time code = frame index. Prims that do not move must not be in ``tracks``.
    ``point_tracks`` maps a Mesh prim path to its points (F, N, 3) in the prim's own frame.
    ``particles`` maps an object name to ``{points (F, P, 3) world, show, mesh, colour (RGB 0–1), width m}``:
    ``/World/Particles/<name>`` is defined here, in the simulation's own layer (so that a later
    ``estimate``, which rewrites ``physics.usda``, cannot take the particles away while this layer still
    hides their mesh). Every such prim is hidden at frame 0 — the photo; where ``show``, the particles
    replace the mesh from frame 1 on; the others stay hidden, kept for artists and other renderers.
    """
    layer = Sdf.Layer.CreateAnonymous(".usdc")
    if particles:
        _define_particle_prims(layer, particles)
    layer.timeCodesPerSecond = float(fps)
    layer.framesPerSecond = float(fps)
    layer.startTimeCode = 0.0
    layer.endTimeCode = float(max(frames - 1, 0))
    layer.customLayerData = metadata
    with Sdf.ChangeBlock():
        for prim_path, (translations, orients) in tracks.items():
            spec = Sdf.CreatePrimInLayer(layer, prim_path)
            spec.specifier = Sdf.SpecifierOver
            t_attr = Sdf.AttributeSpec(spec, "xformOp:translate", Sdf.ValueTypeNames.Double3)
            o_attr = Sdf.AttributeSpec(spec, "xformOp:orient", Sdf.ValueTypeNames.Quatf)
            for f in range(len(translations)):
                layer.SetTimeSample(t_attr.path, float(f), Gf.Vec3d(*map(float, translations[f])))
                w, x, y, z = map(float, orients[f])
                layer.SetTimeSample(o_attr.path, float(f), Gf.Quatf(w, x, y, z))
        for prim_path, points in (point_tracks or {}).items():
            spec = Sdf.CreatePrimInLayer(layer, prim_path)
            spec.specifier = Sdf.SpecifierOver
            _point_samples(layer, spec, points)
        for name, item in (particles or {}).items():
            spec = layer.GetPrimAtPath(f"{PARTICLES}/{name}")
            _point_samples(layer, spec, item["points"])
            if item["show"] and len(item["points"]) > 1:
                _visibility_samples(layer, spec, {0: UsdGeom.Tokens.invisible, 1: UsdGeom.Tokens.inherited})
                mesh = Sdf.CreatePrimInLayer(layer, item["mesh"])
                mesh.specifier = Sdf.SpecifierOver
                _visibility_samples(layer, mesh, {0: UsdGeom.Tokens.inherited, 1: UsdGeom.Tokens.invisible})
    # every ancestor of an over is an over too, so the layer defines nothing but the particles
    particles_root = Sdf.Path(PARTICLES)
    for spec_path in _all_prim_paths(layer):
        if not spec_path.HasPrefix(particles_root):
            layer.GetPrimAtPath(spec_path).specifier = Sdf.SpecifierOver
    layers.save_layer(layer, path)


def _define_particle_prims(layer: Sdf.Layer, particles: dict) -> None:
    """``def Points`` prims under ``/World/Particles`` in ``layer``: display colour, constant width, hidden."""
    stage = Usd.Stage.Open(layer)
    UsdGeom.Scope.Define(stage, PARTICLES)
    for name, item in particles.items():
        pts = UsdGeom.Points.Define(stage, f"{PARTICLES}/{name}")
        pts.CreateWidthsAttr(Vt.FloatArray([float(item["width"])]))
        pts.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        pts.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, item["colour"]))]))
        pts.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
        pts.GetPrim().SetCustomDataByKey("physomni:object", f"{OBJECTS}/{name}")


def _point_samples(layer: Sdf.Layer, spec: Sdf.PrimSpec, points: np.ndarray) -> None:
    """``points`` and ``extent`` samples, one per frame, from (F, N, 3)."""
    p_attr = Sdf.AttributeSpec(spec, "points", Sdf.ValueTypeNames.Point3fArray)
    e_attr = Sdf.AttributeSpec(spec, "extent", Sdf.ValueTypeNames.Float3Array)
    for f in range(len(points)):
        pts = np.ascontiguousarray(points[f], np.float32)
        layer.SetTimeSample(p_attr.path, float(f), Vt.Vec3fArray.FromNumpy(pts))
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        layer.SetTimeSample(e_attr.path, float(f), Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)),
                                                                  Gf.Vec3f(*map(float, hi))]))


def _visibility_samples(layer: Sdf.Layer, spec: Sdf.PrimSpec, samples: dict) -> None:
    attr = spec.attributes.get("visibility") or Sdf.AttributeSpec(spec, "visibility", Sdf.ValueTypeNames.Token,
                                                                  Sdf.VariabilityVarying)
    for time_code, token in samples.items():
        layer.SetTimeSample(attr.path, float(time_code), token)


def _all_prim_paths(layer: Sdf.Layer) -> list[Sdf.Path]:
    out = []
    layer.Traverse(Sdf.Path.absoluteRootPath, lambda p: out.append(p) if p.IsPrimPath() else None)
    return out


def write_render_layer(path: pathlib.Path, *, fps: float, frames: int, camera: str = "/World/Camera",
                       matrices=None, start: int = 0, metadata: dict | None = None) -> None:
    """``render.usda``: the render stage's camera move as time samples on ``camera``'s ``xformOp:transform``
    (``matrices`` (F, 4, 4), USD row-vector form, one per frame from time code ``start``); without ``matrices`` an
    empty layer (the camera as the layers below hold it). ``metadata`` goes to the layer's customLayerData."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layers.set_stage_metadata(layer, fps, frames)
    if start:
        layer.startTimeCode, layer.endTimeCode = float(start), float(start + frames - 1)
    layer.comment = "physomni-usd render: the camera move; keys in edits.usda override it."
    if metadata:
        layer.customLayerData = metadata
    if matrices is not None:
        spec = Sdf.CreatePrimInLayer(layer, camera)
        spec.specifier = Sdf.SpecifierOver
        parent = spec.nameParent
        while parent and parent.path != Sdf.Path.absoluteRootPath:
            parent.specifier = Sdf.SpecifierOver
            parent = parent.nameParent
        attr = Sdf.AttributeSpec(spec, "xformOp:transform", Sdf.ValueTypeNames.Matrix4d)
        for k, m in enumerate(matrices):
            layer.SetTimeSample(attr.path, float(start + k), Gf.Matrix4d(*np.asarray(m, float).ravel().tolist()))
        order = Sdf.AttributeSpec(spec, "xformOpOrder", Sdf.ValueTypeNames.TokenArray, variability=Sdf.VariabilityUniform)
        order.default = Vt.TokenArray(["xformOp:transform"])
    layers.save_layer(layer, path)
