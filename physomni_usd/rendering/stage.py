"""Reading what the renderer needs from a composed stage: camera, plate, textured meshes, per time code."""

from __future__ import annotations

import pathlib
from dataclasses import dataclass

import cv2
import numpy as np
from pxr import Usd, UsdGeom

from ..errors import InputError
from ..geometry.camera import RenderCamera, camera_from_usd
from ..geometry.mesh import triangulate
from ..usd.author import OBJECTS
from ..usd.textures import read_image, texture_file


@dataclass
class RenderObject:
    path: str
    faces: np.ndarray  # (M, 3)
    st: np.ndarray  # (N, 2)
    texture: np.ndarray  # (h, w, 4) uint8 RGBA
    points_attr: Usd.Attribute
    static_points: np.ndarray | None  # (N, 3) when points are not animated
    height: float  # metres, from the extent
    prim: Usd.Prim | None = None
    origin: tuple[int, int] | None = None  # the texture's top-left pixel in the photo (physomni:textureOrigin)
    corner_st: np.ndarray | None = None  # (M, 3, 2) st at each triangle corner (faceVarying st kept exact)
    two_sided: bool = False  # the texture is [photo crop | unseen sides] (physomni:unseenSides)
    body: str = "mesh"  # "pillow": drawn with rendering.pillow's body, its points static and in its local frame
    slab_points: np.ndarray | None = None  # a pillow's: its slab's hull (local), which says where it stands
    photo_pose: np.ndarray | None = None  # a pillow's: its local-to-world transform where the photo shows it


@dataclass
class RenderParticles:
    """One ``Points`` prim drawn as shaded splats in its display colour."""
    prim: Usd.Prim
    colour: np.ndarray  # (3,) RGB 0–255
    width: float  # metres


def read_plate(stage: Usd.Stage) -> np.ndarray:
    prim = stage.GetPrimAtPath("/World/Background")
    if not prim:
        raise InputError("the shot has no /World/Background plate to render over")
    return read_image(texture_file(prim), "background", rgba=False)


def read_wide_plate(stage: Usd.Stage) -> tuple[np.ndarray, tuple[int, int, int, int]] | None:
    """The plate extended beyond the photo's frame (``physomni:widePlate`` on the background card) (H', W', 3)
    uint8 RGB and its margins (top, bottom, left, right) in pixels; None for shots built without one."""
    prim = stage.GetPrimAtPath("/World/Background")
    rel = prim.GetCustomDataByKey("physomni:widePlate") if prim else None
    margins = prim.GetCustomDataByKey("physomni:widePlateMargins") if prim else None
    if not rel or margins is None:
        return None
    for spec in prim.GetPrimStack():
        if spec.customData.get("physomni", {}).get("widePlate") == rel:
            path = pathlib.Path(spec.layer.realPath).parent / rel
            return read_image(path, "wide background", rgba=False), tuple(int(m) for m in margins)
    return None


def scene_stage(stage: Usd.Stage) -> Usd.Stage | None:
    """The shot's scene layer opened alone (the photo's camera and each object where the photo shows it), or
    None where ``stage`` has none."""
    from ..usd.layers import SCENE

    for layer in stage.GetLayerStack(includeSessionLayers=False):
        if layer.realPath and pathlib.Path(layer.realPath).name == SCENE:
            scene = Usd.Stage.Open(layer)
            if scene.GetPrimAtPath("/World/Camera"):
                return scene
    return None


def read_photo_camera_matrix(stage: Usd.Stage) -> np.ndarray:
    """(4, 4) local-to-world matrix (USD row-vector form) of the camera that took the photo."""
    scene = scene_stage(stage)
    src, time = (scene, Usd.TimeCode.Default()) if scene else (stage, Usd.TimeCode(stage.GetStartTimeCode()))
    return np.array(UsdGeom.Xformable(src.GetPrimAtPath("/World/Camera")).ComputeLocalToWorldTransform(time))


def read_photo_camera(stage: Usd.Stage, width: int, height: int) -> RenderCamera:
    """The camera that took the photo, as ``build`` wrote it in ``scene.usda``, whatever the layers above
    (a camera move, an artist's keys) do with it; the stage's camera at its first frame for stages without
    a scene layer."""
    scene = scene_stage(stage)
    if scene is not None:
        return read_camera(scene, Usd.TimeCode.Default(), width, height)
    return read_camera(stage, Usd.TimeCode(stage.GetStartTimeCode()), width, height)


def read_photo_points(stage: Usd.Stage, objects: list[RenderObject]) -> list[np.ndarray | None] | None:
    """Per object, its (N, 3) world points where ``build`` placed it in ``scene.usda`` (the pose the photo
    shows it in), whatever the layers above do with it (an edit or a session layer moving its start); None for
    an object the scene layer does not hold, and None in place of the list for stages without a scene layer."""
    scene = scene_stage(stage)
    if scene is None:
        return None
    time = Usd.TimeCode(stage.GetStartTimeCode())
    cache = UsdGeom.XformCache(time)
    out = []
    for o in objects:
        prim = scene.GetPrimAtPath(o.path)
        pts = UsdGeom.Mesh(prim).GetPointsAttr().Get(time) if prim and prim.IsA(UsdGeom.Mesh) else None
        if pts is not None and o.body != "mesh":  # drawn with another body, posed as the mesh is
            pts = o.static_points
        if pts is None:
            out.append(None)
            continue
        m = np.array(cache.GetLocalToWorldTransform(prim))
        out.append(grounded(o, np.asarray(pts, np.float64) @ m[:3, :3] + m[3, :3], m))
    return out


def read_photo(stage: Usd.Stage) -> np.ndarray | None:
    """The original photo named by the background card's ``physomni:photo`` custom data (a path relative to
    the layer that wrote it), (H, W, 3) uint8; None for shots without one or when the file is gone."""
    prim = stage.GetPrimAtPath("/World/Background")
    rel = prim.GetCustomDataByKey("physomni:photo") if prim else None
    if not rel:
        return None
    for spec in prim.GetPrimStack():
        if spec.customData.get("physomni", {}).get("photo") == rel:  # namespaced keys nest in customData
            path = pathlib.Path(spec.layer.realPath).parent / rel
            img = cv2.imread(str(path), cv2.IMREAD_COLOR) if path.is_file() else None
            return None if img is None else np.ascontiguousarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB))
    return None


def read_objects(stage: Usd.Stage) -> list[RenderObject]:
    """Every visible Mesh under /World/Objects with its texture (objects without one render grey)."""
    root = stage.GetPrimAtPath(OBJECTS)
    out = []
    if not root:
        return out
    for prim in Usd.PrimRange(root):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        if mesh.ComputeVisibility() == UsdGeom.Tokens.invisible:
            continue
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(), np.int64)
        indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), np.int64)
        faces = triangulate(counts, indices)
        pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar("st")
        points_attr = mesh.GetPointsAttr()
        n = len(points_attr.Get())
        st = np.asarray(pv.ComputeFlattened(), np.float64) if pv and pv.HasValue() else np.zeros((n, 2))
        corner_st = None
        if pv and pv.GetInterpolation() == UsdGeom.Tokens.faceVarying and st.shape[0] == len(indices):
            # one st per polygon corner: triangulate the corners as the faces, and give each vertex the mean
            # of its corners' st for readers that want one per vertex
            corner_st = st[triangulate(counts, np.arange(len(indices)))]
            sums = np.zeros((n, 2))
            np.add.at(sums, indices, st)
            st = sums / np.maximum(np.bincount(indices, minlength=n), 1)[:, None]
        elif st.shape[0] != n:  # other layouts: no projection, sample one texel
            st = np.full((n, 2), 0.5)
        if corner_st is None:
            corner_st = st[faces]
        tex_path = texture_file(prim)
        texture = read_image(tex_path, prim.GetName(), rgba=True) if tex_path else np.full((2, 2, 4), 160, np.uint8)
        static = None if points_attr.GetNumTimeSamples() > 0 else np.asarray(points_attr.Get(), np.float64)
        ext = mesh.GetExtentAttr().Get()
        height = float(ext[1][2] - ext[0][2]) if ext else 1.0
        origin = prim.GetCustomDataByKey("physomni:textureOrigin")
        out.append(RenderObject(str(prim.GetPath()), faces, st, texture, points_attr, static, height, prim,
                                (int(origin[0]), int(origin[1])) if origin is not None and tex_path else None,
                                corner_st, bool(prim.GetCustomDataByKey("physomni:unseenSides"))))
    return out


def read_particles(stage: Usd.Stage) -> list[RenderParticles]:
    """Every ``Points`` prim under /World/Particles (visibility is checked per frame)."""
    from ..usd.author import PARTICLES

    root = stage.GetPrimAtPath(PARTICLES)
    out = []
    for prim in Usd.PrimRange(root) if root else []:
        if not prim.IsA(UsdGeom.Points):
            continue
        pts = UsdGeom.Points(prim)
        colour = pts.GetDisplayColorAttr().Get()
        colour = np.asarray(colour[0], float) * 255 if colour else np.full(3, 160.0)
        widths = pts.GetWidthsAttr().Get()
        out.append(RenderParticles(prim, colour, float(widths[0]) if widths else 0.02))
    return out


def visible(prim: Usd.Prim, time: Usd.TimeCode) -> bool:
    return UsdGeom.Imageable(prim).ComputeVisibility(time) != UsdGeom.Tokens.invisible


def read_camera(stage: Usd.Stage, time: Usd.TimeCode, width: int, height: int) -> RenderCamera:
    prim = stage.GetPrimAtPath("/World/Camera")
    if not prim or not prim.IsA(UsdGeom.Camera):
        raise InputError("the shot has no /World/Camera")
    cam = UsdGeom.Camera(prim)
    m = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)
    return camera_from_usd(cam.GetFocalLengthAttr().Get(time), cam.GetHorizontalApertureAttr().Get(time),
                           cam.GetVerticalApertureAttr().Get(time), np.array(m), width, height)


#: Height (metres) above the floor (z = 0) within which a slab's lowest point stands on it, and a pillow
#: (``rendering.pillow``) is set down there too; from there to GROUND_FADE_M the set-down fades out, so that a
#: pillow lifted off the floor rises with its slab rather than jumping (all or nothing, at 0.0099 m it was drawn
#: 0.0099 m up, at 0.0101 m 0.26 m up: the fallen bike's half-thickness).
GROUND_TOUCH_M = 0.01
GROUND_FADE_M = 0.1


def _set_down(obj, matrix: np.ndarray) -> float:
    """How far (m, up) a pillow ``obj`` posed by ``matrix`` is moved to stand where its slab does: the gap
    between the slab's lowest point and the pillow's, all of it while the slab stands on the floor
    (:data:`GROUND_TOUCH_M`), none from :data:`GROUND_FADE_M` up."""
    slab_low = float((obj.slab_points @ matrix[:3, 2] + matrix[3, 2]).min())
    low = float((obj.static_points @ matrix[:3, 2] + matrix[3, 2]).min())
    reach = float(np.clip((GROUND_FADE_M - slab_low) / (GROUND_FADE_M - GROUND_TOUCH_M), 0.0, 1.0))
    return (slab_low - low) * reach


def grounded(obj, points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``points`` (N, 3), ``obj``'s world points posed by ``matrix`` (4, 4, row-vector form), set down on the
    floor (z = 0) when ``obj`` is a pillow (``rendering.pillow``) whose slab stands there (:func:`_set_down`): the
    pillow lies within the slab, and lying on its side or its back it would hang above the floor the slab rests
    on by however much thinner it is there. The move is counted from the photo's pose, where the pillow is
    drawn exactly as built (there the mask's bottom pixels reach a little below the slab's simplified hull, and
    set down the pillow was lifted 1.9 px off the photo's bike)."""
    slab = getattr(obj, "slab_points", None)
    if slab is None or not len(points):
        return points
    shift = _set_down(obj, matrix)
    photo = getattr(obj, "photo_pose", None)
    if photo is not None:
        shift -= _set_down(obj, photo)
    if shift == 0.0:
        return points
    out = points.copy()
    out[:, 2] += shift
    return out


def world_points(obj: RenderObject, cache: UsdGeom.XformCache, stage: Usd.Stage, time: Usd.TimeCode) -> np.ndarray:
    pts = obj.static_points if obj.static_points is not None else np.asarray(obj.points_attr.Get(time), np.float64)
    m = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(obj.path)))
    return grounded(obj, pts @ m[:3, :3] + m[3, :3], m)
