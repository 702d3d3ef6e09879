"""Checking a scene against what a photo of objects allows, and naming the likely cause of a failed run.

:func:`scene_findings` compares the composed stage at frame 0 with the
objects' typical sizes (``physomni_usd/sizes.py``) and with physics: absurd
sizes and masses, objects starting inside each other, floating above or sunk
into the ground, a camera inside an object. ``build`` prints and records
them, ``validate`` reports them (errors make it exit 1), ``simulate`` refuses
to start on an error, and when its guard gives up, :func:`likely_cause`
names the worst finding in the one line it prints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdPhysics, UsdShade

from ..errors import PhysOmniError
from ..sizes import SizePrior, size_prior
from ..metrics.geometry import world_meshes
from ..geometry.mesh import longest_dimension
from ..usd.author import OBJECTS
from ..geometry.overlap import overlap_depth
from .pieces import is_decomposed

#: Sizes beyond this factor of the label's typical size are worth a warning, beyond the second an error.
SIZE_WARN_FACTOR = 2.0
SIZE_ERROR_FACTOR = 50.0
#: Nothing a photo of objects shows is this large (metres).
MAX_SIZE_M = 1000.0
#: Masses outside these (kg) are worth a warning; above the last, an error.
MASS_WARN_KG = (1e-5, 1e4)
MAX_MASS_KG = 1e7
#: Overlaps deeper than this (metres) are worth a warning; deeper than both of the next two, an error.
PENETRATION_WARN_M = 0.002
PENETRATION_ERROR_M = 0.005
PENETRATION_ERROR_FRACTION = 0.25  # of the smaller object's smallest extent
#: Wall-clock seconds ``simulate`` spends on one frame (its roll-backs included) before it gives up.
FRAME_WALL_BUDGET_S = 30.0
#: Gaps to the ground (or sinking into it) beyond this are worth a warning (metres).
GROUND_TOLERANCE_M = 0.005


@dataclass
class SceneFinding:
    severity: str  # 'error' | 'warning'
    name: str  # the prim (or 'Camera')
    check: str  # 'size' | 'mass' | 'penetration' | 'ground' | 'camera'
    message: str  # one line, naming the object
    badness: float = 0.0  # to rank likely causes

    def as_dict(self) -> dict:
        return {"severity": self.severity, "object": self.name, "check": self.check, "message": self.message}


def length(m: float) -> str:
    """A length for people: '8 cm', '2.7 m', '17.9 km'."""
    m = float(m)
    if abs(m) >= 1000:
        return f"{m / 1000:.3g} km"
    if abs(m) >= 1:
        return f"{m:.3g} m"
    if abs(m) >= 0.01:
        return f"{m * 100:.3g} cm"
    return f"{m * 1000:.3g} mm"


def _density(prim: Usd.Prim) -> float | None:
    """The body's own density, else its physics material's (kg/m³)."""
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
    for p in (prim, mat.GetPrim()) if mat else (prim,):
        attr = p.GetAttribute("physics:density")
        if attr and attr.HasAuthoredValue() and attr.Get():
            return float(attr.Get())
    return None


def _mass(prim: Usd.Prim, mesh) -> float | None:
    attr = prim.GetAttribute("physics:mass")
    if attr and attr.HasAuthoredValue() and attr.Get():
        return float(attr.Get())
    rho = _density(prim)
    if rho is None:
        return None
    volume = mesh.volume if mesh.is_volume else mesh.convex_hull.volume
    return rho * abs(float(volume))


def user_sizes(stage: Usd.Stage) -> dict[str, float]:
    """Sizes the user gave at build time (``--size``), recorded in the scene layer: prim name → metres."""
    out = {}
    for layer in stage.GetLayerStack(includeSessionLayers=False):
        out.update(dict(layer.customLayerData.get("physomni:userSizes", {}) or {}))
    return out


def scene_findings(stage: Usd.Stage, time: float = 0.0) -> list[SceneFinding]:
    """Every finding of the composed ``stage`` at ``time``, errors first.

    An object the user gave a size (``--size``) is held to that size instead of its label's.
    """
    meshes = world_meshes(stage, time)
    given = user_sizes(stage)
    root = stage.GetPrimAtPath(OBJECTS)
    out: list[SceneFinding] = []
    names = sorted(meshes)
    for name in names:
        mesh = meshes[name]
        prim = root.GetChild(name)
        label = prim.GetAttribute("physomni:label").Get() or name
        extent = np.ptp(mesh.vertices, axis=0)
        longest = longest_dimension(mesh.vertices)
        tall = "tall" if extent[2] >= extent[:2].max() else "across"
        size_of = float(extent[2]) if tall == "tall" else longest
        prior = size_prior(label)
        said = "its label suggests"
        if name in given:
            prior, said = SizePrior("--size", float(given[name]), None, "any"), "--size gave"
        if longest > MAX_SIZE_M:
            out.append(SceneFinding("error", name, "size", f"{name} is {length(size_of)} {tall}; nothing in a photo "
                                    f"of objects is kilometres large", np.log(longest)))
        elif prior is not None and prior.votes:
            ratio = longest / prior.longest_m
            hint = f"{name} is {length(size_of)} {tall}; {said} about {length(prior.longest_m)}"
            if ratio > SIZE_ERROR_FACTOR or ratio < 1 / SIZE_ERROR_FACTOR:
                out.append(SceneFinding("error", name, "size", hint, abs(np.log(ratio))))
            elif ratio > SIZE_WARN_FACTOR or ratio < 1 / SIZE_WARN_FACTOR:
                out.append(SceneFinding("warning", name, "size", hint, abs(np.log(ratio))))
        if prim.HasAPI(UsdPhysics.RigidBodyAPI):
            mass = _mass(prim, mesh)
            if mass is not None and mass > MAX_MASS_KG:
                out.append(SceneFinding("error", name, "mass", f"{name} weighs {mass:.3g} kg", np.log10(mass)))
            elif mass is not None and not MASS_WARN_KG[0] <= mass <= MASS_WARN_KG[1]:
                out.append(SceneFinding("warning", name, "mass", f"{name} weighs {mass:.3g} kg", 1.0))
        low = float(mesh.vertices[:, 2].min())
        if low < -GROUND_TOLERANCE_M:
            out.append(SceneFinding("warning", name, "ground", f"{name} starts {length(-low)} below the ground",
                                    -low / max(longest, 1e-9) * 10))
        elif low > GROUND_TOLERANCE_M and not any(
                o != name and abs(float(meshes[o].vertices[:, 2].max()) - low) <= GROUND_TOLERANCE_M
                for o in names):
            out.append(SceneFinding("warning", name, "ground", f"{name} floats {length(low)} above the ground", 0.5))
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            found = penetration(a, meshes[a], b, meshes[b], tuple(
                is_decomposed(stage.GetPrimAtPath(f"{OBJECTS}/{n}")) for n in (a, b)))
            if found is not None:
                out.append(found)
    cam = stage.GetPrimAtPath("/World/Camera")
    if cam:
        eye = np.array(UsdGeom.Xformable(cam).ComputeLocalToWorldTransform(Usd.TimeCode(time)))[3, :3]
        for name in names:
            m = meshes[name]
            if np.all(eye >= m.bounds[0]) and np.all(eye <= m.bounds[1]) and m.convex_hull.contains([eye])[0]:
                out.append(SceneFinding("warning", "Camera", "camera", f"the camera is inside {name}", 2.0))
        if eye[2] <= 0:
            out.append(SceneFinding("warning", "Camera", "camera", "the camera is at or below the ground", 2.0))
    out.sort(key=_rank)
    return out


def penetration(a: str, mesh_a, b: str, mesh_b, decomposed: tuple[bool, bool]) -> SceneFinding | None:
    """The penetration finding of objects ``a`` and ``b`` (trimesh meshes in world space; ``decomposed``: each
    simulated as convex pieces), None where they overlap by no more than ``PENETRATION_WARN_M``; severity
    'error' is what ``simulate`` refuses."""
    depth = overlap_depth(mesh_a, mesh_b, decomposed)
    if depth <= PENETRATION_WARN_M:
        return None
    small = min(float(np.ptp(mesh_a.vertices, axis=0).min()), float(np.ptp(mesh_b.vertices, axis=0).min()))
    deep = depth > PENETRATION_ERROR_M and depth > PENETRATION_ERROR_FRACTION * small
    inner, outer = (a, b) if mesh_a.volume <= mesh_b.volume else (b, a)
    return SceneFinding("error" if deep else "warning", inner, "penetration",
                        f"{inner} starts {length(depth)} inside {outer}", 10.0 * depth / max(small, 1e-9))


#: An absurd size explains overlaps and masses, so it is named first.
CHECK_ORDER = ("size", "mass", "penetration", "ground", "camera")


def _rank(f: SceneFinding):
    return f.severity != "error", CHECK_ORDER.index(f.check), -f.badness


def first_error(findings: list[SceneFinding]) -> SceneFinding | None:
    return next((f for f in findings if f.severity == "error"), None)


def likely_cause(stage: Usd.Stage) -> str | None:
    """The worst finding of the scene at frame 0, as one phrase, or None when nothing is wrong."""
    try:
        findings = scene_findings(stage)
    except Exception:  # noqa: BLE001 — naming a cause must never hide the failure it explains
        return None
    return findings[0].message if findings else None


class SceneRefused(PhysOmniError):
    """The scene has an error-level finding (``finding``): ``simulate`` does not start on it, and ``build`` does
    not write it (exit 1)."""

    def __init__(self, finding: SceneFinding):
        super().__init__(f"{finding.message}: the scene cannot be simulated as it stands "
                         "(fix it in edits.usda or build again; `physomni-usd validate` lists every finding)")
        self.finding = finding


def refuse_broken_scene(stage: Usd.Stage) -> None:
    """Raise :class:`SceneRefused` (exit 1) on the worst error-level finding, before any step is taken."""
    err = first_error(scene_findings(stage))
    if err is not None:
        raise SceneRefused(err)


def failure_line(stage: Usd.Stage, what: str) -> str:
    """``what`` went wrong, and the likely cause if the scene shows one."""
    cause = likely_cause(stage)
    return f"{what}; likely cause: {cause}" if cause else \
        f"{what}; check the masses, speeds and stiffness in the shot"
