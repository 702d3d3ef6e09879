"""``validate``: OpenUSD's own validators plus the checks of our USD contract.

A finding is ``(severity, where, message)``; severity is ``error`` or
``warning``. Any error makes ``physomni-usd validate`` exit non-zero.
"""

from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass

from pxr import Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, UsdValidation

from .errors import InputError
from .usd import layers
from .usd.author import OBJECTS, PARTICLES


@dataclass
class Finding:
    severity: str  # 'error' | 'warning'
    where: str
    message: str
    check: str

    def __str__(self) -> str:
        return f"{self.severity}: {self.where}: {self.message} [{self.check}]"


def usd_validation(stage: Usd.Stage) -> list[Finding]:
    """Every validator registered with ``pxr.UsdValidation``, run on the composed stage."""
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    out = []
    for err in UsdValidation.ValidationContext(validators).Validate(stage):
        kind = err.GetType()
        if kind == UsdValidation.ValidationErrorType.None_:
            continue
        severity = "error" if kind == UsdValidation.ValidationErrorType.Error else "warning"
        sites = err.GetSites()
        where = "stage"
        if sites:
            site = sites[0]
            if site.IsPrim() or site.IsProperty():
                where = str(site.GetPrim().GetPath()) if site.IsPrim() else str(site.GetProperty().GetPath())
            elif site.GetLayer():
                where = site.GetLayer().identifier
        name = err.GetValidator().GetMetadata().name if err.GetValidator() else err.GetName()
        out.append(Finding(severity, where, err.GetMessage(), str(name)))
    return out


def contract_checks(stage: Usd.Stage) -> list[Finding]:
    """The project's USD contract (see USD_CONTRACT in the design notes)."""
    out: list[Finding] = []

    def bad(where, msg, severity="error"):
        out.append(Finding(severity, str(where), msg, "physomni:contract"))

    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.z:
        bad("stage", "upAxis must be Z")
    if not math.isclose(UsdGeom.GetStageMetersPerUnit(stage), 1.0):
        bad("stage", "metersPerUnit must be 1")
    if not math.isclose(UsdPhysics.GetStageKilogramsPerUnit(stage), 1.0):
        bad("stage", "kilogramsPerUnit must be 1")
    if not stage.GetDefaultPrim() or stage.GetDefaultPrim().GetPath() != Sdf.Path("/World"):
        bad("stage", "defaultPrim must be /World")
    tcps, fps = stage.GetTimeCodesPerSecond(), stage.GetFramesPerSecond()
    if not math.isclose(tcps, fps):
        bad("stage", f"timeCodesPerSecond ({tcps:g}) must equal framesPerSecond ({fps:g})")
    for path, kind in (("/World/PhysicsScene", UsdPhysics.Scene), ("/World/Camera", UsdGeom.Camera)):
        prim = stage.GetPrimAtPath(path)
        if not prim or not prim.IsA(kind):
            bad(path, f"missing or not a {kind.__name__}")
    ground = stage.GetPrimAtPath("/World/Ground")
    if not ground or not ground.HasAPI(UsdPhysics.CollisionAPI):
        bad("/World/Ground", "missing, or not a collider")
    out += material_checks(stage)
    objects = stage.GetPrimAtPath(OBJECTS)
    if not objects:
        bad(OBJECTS, "missing")
        return out
    for prim in objects.GetChildren():
        out += _object_checks(prim)
    return out


def material_checks(stage: Usd.Stage) -> list[Finding]:
    """Every PhysOmni material: a known type, and each authored parameter inside its range."""
    from .materials.catalog import CATALOG, PARAMS

    out = []
    for prim in stage.Traverse():
        if not prim.HasAPI("PhysOmniMaterialAPI"):
            continue
        kind = prim.GetAttribute("physomni:materialType").Get()
        if kind not in CATALOG:
            out.append(Finding("error", str(prim.GetPath()), f"unknown physomni:materialType {kind!r}",
                               "physomni:materials"))
        for p in PARAMS.values():
            attr = prim.GetAttribute(p.attr)
            if attr and attr.HasAuthoredValue() and not p.accepts(attr.Get()):
                out.append(Finding("error", f"{prim.GetPath()}.{p.attr}",
                                   f"{attr.Get()!r} is outside {p.describe_range()}", "physomni:materials"))
    return out


def _object_checks(prim: Usd.Prim) -> list[Finding]:
    out = []
    where = str(prim.GetPath())

    def bad(msg, severity="error"):
        out.append(Finding(severity, where, msg, "physomni:contract"))

    if not prim.IsA(UsdGeom.Mesh):
        bad("objects must be Mesh prims")
        return out
    mesh = UsdGeom.Mesh(prim)
    for attr in (mesh.GetPointsAttr(), mesh.GetFaceVertexIndicesAttr(), mesh.GetFaceVertexCountsAttr(),
                 mesh.GetNormalsAttr(), mesh.GetExtentAttr()):
        if not attr.HasAuthoredValue():
            bad(f"{attr.GetName()} is not authored")
    if not UsdGeom.PrimvarsAPI(prim).HasPrimvar("st"):
        bad("primvars:st is missing")
    if not prim.HasAPI("PhysOmniObjectAPI"):
        bad("PhysOmniObjectAPI is not applied", "warning")
    if prim.HasAPI(UsdPhysics.RigidBodyAPI):
        for api in (UsdPhysics.CollisionAPI, UsdPhysics.MeshCollisionAPI, UsdPhysics.MassAPI):
            if not prim.HasAPI(api):
                bad(f"rigid body without {api.__name__}")
        mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
        if not mat or not mat.GetPrim().HasAPI(UsdPhysics.MaterialAPI):
            bad("no physics material bound with material:binding:physics")
    for name in ("xformOp:translate", "xformOp:orient"):
        attr = prim.GetAttribute(name)
        for t in attr.GetTimeSamples() if attr else ():
            value = attr.Get(t)
            if value is None or not all(math.isfinite(float(c)) for c in _components(value)):
                bad(f"{name} is not finite at time {t:g}")
                break
    return out


def _components(value):
    if hasattr(value, "GetReal"):
        return (value.GetReal(), *value.GetImaginary())
    return tuple(value)


def scene_checks(stage: Usd.Stage) -> list[Finding]:
    """What a photo of objects allows: sizes against the labels', masses, overlaps, ground, camera."""
    from .physics.diagnose import scene_findings

    return [Finding(f.severity, f"{OBJECTS}/{f.name}" if f.name != "Camera" else "/World/Camera", f.message,
                    f"physomni:scene.{f.check}") for f in scene_findings(stage)]


def sim_layer_checks(stage: Usd.Stage) -> list[Finding]:
    """The simulation layer holds overs only, but for the particle prims it defines under /World/Particles."""
    out = []
    particles = Sdf.Path(PARTICLES)
    for layer in stage.GetLayerStack(includeSessionLayers=False):
        if not layer.realPath or pathlib.Path(layer.realPath).name != layers.SIM:
            continue
        def visit(path, layer=layer):
            if path.IsPrimPath() and not path.HasPrefix(particles):
                spec = layer.GetPrimAtPath(path)
                if spec and spec.specifier != Sdf.SpecifierOver:
                    out.append(Finding("error", str(path), "sim layer defines a prim outside "
                                       f"{PARTICLES}; it may hold overs only", "physomni:contract"))
        layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return out


def _rate(layer: Sdf.Layer) -> float:
    """Time codes per second USD uses for ``layer``'s samples: its own, else its frames per second, else 24."""
    if layer.HasTimeCodesPerSecond():
        return layer.timeCodesPerSecond
    if layer.HasFramesPerSecond():
        return layer.framesPerSecond
    return 24.0


def time_code_checks(stage: Usd.Stage) -> list[Finding]:
    """Every sublayer at the root's time codes per second. USD rescales a sublayer at another rate (keys at
    frames 10 and 20 of a layer without one land at 12.5 and 25 under a 30 fps root): an error where the
    layer has time samples; a warning for ``edits.usda`` without any, since keys authored there later
    would be moved (``estimate --set`` adds the root's rate to it). Other layers without samples are
    unaffected by their rate."""
    out = []
    root = stage.GetRootLayer()
    rate = _rate(root)
    for layer in stage.GetLayerStack(includeSessionLayers=False):
        if layer is root or math.isclose(_rate(layer), rate):
            continue
        name = pathlib.Path(layer.realPath).name if layer.realPath else layer.identifier
        what = (f"{name} is at {_rate(layer):g} time codes per second"
                + ("" if layer.HasTimeCodesPerSecond() else " (none authored: USD's default)")
                + f" but the root is at {rate:g}")
        if layer.ListAllTimeSamples():
            out.append(Finding("error", name, f"{what}: its time samples are rescaled by "
                               f"{rate / _rate(layer):g}", "physomni:timeCodes"))
        elif name == layers.EDITS:
            out.append(Finding("warning", name, f"{what}: keys authored in it would be rescaled; author "
                               f"timeCodesPerSecond = {rate:g} in its header", "physomni:timeCodes", ))
    return out


def validate_stage(path) -> list[Finding]:
    """All findings for the stage at ``path`` (a shot or any layer we write)."""
    p = pathlib.Path(path)
    if not p.exists():
        raise InputError(f"no such stage: {p}")
    if p.name == layers.SHOT or p.is_dir():
        stage = layers.open_shot(p)
    else:
        layers.check_shot_layers(p)
        stage = Usd.Stage.Open(str(p))
    from .physics.checks import check_values

    check_values(stage)  # a NaN or an absurd value is bad input (exit 2), not a finding among others
    findings = usd_validation(stage)
    findings += time_code_checks(stage)
    if stage.GetPrimAtPath("/World") and stage.GetPrimAtPath("/World/Camera"):
        findings += contract_checks(stage)
        findings += scene_checks(stage)
    findings += sim_layer_checks(stage)
    return findings


def check_shot_values(shot) -> None:
    """Refuse (one line, exit 2) a shot whose composed stage holds a non-finite or absurd value: what every
    command that reads a shot checks before it computes or replaces anything."""
    from .physics.checks import check_values

    check_values(layers.open_shot(shot))
