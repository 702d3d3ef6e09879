"""What the preview page draws, read from the composed stage: the photo's camera, the opening view
(frame 0 as ``render`` draws it, on a card that fills the photo camera's view), the background plate on
its card, each object's mesh with its projected photo texture (unlit: emissive only), and flat-coloured
live meshes or point clouds for deformables."""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from ..errors import InputError
from ..render.stage import read_camera, read_objects, read_plate


@dataclass
class View:
    """The photo's camera as a browser camera: position, a point it looks at, vertical field of view
    (radians); and the photo's size in pixels."""
    position: np.ndarray
    look_at: np.ndarray
    up: np.ndarray
    fov: float
    width: int
    height: int
    axes: np.ndarray  # rows: camera right, down, forward in world

    def project(self, points: np.ndarray, fx: float) -> np.ndarray:
        """Photo pixel coordinates (N, 2) of world points."""
        p = (np.atleast_2d(points) - self.position) @ self.axes.T
        return p[:, :2] / p[:, 2:3] * fx + np.array([self.width, self.height]) / 2


@dataclass
class Drawn:
    """One object as drawn: local vertices, triangles, texture coordinates and its RGBA texture."""
    path: str
    name: str
    points: np.ndarray  # (N, 3) in the prim's frame
    faces: np.ndarray  # (M, 3)
    st: np.ndarray  # (N, 2), USD convention (v up)
    texture: np.ndarray  # (h, w, 4) uint8
    matrix: np.ndarray  # (4, 4) local → world at frame 0, row vectors
    corner_st: np.ndarray | None = None  # (M, 3, 2) st at each triangle corner, where the prim's st is faceVarying


def photo_view(stage: Usd.Stage) -> tuple[View, float]:
    """The opening view and the photo's focal length in pixels."""
    prim = stage.GetPrimAtPath("/World/Camera")
    if not prim:
        raise InputError("the shot has no /World/Camera to look through")
    size = prim.GetCustomDataByKey("physomni:imageSize")
    plate = read_plate(stage)
    w, h = (int(size[0]), int(size[1])) if size else (plate.shape[1], plate.shape[0])
    cam = read_camera(stage, Usd.TimeCode.Default(), w, h)
    axes = np.asarray(cam.axes, float)
    forward = axes[2]
    # look at where the view's centre meets the ground, or 3 m ahead when it looks above the horizon
    dist = -cam.origin[2] / forward[2] if forward[2] < -1e-3 else 3.0
    fov = 2.0 * np.arctan(0.5 * h / cam.fy)
    return View(np.asarray(cam.origin, float), cam.origin + forward * min(dist, 50.0), -axes[1], float(fov), w, h,
                axes), float(cam.fx)


def opening_frame(stage: Usd.Stage) -> np.ndarray:
    """(H, W, 3) uint8: the shot's first frame as ``render`` draws it through the photo's camera, at the
    photo's size up to ``render``'s longest side (the photo itself wherever nothing has moved)."""
    from ..render.video import ShotRenderer

    return ShotRenderer(stage).frame(float(stage.GetStartTimeCode()))


def opening_card(view: View, fx: float, distance: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Where an image fills the photo camera's view exactly, ``distance`` metres in front of it: the card's
    centre (3,), orientation (wxyz; image x right, y down, z into the scene) and width and height in metres."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(view.axes.T).as_quat()  # columns: right, down, forward
    fy = 0.5 * view.height / np.tan(0.5 * view.fov)
    return (view.position + view.axes[2] * distance, np.array([q[3], q[0], q[1], q[2]]),
            view.width * distance / fx, view.height * distance / fy)


def fitted_fov(view: View, aspect: float) -> float:
    """Vertical field of view (radians) that shows the whole photo on a canvas of ``aspect`` (width /
    height): the photo's own where the canvas is wider than the photo, wider where it is narrower, so that
    the photo is letterboxed, never cropped."""
    half_w = np.tan(0.5 * view.fov) * view.width / view.height  # tan of the photo's half horizontal fov
    return float(max(view.fov, 2.0 * np.arctan(half_w / max(aspect, 1e-6))))


def background_card(stage: Usd.Stage, view: View) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """The plate, the centre of its card, the card's orientation (wxyz, image x right, y down, z into
    the scene) and its width and height in metres."""
    from scipy.spatial.transform import Rotation

    prim = stage.GetPrimAtPath("/World/Background")
    if not prim or not prim.IsA(UsdGeom.Mesh):
        raise InputError("the shot has no /World/Background plate")
    pts = np.asarray(UsdGeom.Mesh(prim).GetPointsAttr().Get(), float)
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
    pts = pts @ m[:3, :3] + m[3, :3]
    # corners: bottom-left, bottom-right, top-right, top-left as seen
    width = float(np.linalg.norm(pts[1] - pts[0]))
    height = float(np.linalg.norm(pts[3] - pts[0]))
    x = (pts[1] - pts[0]) / width
    y = (pts[0] - pts[3]) / height
    z = np.cross(x, y)
    q = Rotation.from_matrix(np.stack([x, y, z], axis=1)).as_quat()  # x, y, z, w
    return read_plate(stage), pts.mean(axis=0), np.array([q[3], q[0], q[1], q[2]]), width, height


def drawn_objects(stage: Usd.Stage) -> dict[str, Drawn]:
    """Every visible object mesh with its texture, by prim path."""
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    out = {}
    for o in read_objects(stage):
        pts = o.static_points if o.static_points is not None else np.asarray(o.points_attr.Get(), float)
        m = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(o.path)))
        corners = o.corner_st if not np.allclose(o.corner_st, o.st[o.faces]) else None  # faceVarying only
        out[o.path] = Drawn(o.path, o.path.rsplit("/", 1)[-1], pts, o.faces, o.st, o.texture, m, corners)
    return out


def textured_glb(d: Drawn) -> bytes:
    """A GLB of the object in its own frame whose colour is the photo texture, as emitted light: no
    light or environment changes it. The texture's alpha cuts the silhouette."""
    import trimesh
    from PIL import Image

    tex = Image.fromarray(d.texture, "RGBA")
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[0, 0, 0, 255], baseColorTexture=tex, emissiveTexture=tex.convert("RGB"),
        emissiveFactor=[1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=1.0, alphaMode="MASK",
        alphaCutoff=0.5, doubleSided=True)
    points, faces, uv = d.points, d.faces, d.st
    if d.corner_st is not None:
        # faceVarying st (a photo side beside an unseen side meeting at one vertex): one vertex per corner,
        # so that each face samples its own side of the texture instead of the mean of both
        points = d.points[d.faces].reshape(-1, 3)
        faces = np.arange(len(points)).reshape(-1, 3)
        uv = d.corner_st.reshape(-1, 2)
    mesh = trimesh.Trimesh(points, faces, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, material=material))
    buf = io.BytesIO()
    mesh.export(buf, file_type="glb")
    return buf.getvalue()


def mean_colour(texture: np.ndarray) -> tuple[int, int, int]:
    """Mean RGB (0–255) of the texture where it is opaque."""
    a = texture[..., 3] > 127
    rgb = texture[..., :3][a].mean(axis=0) if a.any() else np.full(3, 160.0)
    return tuple(int(c) for c in rgb)
