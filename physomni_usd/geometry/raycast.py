"""warp kernels of the renderer: primary rays with alpha cut-out, and vertical shadow rays."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._warp import load_warp

#: Surfaces a primary ray may pass through where the texture is transparent.
MAX_LAYERS = 8


@lru_cache(maxsize=1)
def kernels():
    """Compile (once, cached on disk by warp) and return the two kernels."""
    wp = load_warp()

    @wp.kernel
    def primary(mesh: wp.uint64, origin: wp.vec3, rays: wp.array(dtype=wp.vec3),
                corner_px: wp.array(dtype=wp.vec2), alpha: wp.array2d(dtype=wp.float32), max_t: float,
                out_px: wp.array(dtype=wp.vec2), out_face: wp.array(dtype=wp.int32),
                out_depth: wp.array(dtype=wp.float32)):
        i = wp.tid()
        d = rays[i]
        o = origin
        out_face[i] = -1
        out_depth[i] = max_t
        travelled = float(0.0)
        h = alpha.shape[0]
        w = alpha.shape[1]
        for _layer in range(MAX_LAYERS):
            q = wp.mesh_query_ray(mesh, o, d, max_t)
            if not q.result:
                break
            f = q.face
            px = corner_px[f * 3] * q.u + corner_px[f * 3 + 1] * q.v + corner_px[f * 3 + 2] * (1.0 - q.u - q.v)
            ix = wp.clamp(int(px[0]), 0, w - 1)
            iy = wp.clamp(int(px[1]), 0, h - 1)
            if alpha[iy, ix] >= 0.5:
                out_face[i] = f
                out_px[i] = px
                out_depth[i] = travelled + q.t
                break
            o = o + d * (q.t + 1.0e-5)
            travelled = travelled + q.t + 1.0e-5

    @wp.kernel
    def shadow(mesh: wp.uint64, origin: wp.vec3, rays: wp.array(dtype=wp.vec3), max_h: float,
               out_h: wp.array(dtype=wp.float32), out_face: wp.array(dtype=wp.int32)):
        i = wp.tid()
        d = rays[i]
        out_h[i] = -1.0
        out_face[i] = -1
        if d[2] < -1.0e-6:
            t = -origin[2] / d[2]
            g = origin + d * t + wp.vec3(0.0, 0.0, 1.0e-4)
            q = wp.mesh_query_ray(mesh, g, wp.vec3(0.0, 0.0, 1.0), max_h)
            if q.result:
                out_h[i] = q.t
                out_face[i] = q.face

    return primary, shadow


class RayCaster:
    """All objects' triangles in one BVH; points are updated each frame, topology never changes."""

    def __init__(self, points: np.ndarray, faces: np.ndarray, corner_px: np.ndarray, alpha: np.ndarray,
                 device: str):
        wp = load_warp()
        self.wp = wp
        self.device = device
        self.points = wp.array(points.astype(np.float32), dtype=wp.vec3, device=device)
        self.indices = wp.array(faces.astype(np.int32).ravel(), dtype=wp.int32, device=device)
        self.mesh = wp.Mesh(points=self.points, indices=self.indices)
        self.corner_px = wp.array(corner_px.astype(np.float32), dtype=wp.vec2, device=device)
        self.alpha = wp.array(alpha.astype(np.float32), dtype=wp.float32, device=device)
        self._rays = None
        self._key = None

    def update(self, points: np.ndarray) -> None:
        self.points.assign(self.wp.array(points.astype(np.float32), dtype=self.wp.vec3, device=self.device))
        self.mesh.refit()

    def cast(self, origin, rays: np.ndarray, shadow_rays: np.ndarray, max_t: float, max_shadow: float):
        """Per pixel of ``rays``: face index (−1 for none) and atlas pixel coordinates; per pixel of
        ``shadow_rays`` (a coarser grid, shadows are soft): height of the object above the ground seen there.
        :attr:`depth` then holds each pixel's distance along its ray to the surface seen (``max_t`` for none),
        :attr:`shadow_face` the face above each shadow pixel (−1 for none)."""
        wp = self.wp
        primary, shadow = kernels()
        key = (rays.ctypes.data, rays.shape, shadow_rays.ctypes.data, shadow_rays.shape)
        if self._key != key:
            n, m = rays.shape[0] * rays.shape[1], shadow_rays.shape[0] * shadow_rays.shape[1]
            self._rays = wp.array(rays.reshape(-1, 3), dtype=wp.vec3, device=self.device)
            self._shadow_rays = wp.array(shadow_rays.reshape(-1, 3), dtype=wp.vec3, device=self.device)
            self._px = wp.zeros(n, dtype=wp.vec2, device=self.device)
            self._face = wp.zeros(n, dtype=wp.int32, device=self.device)
            self._depth = wp.zeros(n, dtype=wp.float32, device=self.device)
            self._h = wp.zeros(m, dtype=wp.float32, device=self.device)
            self._shadow_face = wp.zeros(m, dtype=wp.int32, device=self.device)
            self._key = key
        o = wp.vec3(*map(float, origin))
        wp.launch(primary, dim=self._rays.shape[0],
                  inputs=[self.mesh.id, o, self._rays, self.corner_px, self.alpha, float(max_t)],
                  outputs=[self._px, self._face, self._depth], device=self.device)
        wp.launch(shadow, dim=self._shadow_rays.shape[0], inputs=[self.mesh.id, o, self._shadow_rays,
                                                                   float(max_shadow)],
                  outputs=[self._h, self._shadow_face], device=self.device)
        shape = rays.shape[:2]
        self.depth = self._depth.numpy().reshape(shape)
        self.shadow_face = self._shadow_face.numpy().reshape(shadow_rays.shape[:2])
        return (self._face.numpy().reshape(shape), self._px.numpy().reshape(shape + (2,)),
                self._h.numpy().reshape(shadow_rays.shape[:2]))


class SilhouetteRenderer:
    """Which object each pixel sees, for the alignment's silhouettes and the camera search.

    The same warp kernels as the renderer (CPU or CUDA), without textures: one
    BVH over every object's triangles, built once; :meth:`update` refits it
    when objects move, and any number of cameras can then be rendered.
    """

    def __init__(self, vertex_sets, faces, device: str | None = None):
        from .._warp import pick_device

        self.device = pick_device(device)
        self.counts = [len(v) for v in vertex_sets]
        offsets = np.cumsum([0] + self.counts[:-1])
        tri = [np.asarray(f, np.int64) + o for f, o in zip(faces, offsets)]
        self.face_object = np.concatenate([np.full(len(f), i, np.int32) for i, f in enumerate(faces)])
        all_faces = np.concatenate(tri)
        self.caster = RayCaster(np.vstack(vertex_sets), all_faces, np.zeros((3 * len(all_faces), 2)),
                                np.ones((1, 1)), self.device)

    def update(self, vertex_sets) -> None:
        self.caster.update(np.vstack(vertex_sets))

    def render(self, camera) -> np.ndarray:
        """(H, W) int32: the index of the object seen through each pixel centre, −1 for none."""
        wp = self.caster.wp
        primary, _ = kernels()
        uu, vv = np.meshgrid(np.arange(camera.width) + 0.5, np.arange(camera.height) + 0.5)
        rays = camera.rays(uu, vv).astype(np.float32).reshape(-1, 3)
        n = len(rays)
        face = wp.zeros(n, dtype=wp.int32, device=self.device)
        px = wp.zeros(n, dtype=wp.vec2, device=self.device)
        depth = wp.zeros(n, dtype=wp.float32, device=self.device)
        wp.launch(primary, dim=n, inputs=[self.caster.mesh.id, wp.vec3(*map(float, camera.origin)),
                                          wp.array(rays, dtype=wp.vec3, device=self.device), self.caster.corner_px,
                                          self.caster.alpha, 1e6], outputs=[px, face, depth], device=self.device)
        f = face.numpy()
        ids = np.where(f >= 0, self.face_object[np.maximum(f, 0)], -1)
        return ids.reshape(camera.height, camera.width)
