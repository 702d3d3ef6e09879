"""The objects of a composed stage as the simulator sees them: material type, solver family,
parameters and world-space surface — the one place that routes a material to a solver."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom, UsdPhysics

from ..errors import InputError
from ..materials.catalog import CATALOG, PARAMS, keys_of, material_type
from ..usd.contract import bound_material, object_prims
from .mpm import MPM_TYPES

#: Solver family per material type; what is not listed here is rigid.
FAMILY = {**{t: "mpm" for t in MPM_TYPES}, "pbd_cloth": "cloth", "pbd_elastic": "soft"}


def family_of(material_type: str) -> str:
    """'rigid', 'mpm', 'cloth' or 'soft'."""
    return FAMILY.get(material_type, "rigid")


@dataclass
class SimObject:
    prim: Usd.Prim
    kind: str  # physomni:materialType
    params: dict  # canonical key → value, the type's defaults where nothing is authored
    fixed: bool
    points: np.ndarray  # (N, 3) world
    faces: np.ndarray  # (M, 3)
    matrix: np.ndarray  # (4, 4) local → world, row vectors (USD convention)
    #: canonical key → who set the value: "default" (the catalog's, nothing authored), "rules", "vlm", "user"
    sources: dict = field(default_factory=dict)
    #: kg/m³: a cloth's density as authored for a solid kind (the estimate's for the object before ``--set
    #: NAME.material=pbd_cloth``), which the cloth turns into kg/m² by the object's thickness
    #: (:func:`.cloth.areal_density`); None where its density is a cloth's own (kg/m²) or the catalog's
    volume_density: float | None = None

    @property
    def path(self) -> str:
        return str(self.prim.GetPath())

    @property
    def name(self) -> str:
        return self.prim.GetName()

    @property
    def family(self) -> str:
        return family_of(self.kind)

    @property
    def is_body(self) -> bool:
        """Whether the stage itself makes it a UsdPhysics rigid body (Newton's USD import reads it)."""
        return self.prim.HasAPI(UsdPhysics.RigidBodyAPI)

    def trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.points, self.faces, process=False)

    def to_local(self, world: np.ndarray) -> np.ndarray:
        """World points (…, 3) in the prim's own frame."""
        inv = np.linalg.inv(self.matrix)
        return world @ inv[:3, :3] + inv[3, :3]


def scene_objects(stage: Usd.Stage) -> list[SimObject]:
    """Every object under /World/Objects with a mesh, in mask order."""
    from ..geometry.mesh import triangulate

    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    out = []
    for prim in object_prims(stage):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        mat = bound_material(prim)
        try:
            kind = material_type(mat.GetAttribute("physomni:materialType").Get() if mat else None)
        except ValueError as exc:
            raise InputError(f"{mat.GetPath()}.physomni:materialType: {exc}") from None
        params = dict(CATALOG[kind].defaults)
        sources = dict.fromkeys(params, "default")
        material_source = (mat.GetAttribute("physomni:source").Get() if mat else None) or "rules"
        for key in keys_of(kind):
            attr = mat.GetAttribute(PARAMS[key].attr) if mat else None
            if attr and attr.HasAuthoredValue():
                params[key] = attr.Get()
                sources[key] = attr.GetCustomDataByKey("physomni:source") or material_source
        volume_density = None
        if kind == "pbd_cloth" and sources.get("density", "default") != "default" and \
                authored_with(mat, PARAMS["density"].attr) != "pbd_cloth":
            volume_density = float(params["density"])
        fixed = bool(prim.GetAttribute("physomni:fixed").Get())
        m = np.array(cache.GetLocalToWorldTransform(prim))
        pts = np.asarray(mesh.GetPointsAttr().Get(), float)
        faces = triangulate(np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64),
                            np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64))
        out.append(SimObject(prim, kind, params, fixed, pts @ m[:3, :3] + m[3, :3], faces, m, sources,
                             volume_density))
    return out


def authored_with(mat: Usd.Prim, name: str):
    """The ``physomni:materialType`` in force where ``mat``'s attribute ``name`` was authored: the strongest type
    authored in that layer or a weaker one. A parameter means what the type it was written for says (a
    density is kg/m³ for a solid, kg/m² for a cloth), and switching the type in a stronger layer (``--set
    NAME.material=KIND`` in the edits) leaves the parameters written for the old one."""
    stack = list(mat.GetStage().GetLayerStack())
    specs = mat.GetAttribute(name).GetPropertyStack(Usd.TimeCode.Default())
    if not specs or specs[0].layer not in stack:
        return mat.GetAttribute("physomni:materialType").Get()
    at = stack.index(specs[0].layer)
    for spec in mat.GetAttribute("physomni:materialType").GetPropertyStack(Usd.TimeCode.Default()):
        if spec.layer in stack and stack.index(spec.layer) >= at and spec.default is not None:
            return spec.default
    return None
