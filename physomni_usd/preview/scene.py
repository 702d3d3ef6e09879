"""What the preview page draws, read from the composed stage: the photo's camera, the opening view
(frame 0 as ``render`` draws it, on a card that fills the photo camera's view), the background plate on
its card, each object's mesh with its projected photo texture (unlit: emissive only), each rigid object's
contact shadow as a decal on the ground that follows it, and flat-coloured live meshes or point clouds for
deformables."""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from ..errors import InputError
from ..rendering.stage import read_camera, read_objects, read_plate


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

    def world_points(self) -> np.ndarray:
        """(N, 3) the vertices in the world at frame 0, metres."""
        return self.points @ self.matrix[:3, :3] + self.matrix[3, :3]


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


def opening_frame(stage: Usd.Stage, regions: bool = False):
    """(H, W, 3) uint8: the shot's first frame as ``render`` draws it through the photo's camera, at the
    photo's size up to ``render``'s longest side (the photo itself wherever nothing has moved); with
    ``regions``, also each object's pixels of it that change once the object moves, and the pixels two objects
    share keyed by the pair, which change once both have moved (:func:`~.card.object_regions`)."""
    from ..rendering.video import ShotRenderer

    renderer = ShotRenderer(stage)
    image = renderer.frame(float(stage.GetStartTimeCode()))
    if not regions:
        return image
    from .card import object_regions

    return image, object_regions(renderer)


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


#: Texels along the longer side of one object's contact shadow (:func:`contact_decal`).
DECAL_TEXELS = 64
#: Most texels along the longer side of the ground's shadow image (:class:`GroundShadow`), sent again each frame
#: something moves (about 4 ms to encode at 512 × 400).
GROUND_TEXELS = 512
#: The ground's shadow lies this far above the ground (m), so that an object standing on the ground hides it under
#: its foot.
SHADOW_LIFT = 5e-4


@dataclass
class Decal:
    """An object's contact shadow at frame 0 as ``render`` casts it on the ground (z = 0): the darkening
    ``alpha`` (h, w) float32, 0–1, of texels ``step`` metres square, row 0 towards −y (as the preview lays an
    image flat); the texels' centre at frame 0 (``centre`` (3,), world, metres); and the object's reach (m),
    the gap beneath it at which its shadow is a quarter as dark."""
    alpha: np.ndarray
    centre: np.ndarray
    step: float
    reach: float


def contact_decal(d: Drawn, strength: float, falloff: float, blur: float = 0.0,
                  texels: int = DECAL_TEXELS) -> Decal:
    """The contact shadow of ``d`` as it stands at frame 0, as ``render`` darkens the ground (z = 0) around it:
    ``strength`` · ``contact_falloff(distance / reach)``, distance in metres from a ground point to the
    object's nearest surface and reach ``falloff`` × the object's height (``RenderSettings.shadow_strength``
    and ``shadow_falloff``), softened by a Gaussian ``blur`` metres wide (``render`` blurs its shadows on the
    screen: :func:`shadow_blur_m`), over the object's footprint widened by where all that reaches 0."""
    import cv2
    import trimesh

    from ..geometry.raycast import CONTACT_REACH, contact_falloff

    world = d.world_points()
    lo, hi = world.min(axis=0), world.max(axis=0)
    reach = falloff * max(float(hi[2] - lo[2]), 1e-3)
    pad = CONTACT_REACH * reach + 3.0 * blur
    (x0, y0), (x1, y1) = lo[:2] - pad, hi[:2] + pad
    step = max(x1 - x0, y1 - y0) / texels
    nx, ny = max(2, int(np.ceil((x1 - x0) / step))), max(2, int(np.ceil((y1 - y0) / step)))
    xs = 0.5 * (x0 + x1) + (np.arange(nx) - 0.5 * (nx - 1)) * step
    ys = 0.5 * (y0 + y1) + (np.arange(ny) - 0.5 * (ny - 1)) * step
    gx, gy = np.meshgrid(xs, ys)
    ground = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    _, distance, _ = trimesh.proximity.closest_point(trimesh.Trimesh(world, d.faces, process=False), ground)
    alpha = (strength * contact_falloff(distance / reach)).reshape(ny, nx).astype(np.float32)
    if blur > 0.5 * step:
        alpha = cv2.GaussianBlur(alpha, (0, 0), blur / step)
    return Decal(alpha, np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0]), float(step), reach)


def shadow_blur_m(view: View, fx: float, at: np.ndarray, blur: float) -> float:
    """Metres on the ground at ``at`` (3,) that ``render``'s shadow blur spans: ``blur`` (``RenderSettings.
    shadow_blur``, a fraction of the photo's diagonal in pixels) at the distance of ``at`` from the photo's camera."""
    depth = float((np.asarray(at, float) - view.position) @ view.axes[2])
    return blur * float(np.hypot(view.width, view.height)) * max(depth, 0.0) / fx


def _yaw(rotation: np.ndarray) -> float:
    """The angle (radians) of the rotation about +z nearest to ``rotation`` (3, 3): what turns a shadow."""
    return float(np.arctan2(rotation[1, 0] - rotation[0, 1], rotation[0, 0] + rotation[1, 1]))


@dataclass
class ShadowTrack:
    """How a rigid body carries its contact shadow: the body's pose at frame 0 (``pose0`` (7,): position,
    quaternion x, y, z, w) and its turn about +z then (``yaw0``, radians), its hull's points in the body's frame
    (``hull`` (N, 3)) and their lowest height then."""
    decal: Decal
    pose0: np.ndarray
    yaw0: float
    hull: np.ndarray
    lowest0: float

    @classmethod
    def of(cls, d: Drawn, decal: Decal, pose0: np.ndarray) -> "ShadowTrack":
        from scipy.spatial import ConvexHull, QhullError
        from scipy.spatial.transform import Rotation

        world = d.world_points()
        try:
            world = world[ConvexHull(world).vertices]  # the lowest point is a hull vertex
        except (QhullError, ValueError):
            pass
        r0 = Rotation.from_quat(pose0[3:7]).as_matrix()
        return cls(decal, np.asarray(pose0, float).copy(), _yaw(r0), (world - pose0[:3]) @ r0,
                   float(world[:, 2].min()))

    def place(self, pose: np.ndarray) -> tuple[np.ndarray, float, float]:
        """For the body at ``pose`` (7,): where the shadow's centre is on the ground (2,), how far it has
        turned about +z since frame 0 (radians), and how much of its darkness is left (0–1) for the gap the body
        has lifted off by since then (the fall-off with height that ``render`` has)."""
        from scipy.spatial.transform import Rotation

        from ..geometry.raycast import contact_falloff

        r = Rotation.from_quat(pose[3:7]).as_matrix()
        turn = _yaw(r) - self.yaw0
        c, s = np.cos(turn), np.sin(turn)
        offset = self.decal.centre[:2] - self.pose0[:2]
        xy = pose[:2] + np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])
        lift = max(0.0, float((self.hull @ r.T)[:, 2].min() + pose[2]) - self.lowest0)
        return xy, turn, float(contact_falloff(lift / self.decal.reach) / contact_falloff(0.0))


class GroundShadow:
    """Every rigid body's contact shadow on one image lying on the ground, as ``render`` combines them
    (1 − Π(1 − darkening)): one image, because overlapping flat images at one height hide each other in the
    browser's depth test. ``tracks`` by body index; the image covers their shadows at frame 0 and half as much
    again on each side, where the objects may go."""

    def __init__(self, tracks: dict[int, ShadowTrack], texels: int = GROUND_TEXELS):
        self.tracks = tracks
        centres = np.array([t.decal.centre[:2] for t in tracks.values()])
        halves = np.array([0.5 * t.decal.step * np.array(t.decal.alpha.shape[::-1]) for t in tracks.values()])
        lo, hi = (centres - halves).min(axis=0), (centres + halves).max(axis=0)
        span = hi - lo
        lo, hi = lo - 0.5 * span.max(), hi + 0.5 * span.max()
        # texels as fine as the finest object's shadow, as far as the image's size allows
        self.step = max(min(t.decal.step for t in tracks.values()), float((hi - lo).max()) / texels)
        nx, ny = (max(2, int(np.ceil(extent / self.step))) for extent in hi - lo)
        self.shape = (ny, nx)
        self.origin = lo  # the corner of texel (0, 0), world metres
        self.width, self.height = self.shape[1] * self.step, self.shape[0] * self.step

    @property
    def centre(self) -> np.ndarray:
        """(3,): the image's centre in the world, just above the ground."""
        return np.array([self.origin[0] + 0.5 * self.width, self.origin[1] + 0.5 * self.height, SHADOW_LIFT])

    def darkening(self, poses: np.ndarray, bodies=None) -> np.ndarray:
        """(h, w) float32: the ground's darkening with the bodies at ``poses`` (B, 7), row 0 towards −y; only
        that of ``bodies`` (indices) where given."""
        import cv2

        light = np.ones(self.shape, np.float32)
        for body, t in self.tracks.items():
            if bodies is not None and body not in bodies:
                continue
            xy, turn, fade = t.place(np.asarray(poses[body], float))
            if fade <= 0.0:
                continue
            a = t.decal.alpha
            c, s = np.cos(turn), np.sin(turn)
            k = t.decal.step / self.step
            # decal texel (u, v) → world: centre + R(turn) · ((u, v) − its middle) · step → ground texel
            mid = 0.5 * (np.array(a.shape[::-1], float) - 1.0)
            lin = k * np.array([[c, -s], [s, c]])
            at = (xy - self.origin) / self.step - 0.5 - lin @ mid
            # only the texels the turned decal covers (a whole-image warp per body costs ten times as much)
            corners = (lin @ np.array([[0, a.shape[1], 0, a.shape[1]], [0, 0, a.shape[0], a.shape[0]]])).T + at
            x0, y0 = np.maximum(np.floor(corners.min(axis=0)).astype(int) - 1, 0)
            x1, y1 = np.minimum(np.ceil(corners.max(axis=0)).astype(int) + 2, self.shape[::-1])
            if x1 <= x0 or y1 <= y0:
                continue
            m = np.hstack([lin, (at - (x0, y0))[:, None]]).astype(np.float64)
            warped = cv2.warpAffine(a, m, (int(x1 - x0), int(y1 - y0)), flags=cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
            light[y0:y1, x0:x1] *= 1.0 - fade * warped
        return 1.0 - light

    def rgba(self, poses: np.ndarray) -> np.ndarray:
        """(h, w, 4) uint8: black, as transparent as the ground is lit (:meth:`darkening`)."""
        out = np.zeros(self.shape + (4,), np.uint8)
        out[..., 3] = np.clip(self.darkening(poses) * 255.0 + 0.5, 0, 255).astype(np.uint8)
        return out
