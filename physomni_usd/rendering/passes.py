"""Control passes of a rendered shot: depth, normals, forward motion and object ids, exact from the stage.

Each frame's passes come from the same primary rays as its image (the ray
caster's face, barycentric coordinates and distance per pixel, handed over in
the :class:`~physomni_usd.rendering.video.FrameState` that rendered it) and, for the
pixels that see no object, from the environment the renderer stands the
objects in (:class:`~physomni_usd.rendering.world.Environment`). They are written
as one multi-channel float32 OpenEXR per frame, ``passes.####.exr`` (the frame
number is the time code), with the channel names of :data:`CHANNELS`, plus
``passes.json`` (ids → prim paths, the conventions) and a preview MP4 per pass.

Conventions (also written to ``passes.json``):

* ``Z``: distance along the camera's optical axis in metres (not along the ray), finite everywhere.
* ``N.X N.Y N.Z``: world-space unit normal (Z up) of the surface seen, turned to face the camera.
* ``motion.X motion.Y``: forward motion in pixels to the next frame, +x right, +y down: the surface
  point a pixel sees at frame t (same triangle, same barycentric coordinates) at frame t + 1, projected with
  the camera of t + 1, minus the pixel's centre. The environment is static, so its motion is the camera's.
  The last frame has no next frame: its motion is zero.
* ``objectId``: 0 for the environment, 1..K for the objects in ``passes.json``'s ``objects``.

The passes see each object's mesh; the image shows the mesh through its texture, whose alpha (the photo's
mask) cuts the object out exactly, so along an object's edge the image may show the background a pixel or two
inside its ``objectId``. Particles (``Points`` prims) are drawn over the image but are not in the passes.
"""

from __future__ import annotations

import pathlib

import cv2
import numpy as np

from ..errors import InputError

#: The passes a user may ask for, in the order they are written, and their EXR channels.
CHANNELS = {"depth": ("Z",), "normal": ("N.X", "N.Y", "N.Z"), "flow": ("motion.X", "motion.Y"),
            "mask": ("objectId",)}
PASSES = tuple(CHANNELS)
CONVENTIONS = {
    "Z": "distance along the camera's optical axis, metres; finite everywhere",
    "N.X N.Y N.Z": "world-space unit normal (Z up) of the surface seen, facing the camera",
    "motion.X motion.Y": "forward motion to the next frame, pixels, +x right, +y down; zero on the last frame",
    "objectId": "0 for the environment, 1..K for the objects listed under 'objects'",
}


def parse_passes(text: str | None) -> tuple[str, ...]:
    """``--passes`` as given (comma-separated names, or ``all``) → the passes in :data:`PASSES` order."""
    if text is None:
        return ()
    names = [n.strip().lower() for n in text.split(",") if n.strip()]
    if names == ["all"]:
        return PASSES
    bad = [n for n in names if n not in CHANNELS]
    if bad or not names:
        raise InputError(f"--passes {text!r}: expected a comma-separated list of {', '.join(PASSES)} (or all)"
                         + (f"; unknown: {', '.join(bad)}" if bad else ""))
    return tuple(p for p in PASSES if p in names)


def frame_passes(renderer, state, t_next: float | None, cache: dict | None = None) -> dict[str, np.ndarray]:
    """The passes of one frame of ``renderer`` (a ShotRenderer), from the ``state`` (a FrameState) its
    ``render`` returned with the image: ``Z`` (H, W), ``N`` (H, W, 3), ``motion`` (H, W, 2), all float32, and
    ``objectId`` (H, W) int32. ``t_next`` is the next frame's time code (None for the last frame: zero motion).
    ``cache`` (any dict, kept by the caller from frame to frame) spares recomputing the environment while the
    camera holds."""
    from pxr import Usd

    from .stage import read_camera

    cam = state.camera
    h, w = renderer.height, renderer.width
    env = _environment(renderer, state, {} if cache is None else cache)
    dist, normal = env["t"].copy(), env["normal"].copy()  # flat (H·W,) and (H·W, 3)
    object_id = np.zeros(h * w, np.int32)
    motion = np.zeros((h * w, 2), np.float32)
    idx = np.flatnonzero(state.mesh_face >= 0) if state.mesh_face is not None else np.zeros(0, np.int64)
    if len(idx):  # flat indices: much cheaper than boolean masks over the whole frame
        face = state.mesh_face.reshape(-1)[idx]
        object_id[idx] = renderer.face_object[face] + 1
        dist[idx] = state.mesh_depth.reshape(-1)[idx]
        tri = state.points[renderer.faces[face]]  # (P, 3, 3) at t
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
        n *= np.where(np.einsum("ij,ij->i", n, env["rays"][idx]) > 0, -1.0, 1.0)[:, None]
        normal[idx] = n
    if t_next is not None:
        cam1 = read_camera(renderer.stage, Usd.TimeCode(t_next), w, h)
        moved = not (np.array_equal(cam1.origin, cam.origin) and np.array_equal(cam1.axes, cam.axes)
                     and (cam1.fx, cam1.fy) == (cam.fx, cam.fy))
        if moved:  # the static world seen through the next camera
            points = np.asarray(cam.origin, np.float64) + env["rays"] * env["t"][:, None].astype(np.float64)
            motion = (cam1.project(points)[0] - env["centre"]).astype(np.float32)
        if len(idx):
            bary = state.bary.reshape(-1, 2)[idx].astype(np.float64)
            u, v = bary[:, 0:1], bary[:, 1:2]
            tri1 = renderer.points_at(Usd.TimeCode(t_next))[renderer.faces[face]]
            p1 = tri1[:, 0] * u + tri1[:, 1] * v + tri1[:, 2] * (1.0 - u - v)
            motion[idx] = cam1.project(p1)[0] - env["centre"][idx]
    return {"Z": (dist * env["cos"]).reshape(h, w), "N": normal.reshape(h, w, 3),
            "motion": motion.reshape(h, w, 2), "objectId": object_id.reshape(h, w)}


def _environment(renderer, state, cache: dict) -> dict[str, np.ndarray]:
    """What the passes need of the frame's camera and the environment, flat over the pixels: the rays
    (H·W, 3), their cosine to the optical axis (H·W,), the environment's distance (H·W,) and normal (H·W, 3)
    along each ray (float32), and the pixel centres (H·W, 2); kept in ``cache`` while the camera holds."""
    cam = state.camera
    key = (tuple(np.asarray(cam.origin, float)), tuple(np.asarray(cam.axes, float).ravel()), cam.fx, cam.fy)
    if cache.get("key") == key:
        return cache["env"]
    h, w = state.rays.shape[:2]
    rays = state.rays.reshape(-1, 3).astype(np.float64)  # unit, from this frame's camera
    t, _, normal = renderer.environment.intersect(cam.origin, rays)
    env = {"rays": rays, "cos": (rays @ np.asarray(cam.axes[2], np.float64)).astype(np.float32),
           "t": t.astype(np.float32), "normal": normal.astype(np.float32),
           "centre": np.stack(np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5), -1).reshape(-1, 2)}
    cache.update(key=key, env=env)
    return env


def exr_channels(passes: tuple[str, ...], buffers: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The EXR channels (name → (H, W) float32) of the requested ``passes`` from :func:`frame_passes`."""
    out = {}
    if "depth" in passes:
        out["Z"] = buffers["Z"]
    if "normal" in passes:
        for k, axis in enumerate("XYZ"):
            out[f"N.{axis}"] = np.ascontiguousarray(buffers["N"][..., k])
    if "flow" in passes:
        out["motion.X"] = np.ascontiguousarray(buffers["motion"][..., 0])
        out["motion.Y"] = np.ascontiguousarray(buffers["motion"][..., 1])
    if "mask" in passes:
        out["objectId"] = buffers["objectId"].astype(np.float32)
    return out


def write_exr(path: pathlib.Path, channels: dict[str, np.ndarray]) -> None:
    """One scanline float32 OpenEXR, ZIP-compressed, written to a temporary file and renamed."""
    import OpenEXR

    from .._files import atomic_path

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_path(path) as tmp:
        with OpenEXR.File(header, {k: np.ascontiguousarray(v, np.float32) for k, v in channels.items()}) as f:
            f.write(str(tmp))


def read_exr(path) -> dict[str, np.ndarray]:
    """Channel name → (H, W) float32 of an EXR written by :func:`write_exr`."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        return {name: np.array(c.pixels) for name, c in f.channels().items()}


def preview(name: str, buffers: dict[str, np.ndarray], scale: dict) -> np.ndarray:
    """An (H, W, 3) uint8 picture of pass ``name`` for its preview video. ``scale`` holds the ranges fixed at
    the first frame (so the preview does not flicker): near/far depth, the largest motion."""
    if name == "depth":  # near bright, far dark, on inverse depth
        inv = 1.0 / np.maximum(buffers["Z"], 1e-6)
        if "depth" not in scale:
            scale["depth"] = (float(np.percentile(inv, 1)), float(np.percentile(inv, 99.5)))
        lo, hi = scale["depth"]
        g = np.clip((inv - lo) / max(hi - lo, 1e-9), 0, 1) * 255
        return np.repeat(g[..., None], 3, -1).astype(np.uint8)
    if name == "normal":
        return np.clip((buffers["N"] * 0.5 + 0.5) * 255 + 0.5, 0, 255).astype(np.uint8)
    if name == "flow":  # hue: direction, brightness: speed
        m = buffers["motion"]
        mag = np.hypot(m[..., 0], m[..., 1])
        if "flow" not in scale or scale["flow"] <= 0:
            scale["flow"] = float(np.percentile(mag, 99.5)) * 1.5
        hsv = np.zeros(m.shape[:2] + (3,), np.uint8)
        hsv[..., 0] = ((np.arctan2(m[..., 1], m[..., 0]) + np.pi) / (2 * np.pi) * 179).astype(np.uint8)
        hsv[..., 1] = 255
        hsv[..., 2] = np.clip(mag / max(scale["flow"], 1e-6) * 255, 0, 255).astype(np.uint8)
        return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)
    ids = buffers["objectId"]  # a fixed palette: golden-angle hues, the environment black
    hue = ((ids * 0.618034) % 1.0 * 179).astype(np.uint8)
    hsv = np.stack([hue, np.full_like(hue, 200), np.where(ids > 0, 230, 0).astype(np.uint8)], -1)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)


def pass_files(folder: pathlib.Path, passes: tuple[str, ...], frames) -> list[pathlib.Path]:
    """Every file the passes of ``frames`` (time codes) write in ``folder``."""
    return ([folder / f"passes.{int(t):04d}.exr" for t in frames] + [folder / "passes.json"]
            + [folder / f"{p}.mp4" for p in passes])


class PassWriter:
    """Writes the requested passes of each frame a ShotRenderer renders: an EXR per frame, a preview MP4 per
    pass, and ``passes.json`` on :meth:`close`."""

    def __init__(self, folder: pathlib.Path, passes: tuple[str, ...], renderer, fps: float, quality: int):
        from .._files import atomic_path, make_dirs
        from .encode import video_writer

        self.folder, self.passes, self.renderer = pathlib.Path(folder), passes, renderer
        make_dirs(self.folder)
        self.scale: dict = {}
        self._environment: dict = {}  # frame_passes' cache of the environment along the camera's rays
        self.frames: list[int] = []
        self._paths = [atomic_path(self.folder / f"{p}.mp4") for p in passes]
        self.writers = []
        for ctx in self._paths:
            tmp = ctx.__enter__()
            self.writers.append(video_writer(tmp, fps, quality))

    def add(self, state, t_next: float | None) -> None:
        """The passes of the frame the renderer rendered from ``state`` (a FrameState; ``t_next``: the next
        frame's time code or None)."""
        from .encode import even_sides

        t = state.time
        buffers = frame_passes(self.renderer, state, t_next, self._environment)
        write_exr(self.folder / f"passes.{int(t):04d}.exr", exr_channels(self.passes, buffers))
        for name, writer in zip(self.passes, self.writers):
            writer.append_data(even_sides(preview(name, buffers, self.scale)))
        self.frames.append(int(t))

    def close(self, ok: bool = True) -> dict:
        """Finish the previews and write ``passes.json``; returns what the report records."""
        from .._files import write_json

        for writer in self.writers:
            writer.close()
        for ctx in self._paths:
            ctx.__exit__(None, None, None) if ok else ctx.__exit__(RuntimeError, RuntimeError(), None)
        if not ok:
            return {}
        objects = {str(k + 1): o.path for k, o in enumerate(self.renderer.objects)}
        channels = [c for p in self.passes for c in CHANNELS[p]]
        info = {"passes": list(self.passes), "channels": channels, "files": "passes.####.exr (#### = frame)",
                "frames": self.frames, "width": self.renderer.width, "height": self.renderer.height,
                "pixel_type": "float32", "objects": {"0": "environment", **objects},
                "conventions": {k: v for k, v in CONVENTIONS.items() if set(k.split()) & set(channels)},
                "previews": {p: f"{p}.mp4" for p in self.passes}}
        write_json(self.folder / "passes.json", info)
        return {"dir": str(self.folder), "passes": list(self.passes), "channels": channels,
                "objects": len(objects)}
