"""warp kernels of the renderer: primary rays with alpha cut-out, and contact shadows on the ground.

The primary kernel runs over a list of the image's pixels (those the objects' projected triangles may cover;
no other ray can hit them) and also returns each hit's barycentric coordinates, from which the control passes take the
surface point a pixel sees. The passes see the meshes (the first surface on each ray), the image sees them
through their textures' alpha (the photo's mask cuts each object out exactly).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np

from .._warp import load_warp

#: Surfaces a primary ray may pass through where the texture is transparent.
MAX_LAYERS = 8
#: CPU threads casting primary rays at once (at most the machine's cores).
MAX_THREADS = 8
#: A contact shadow is looked for this many of its reaches from the object (beyond, (1 + 5)⁻² < 3 % of it).
CONTACT_REACH = 5.0
#: A contact shadow fades as (1 + distance / reach)^−CONTACT_POWER: a sphere's ambient occlusion falls with the
#: cube of the distance to its centre; a square leaves the ring around a ball seen from above (where a cube's
#: shadow is hidden under it) dark enough to read, and is what the renderer and its docs use.
CONTACT_POWER = 2.0


@lru_cache(maxsize=1)
def kernels():
    """Compile (once, cached on disk by warp) and return the two kernels."""
    wp = load_warp()

    @wp.kernel
    def primary(mesh: wp.uint64, origin: wp.vec3, rays: wp.array(dtype=wp.vec3),
                corner_px: wp.array(dtype=wp.vec2), alpha: wp.array2d(dtype=wp.float32), max_t: float,
                pixels: wp.array(dtype=wp.int32),
                out_px: wp.array(dtype=wp.vec2), out_face: wp.array(dtype=wp.int32),
                out_depth: wp.array(dtype=wp.float32), out_mesh_face: wp.array(dtype=wp.int32),
                out_mesh_depth: wp.array(dtype=wp.float32), out_bary: wp.array(dtype=wp.vec2)):
        # one thread per listed pixel; i indexes the whole image's rays and outputs
        i = pixels[wp.tid()]
        d = rays[i]
        o = origin
        out_face[i] = -1
        out_depth[i] = max_t
        out_mesh_face[i] = -1
        out_mesh_depth[i] = max_t
        travelled = float(0.0)
        h = alpha.shape[0]
        w = alpha.shape[1]
        for _layer in range(MAX_LAYERS):
            q = wp.mesh_query_ray(mesh, o, d, max_t)
            if not q.result:
                break
            f = q.face
            if _layer == 0:  # the mesh itself, whatever its texture's alpha: what the control passes see
                out_mesh_face[i] = f
                out_mesh_depth[i] = q.t
                out_bary[i] = wp.vec2(q.u, q.v)
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
    def contact(meshes: wp.array(dtype=wp.uint64), weight: wp.array(dtype=wp.float32),
                reach: wp.array(dtype=wp.float32), cutoff: float, power: float, tail: float, origin: wp.vec3,
                back_normal: wp.vec3, back_offset: float, rays: wp.array(dtype=wp.vec3), first: int, step: int,
                out: wp.array(dtype=wp.float32)):
        # the ground point each ray meets, darkened by every weighted object by its distance to it; a ray that
        # meets the backdrop first sees no ground. Thread k of a launch takes ray first + k·step.
        i = first + wp.tid() * step
        d = rays[i]
        lit = float(1.0)
        t = float(-1.0)
        if d[2] < -1.0e-6 and origin[2] > 0.0:
            t = -origin[2] / d[2]
            dn = wp.dot(d, back_normal)
            if dn < -1.0e-9:
                t_back = (back_offset - wp.dot(origin, back_normal)) / dn
                if t_back > 0.0 and t_back < t:
                    t = -1.0
        if t > 0.0:
            g = origin + d * t
            for k in range(meshes.shape[0]):
                if weight[k] > 0.0:
                    q = wp.mesh_query_point_no_sign(meshes[k], g, cutoff * reach[k])
                    if q.result:
                        p = wp.mesh_eval_position(meshes[k], q.face, q.u, q.v)
                        gap = 1.0 + wp.length(p - g) / reach[k]
                        lit = lit * (1.0 - weight[k] * (wp.pow(gap, -power) - tail))
        out[i] = 1.0 - lit

    return primary, contact


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
        self._all = None
        self._threads = 1 if str(self.device).startswith("cuda") else max(1, min(os.cpu_count() or 1, MAX_THREADS))
        self._pool = ThreadPoolExecutor(self._threads) if self._threads > 1 else None
        self._loaded = False

    def _chunks(self, pixels: np.ndarray) -> list:
        """``pixels`` as warp arrays, one per CPU thread (interleaved, so each gets a like share of the objects'
        pixels), or one on a GPU."""
        n = self._threads if len(pixels) >= 4096 else 1
        return [self.wp.array(np.ascontiguousarray(pixels[k::n]), dtype=self.wp.int32, device=self.device)
                for k in range(n)]

    def update(self, points: np.ndarray) -> None:
        self.points.assign(self.wp.array(points.astype(np.float32), dtype=self.wp.vec3, device=self.device))
        self.mesh.refit()

    def cast(self, origin, rays: np.ndarray, max_t: float, pixels: np.ndarray | None = None):
        """Per pixel of ``rays``: face index (−1 for none) and atlas pixel coordinates.

        ``pixels`` (P,) int32 flat indices into ``rays``: the only pixels whose rays can hit anything (see
        :func:`covered_pixels`); the others are "no hit" without being cast. None casts every ray. :attr:`depth` then holds each pixel's
        distance along its ray to the surface seen (``max_t`` for none), :attr:`mesh_face` and
        :attr:`mesh_depth` the first face on each ray and its distance whatever the texture's alpha there,
        :attr:`bary` (H, W, 2) the barycentric (u, v) on that face (the point is u·p0 + v·p1 + (1 − u − v)·p2;
        undefined where nothing is hit). These are views of the caster's buffers, valid until the next cast."""
        wp = self.wp
        primary, _ = kernels()
        key = (rays.ctypes.data, rays.shape)
        if self._key != key:
            n = rays.shape[0] * rays.shape[1]
            self._rays = wp.array(rays.reshape(-1, 3), dtype=wp.vec3, device=self.device)
            self._px = wp.zeros(n, dtype=wp.vec2, device=self.device)
            self._face = wp.zeros(n, dtype=wp.int32, device=self.device)
            self._depth = wp.zeros(n, dtype=wp.float32, device=self.device)
            self._bary = wp.zeros(n, dtype=wp.vec2, device=self.device)
            self._mesh_face = wp.zeros(n, dtype=wp.int32, device=self.device)
            self._mesh_depth = wp.zeros(n, dtype=wp.float32, device=self.device)
            self._key = key
        shape = rays.shape[:2]
        if pixels is None:
            if self._all is None or self._all[0] != shape:
                self._all = (shape, self._chunks(np.arange(shape[0] * shape[1], dtype=np.int32)))
            chunks = self._all[1]
        else:
            for a, v in ((self._face, -1), (self._depth, float(max_t)), (self._mesh_face, -1),
                         (self._mesh_depth, float(max_t))):
                a.fill_(v)
            chunks = self._chunks(np.asarray(pixels, np.int32))
        o = wp.vec3(*map(float, origin))

        def launch(listed):
            wp.launch(primary, dim=listed.shape[0],
                      inputs=[self.mesh.id, o, self._rays, self.corner_px, self.alpha, float(max_t), listed],
                      outputs=[self._px, self._face, self._depth, self._mesh_face, self._mesh_depth, self._bary],
                      device=self.device)

        if len(chunks) > 1 and self._loaded:  # warp's CPU kernels run on one core and release the GIL
            list(self._pool.map(launch, chunks))
        else:  # the first launch loads (or compiles) the kernel: once, from this thread
            for c in chunks:
                if c.shape[0]:
                    launch(c)
            self._loaded = True
        self.depth = self._depth.numpy().reshape(shape)
        self.mesh_face = self._mesh_face.numpy().reshape(shape)
        self.mesh_depth = self._mesh_depth.numpy().reshape(shape)
        self.bary = self._bary.numpy().reshape(shape + (2,))
        return self._face.numpy().reshape(shape), self._px.numpy().reshape(shape + (2,))


def contact_falloff(gap: np.ndarray) -> np.ndarray:
    """Fraction of a contact shadow left at ``gap`` = distance to the object's surface / its reach (any shape):
    (1 + gap)^−:data:`CONTACT_POWER`, less its value at :data:`CONTACT_REACH`, so that it ends at 0 there
    without a step. The contact kernel computes the same."""
    g = np.asarray(gap, np.float64)
    tail = (1.0 + CONTACT_REACH) ** -CONTACT_POWER
    return np.where(g < CONTACT_REACH, (1.0 + g) ** -CONTACT_POWER - tail, 0.0)


class ContactCaster:
    """Soft contact shadows on the ground (z = 0): one BVH per object, so that each object darkens the ground
    by its own distance to it, whichever object is nearer; points are updated each frame like the ray caster's.

    The darkening of a ground point by object k is ``weight[k] · contact_falloff(d / reach[k])``, d the distance in
    metres from the point to the object's nearest surface: ambient-occlusion-like, strongest where the object
    touches the ground, fading both with the gap beneath it (height) and with distance beside it, whatever the
    light. Several objects combine as independent occluders: 1 − Π(1 − darkening)."""

    def __init__(self, points: np.ndarray, faces: np.ndarray, face_object: np.ndarray, device: str):
        wp = load_warp()
        self.wp = wp
        self.device = device
        self._vertices, self._points, self.meshes = [], [], []
        for k in range(int(face_object.max()) + 1 if len(face_object) else 0):
            f = faces[face_object == k]
            used = np.unique(f)  # this object's vertices, in the order of the whole stage's points
            self._vertices.append(used)
            pts = wp.array(points[used].astype(np.float32), dtype=wp.vec3, device=device)
            idx = wp.array(np.searchsorted(used, f).astype(np.int32).ravel(), dtype=wp.int32, device=device)
            self._points.append(pts)
            self.meshes.append(wp.Mesh(points=pts, indices=idx))
        self._ids = wp.array(np.array([m.id for m in self.meshes], np.uint64), dtype=wp.uint64, device=device)
        self._key, self._out, self._rays = None, None, None
        self._threads = 1 if str(device).startswith("cuda") else max(1, min(os.cpu_count() or 1, MAX_THREADS))
        self._pool = ThreadPoolExecutor(self._threads) if self._threads > 1 else None
        self._loaded = False

    def update(self, points: np.ndarray, weight: np.ndarray) -> None:
        """Move the objects with a positive ``weight`` (K,) to ``points`` (N, 3), the whole stage's, metres."""
        for k, (used, pts, mesh) in enumerate(zip(self._vertices, self._points, self.meshes)):
            if weight[k] > 0.0:
                pts.assign(self.wp.array(points[used].astype(np.float32), dtype=self.wp.vec3, device=self.device))
                mesh.refit()

    def darkening(self, origin, rays: np.ndarray, weight: np.ndarray, reach: np.ndarray,
                  backdrop: tuple[np.ndarray, float] | None = None) -> np.ndarray:
        """(h, w) float32 in [0, 1): how much each ray's ground point is darkened, for rays (h, w, 3) unit world
        from ``origin`` (3,); ``weight`` (K,) each object's darkening at contact (0 casts nothing), ``reach``
        (K,) metres (at d = reach it is down to a quarter). Rays that miss the ground, or meet the ``backdrop``
        plane (unit normal (3,) towards the camera, offset: dot(p, normal) = offset) before it, get 0. Call
        :meth:`update` first."""
        wp = self.wp
        _, contact = kernels()
        key = (rays.ctypes.data, rays.shape)
        if key != self._key:
            self._rays = wp.array(np.ascontiguousarray(rays.reshape(-1, 3), np.float32), dtype=wp.vec3,
                                  device=self.device)
            self._out = wp.zeros(self._rays.shape[0], dtype=wp.float32, device=self.device)
            self._key = key
        if not len(self.meshes) or not np.any(weight > 0):
            return np.zeros(rays.shape[:2], np.float32)
        normal, offset = backdrop if backdrop is not None else ((0.0, 0.0, 0.0), 0.0)
        w = wp.array(np.asarray(weight, np.float32), dtype=wp.float32, device=self.device)
        r = wp.array(np.maximum(np.asarray(reach, np.float32), 1e-6), dtype=wp.float32, device=self.device)
        n = self._rays.shape[0]
        step = self._threads if n >= 4096 else 1
        inputs = [self._ids, w, r, float(CONTACT_REACH), float(CONTACT_POWER),
                  float((1.0 + CONTACT_REACH) ** -CONTACT_POWER), wp.vec3(*map(float, origin)),
                  wp.vec3(*map(float, normal)), float(offset), self._rays]

        def launch(first: int) -> None:
            wp.launch(contact, dim=(n - first + step - 1) // step, inputs=inputs + [first, step],
                      outputs=[self._out], device=self.device)

        if step > 1 and self._loaded:  # interleaved over the CPU's cores, like the primary rays
            list(self._pool.map(launch, range(step)))
        else:  # the first launch loads the kernel, from this thread
            for first in range(step):
                launch(first)
            self._loaded = True
        return self._out.numpy().reshape(rays.shape[:2]).copy()  # the buffer is the next call's


def covered_pixels(cam, points: np.ndarray, faces: np.ndarray) -> np.ndarray | None:
    """Flat indices (P,) int32 of the pixels of ``cam`` (a RenderCamera) whose rays may hit a triangle of
    ``faces`` (M, 3) over ``points`` (N, 3) world: the triangles' projections filled and grown by two pixels,
    so that the list holds every pixel centre inside one. None (every pixel) when a point is not in front of
    the camera, where a projection says nothing."""
    import cv2

    uv, z = cam.project(points)
    # beyond a few frames' size, cv2's fixed point would overflow: cast everything then
    if not len(points) or np.min(z) <= 1e-6 or np.abs(uv).max() > 8.0 * max(cam.width, cam.height):
        return None
    mask = np.zeros((cam.height, cam.width), np.uint8)
    tri = np.round(uv * 16).astype(np.int32)[faces]
    for t in tri:  # one call per triangle: fillPoly of many polygons leaves their overlaps empty
        cv2.fillConvexPoly(mask, t, 1, lineType=cv2.LINE_8, shift=4)
    mask = cv2.dilate(mask, np.ones((5, 5), np.uint8))
    return np.flatnonzero(mask).astype(np.int32)


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
        bary = wp.zeros(n, dtype=wp.vec2, device=self.device)
        mesh_face = wp.zeros(n, dtype=wp.int32, device=self.device)
        mesh_depth = wp.zeros(n, dtype=wp.float32, device=self.device)
        wp.launch(primary, dim=n, inputs=[self.caster.mesh.id, wp.vec3(*map(float, camera.origin)),
                                          wp.array(rays, dtype=wp.vec3, device=self.device), self.caster.corner_px,
                                          self.caster.alpha, 1e6,
                                          wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device=self.device)],
                  outputs=[px, face, depth, mesh_face, mesh_depth, bary], device=self.device)
        f = face.numpy()
        ids = np.where(f >= 0, self.face_object[np.maximum(f, 0)], -1)
        return ids.reshape(camera.height, camera.width)


def cut_out_silhouettes(vertex_sets, faces, camera, cutouts, device: str | None = None) -> list[np.ndarray]:
    """Visible masks (H, W) bool of meshes from ``camera`` as the shot shows them there: each mesh seen through
    its cut-out ``cutouts[i]`` ((H, W) bool at the camera's size, what its texture projects from this camera
    as opaque: its mask), so that a mesh hides what is behind it only where it is opaque.

    The lifted meshes span their outlines' concavities (the gap between a motorcycle's wheels) and their
    textures cut those away. A texture projected from this camera gives every surface of an object on one of
    its rays the same alpha, so a pixel shows the nearest object that is opaque there: each mesh is cast only
    through the pixels of its cut-out, and the nearest first hit wins."""
    from .._warp import pick_device

    h, w = camera.height, camera.width
    uu, vv = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = np.ascontiguousarray(camera.rays(uu, vv).astype(np.float32))
    nearest = np.full(h * w, np.inf)
    ids = np.full(h * w, -1, np.int32)
    device = pick_device(device)
    for i, (v, f, cut) in enumerate(zip(vertex_sets, faces, cutouts)):
        pixels = np.flatnonzero(np.asarray(cut, bool)).astype(np.int32)
        if not len(pixels) or not len(f):
            continue
        caster = RayCaster(np.asarray(v, float), np.asarray(f, np.int64), np.zeros((3 * len(f), 2)),
                           np.ones((1, 1)), device)
        caster.cast(camera.origin, rays, 1e6, pixels)
        depth = np.where(caster.mesh_face.ravel() >= 0, caster.mesh_depth.ravel(), np.inf)
        nearer = depth < nearest
        nearest[nearer], ids[nearer] = depth[nearer], i
    ids = ids.reshape(h, w)
    return [ids == i for i in range(len(vertex_sets))]
