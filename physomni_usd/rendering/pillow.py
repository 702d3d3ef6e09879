"""The body a slab-lifted object is drawn with: a pillow of its photo mask, for the frames only.

A slab (``physomni:liftedShape`` ``extrude``) joins its front and back by walls along the photo's rays: once
the object turns (a push tips it over, an orbit walks round it) those walls face the camera and show the
outline's few pixels drawn out across the slab's whole depth (the fallen motorcycle's four hanging panels).
Drawn instead, each pixel of the mask is a front point and a back point on that pixel's ray, apart by a
parabola of the pixel's distance to the outline and centred on the lifted mesh's depth there, so that front and
back meet at the outline and there are no walls at all, and the pillow fills the middle of the slab the physics
moves (a fallen bike lying on its back rests on the floor, not a slab's half depth above it). The parabola
spans the widest disc of the mask that covers the pixel and is never steeper than :data:`RIM_SLOPE`, so that a
thin part (a mirror stalk, a leg) stays no thicker than half its width, and along each ray no point lies deeper
than the lifted mesh there (the mask's outline, though, may reach a pixel or two past the mesh's simplified one:
the photo's bike's bottom pixels lie below its slab). Both sides take the pixel's own texel: the back is the
front seen in a mirror. The pillow is laid in the mesh's own frame, so the physics body's transform poses it each
frame, and ``rendering.stage.grounded`` sets it down on the floor wherever the slab stands on it, counted from
the photo's pose (there it is drawn as built); the collider, the mesh in the USD and its physics are unchanged. Only a shot in which the object or the camera can move draws it (:func:`with_pillows`): frame 0 of
a still one is the slab's, the photo itself.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

#: The lifted shapes drawn as a pillow: the slab of an outline (the others are round, inflated or boxes).
SLABS = ("extrude",)
#: Least share of its convex hull an outline fills and still is drawn as its slab: a box-like outline (a bin, a
#: crate: 1.0) has flat walls that the unseen sides' copy textures (texture/sides.py); a ragged one (the
#: motorcycle 0.65, the bench 0.70) has walls that run in and out of every notch.
SLAB_SOLIDITY = 0.9
#: The slope of the pillow's back at the outline (depth over distance across the photo, 2: 63°): a texel is
#: drawn out at most √(1 + slope²) times wherever it is seen from, and a part is as thick as its half width.
RIM_SLOPE = 2.0
#: Steepest the pillow's front may run back along the rays, depth over distance across them (2: 63°): a
#: texel of it is drawn out at most √(1 + slope²) times once it faces the camera.
FRONT_SLOPE = 2.0
#: Cells of the pillow's grid across the mask's longer side (each a vertex on the front and one on the back).
CELLS = 192
#: Cells across the coarser grid on which the lifted mesh's depth along the rays is read (it varies slowly).
DEPTH_CELLS = 96


def _local_radius(inside: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """(h, w) per cell of ``inside``: the radius (cells) of the widest disc within the mask that covers it,
    to the nearest power of √2 — a thin part's own half width, not the body's beside it."""
    radius = np.zeros(dist.shape, np.float32)
    top = float(dist.max())
    r = 1.0
    while r <= top:
        k = int(np.ceil(r))
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * k + 1, 2 * k + 1))
        covered = cv2.dilate((dist >= r).astype(np.uint8), disc) > 0
        radius[covered & inside] = r
        r *= np.sqrt(2.0)
    return np.maximum(radius, dist)


def _mesh_depths(points: np.ndarray, faces: np.ndarray, origin: np.ndarray, rays: np.ndarray):
    """Per ray (unit, (R, 3)) from ``origin``: the distances (R,) to the first and last surface of the mesh
    it crosses, NaN where it misses."""
    import trimesh

    mesh = trimesh.Trimesh(points, faces, process=False)
    near = np.full(len(rays), np.nan)
    far = np.full(len(rays), np.nan)
    if not len(rays):
        return near, far
    loc, ray_idx, _ = mesh.ray.intersects_location(np.repeat(origin[None], len(rays), 0), rays,
                                                   multiple_hits=True)
    if len(ray_idx):
        t = np.einsum("ij,ij->i", loc - origin, rays[ray_idx])
        near_t = np.full(len(rays), np.inf)
        far_t = np.full(len(rays), -np.inf)
        np.minimum.at(near_t, ray_idx, t)
        np.maximum.at(far_t, ray_idx, t)
        hit = np.isfinite(near_t)
        near[hit], far[hit] = near_t[hit], far_t[hit]
    return near, far


def _filled(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``values`` (h, w) with every cell not ``known`` taking its nearest known cell's value."""
    if known.all() or not known.any():
        return values
    _, labels = cv2.distanceTransformWithLabels((~known).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    ky, kx = np.nonzero(known)
    lut = np.zeros(labels.max() + 1, values.dtype)
    lut[labels[ky, kx]] = values[ky, kx]
    return lut[labels]


def _gentle(near: np.ndarray, inside: np.ndarray, cell_m: float) -> np.ndarray:
    """``near`` (h, w) metres along the rays with no cell of ``inside`` more than :data:`FRONT_SLOPE` times the
    cells' spacing (``cell_m`` metres) behind a neighbour: a part of the lifted front that runs back along the
    rays (a slab's foot reaching behind, a tail at the outline) comes forward to its neighbours, so it is no
    wall of its own once the object turns."""
    out = np.where(inside, near, np.inf).astype(np.float32)
    rise = np.float32(FRONT_SLOPE * cell_m)
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(max(out.shape)):
        pulled = np.minimum(out, cv2.erode(out, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=np.inf) + rise)
        if np.array_equal(pulled, out):
            break
        out = pulled
    return np.where(inside, out, near).astype(np.float32)


def pillow(obj, camera, matrix: np.ndarray):
    """``obj`` (a RenderObject lifted as a slab, its points static, its texture placed in the photo) drawn as
    a pillow of its mask, or None where it is better a slab (its outline fills :data:`SLAB_SOLIDITY` of its
    hull) or cannot be one (no mask, the rays miss its mesh). ``camera`` is the
    photo's (a RenderCamera at the photo's own size), ``matrix`` (4, 4) the object's local-to-world transform
    where the photo shows it (USD row-vector form)."""
    if obj.static_points is None or obj.origin is None or len(obj.faces) == 0:
        return None
    tex = obj.texture
    crop_w = tex.shape[1] // 2 if obj.two_sided else tex.shape[1]
    alpha = tex[:, :crop_w, 3] >= 254  # the photo's own pixels of it (254: painted where another hides it)
    if alpha.sum() < 16:
        return None
    hull = cv2.convexHull(cv2.findNonZero(alpha.astype(np.uint8)))
    if alpha.sum() >= SLAB_SOLIDITY * cv2.contourArea(hull):
        return None
    ys, xs = np.nonzero(alpha)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    step = max(1.0, max(y1 - y0, x1 - x0) / CELLS)
    gh, gw = int(np.ceil((y1 - y0) / step)) + 2, int(np.ceil((x1 - x0) / step)) + 2
    # cell centres in crop pixels, one empty cell all round so that the outline closes inside the grid
    gx = x0 + (np.arange(gw) - 0.5) * step
    gy = y0 + (np.arange(gh) - 0.5) * step
    mx = np.clip(np.round(gx - 0.5).astype(int), 0, crop_w - 1)
    my = np.clip(np.round(gy - 0.5).astype(int), 0, tex.shape[0] - 1)
    inside = alpha[my][:, mx].copy()
    inside[[0, -1], :] = False
    inside[:, [0, -1]] = False
    if inside.sum() < 4:
        return None
    dist = cv2.distanceTransform(inside.astype(np.uint8), cv2.DIST_L2, 5)
    radius = _local_radius(inside, dist)
    # front and back meet on the outermost cells (at distance 1): the distance is counted from there, or the
    # first step in from them would rise one and a half cells' worth in one cell
    d = np.clip(dist - 1.0, 0.0, radius)
    # a parabola across the part, as steep as RIM_SLOPE at the outline and flat where the part is widest:
    # a texel is drawn out at most √(1 + slope²) times wherever the surface is seen from (a round profile,
    # upright at the outline, drew the rim's pixels across the whole side once the object lay down)
    bulge = RIM_SLOPE * 0.5 * radius * (1.0 - (1.0 - d / np.maximum(radius, 1e-6)) ** 2) * step  # crop px, depth
    boundary = inside & (cv2.erode(inside.astype(np.uint8), np.ones((3, 3), np.uint8)) == 0)
    bulge[boundary] = 0.0

    # the rays of the photo through each cell centre, and the lifted mesh's depth along them
    ox, oy = obj.origin
    uu = (ox + gx[None, :] - 0.5 * camera.width) / camera.fx
    vv = (oy + gy[:, None] - 0.5 * camera.height) / camera.fy
    d3 = np.stack(np.broadcast_arrays(uu, vv, np.ones_like(uu * vv)), -1) @ camera.axes
    rays = d3 / np.linalg.norm(d3, axis=-1, keepdims=True)  # (gh, gw, 3)
    world = obj.static_points @ matrix[:3, :3] + matrix[3, :3]
    coarse = max(1, int(np.ceil(max(gh, gw) / DEPTH_CELLS)))
    cy, cx = np.arange(0, gh, coarse), np.arange(0, gw, coarse)
    sub = rays[cy][:, cx]
    near, far = _mesh_depths(world, obj.faces, np.asarray(camera.origin, np.float64), sub.reshape(-1, 3))
    near, far = near.reshape(sub.shape[:2]), far.reshape(sub.shape[:2])
    known = np.isfinite(near)
    if not known.any():
        return None
    near, far = _filled(near, known), _filled(far, known)
    # coarse sample (i, j) lies on cell (i·coarse, j·coarse): read each cell between its samples there (a
    # resize to the grid's size would spread them evenly over it, up to a cell off at the far end)
    map_x = np.broadcast_to(np.arange(gw, dtype=np.float32)[None, :] / coarse, (gh, gw))
    map_y = np.broadcast_to(np.arange(gh, dtype=np.float32)[:, None] / coarse, (gh, gw))
    near, far = (cv2.remap(v.astype(np.float32), np.ascontiguousarray(map_x), np.ascontiguousarray(map_y),
                           cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE) for v in (near, far))
    # the pillow sits in the middle of the slab's depth, where the physics' slab has its mass and rests on its
    # faces (on the slab's front it hung a half slab above the floor once the bike lay on its back); the middle
    # is kept as gentle as the front should be, so that a step in the slab's depth is no wall of its own
    mid = _gentle(0.5 * (near + far), inside, step * float(np.median(near[inside])) / camera.fx)
    depth = np.minimum(bulge * mid / camera.fx, np.maximum(far - near, 0.0))
    near = mid - 0.5 * depth

    # vertices: each inside cell on the front and, unless it is on the outline, on the back
    index = -np.ones((gh, gw), np.int64)
    cells = np.argwhere(inside)
    index[inside] = np.arange(len(cells))
    back = -np.ones((gh, gw), np.int64)
    inner = inside & ~boundary
    back[inner] = len(cells) + np.arange(int(inner.sum()))
    back[boundary] = index[boundary]
    origin = np.asarray(camera.origin, np.float64)
    front_pts = origin + rays[inside] * near[inside][:, None]
    back_pts = origin + rays[inner] * (near + depth)[inner][:, None]
    pts_world = np.concatenate([front_pts, back_pts])
    texel = np.stack([np.broadcast_to(gx[None, :], (gh, gw)), np.broadcast_to(gy[:, None], (gh, gw))], -1)
    st_cell = np.stack([texel[..., 0] / tex.shape[1], 1.0 - texel[..., 1] / tex.shape[0]], -1)
    st = np.concatenate([st_cell[inside], st_cell[inner]])

    # each grid square split into two triangles, kept where all three corners are inside
    a, b = (slice(0, -1), slice(0, -1)), (slice(0, -1), slice(1, None))
    c, e = (slice(1, None), slice(1, None)), (slice(1, None), slice(0, -1))
    tris = []
    for p, q, r in ((a, b, c), (a, c, e), (a, b, e), (b, c, e)):
        ok = inside[p] & inside[q] & inside[r]
        # squares whose both diagonal splits apply would double up: a-b-c/a-c-e where all four are in
        four = inside[a] & inside[b] & inside[c] & inside[e]
        if (p, q, r) in ((a, b, e), (b, c, e)):
            ok &= ~four
        tris.append((index[p][ok], index[q][ok], index[r][ok], back[p][ok], back[q][ok], back[r][ok]))
    fi, fj, fk, bi, bj, bk = (np.concatenate(x) for x in zip(*tris))
    front_faces = np.stack([fi, fk, fj], 1)  # wound to face the photo's camera (image y runs down)
    back_faces = np.stack([bi, bj, bk], 1)
    # a face with all three corners on the outline is there twice, once each way: a sheet where the part is
    # a cell or two wide, closed like the rest (every edge between an even number of faces)
    faces = np.concatenate([front_faces, back_faces])
    if abs(np.linalg.det(matrix[:3, :3])) < 1e-12:  # scaled to nothing: no frame to lay the pillow in
        return None
    local = (pts_world - matrix[3, :3]) @ np.linalg.inv(matrix[:3, :3])
    # the slab's hull: the points whose lowest one says where the slab stands (grounded)
    import trimesh
    from scipy.spatial import QhullError

    try:
        hull = np.asarray(trimesh.Trimesh(obj.static_points, process=False).convex_hull.vertices, np.float64)
    except QhullError:  # a flat or degenerate slab: its own points, all of them
        hull = obj.static_points
    return dataclasses.replace(obj, faces=faces, st=st, static_points=local, corner_st=st[faces],
                               body="pillow", slab_points=hull, photo_pose=np.array(matrix, np.float64))


def with_pillows(objects: list, stage, camera) -> list:
    """``objects`` (RenderObjects) with each slab-lifted one replaced by its :func:`pillow` where the shot can
    show it turned: its transform varies in time or starts away from where the photo shows it, or the camera
    moves (the others, a slab that stays where the photo shows it, and one that cannot be made a pillow, as
    they are: the photo itself, and no pillow built for a frame-0 render of a still shot)."""
    from pxr import Usd, UsdGeom

    from ..usd.layers import transform_may_vary
    from .stage import read_photo_camera_matrix, scene_stage

    scene = scene_stage(stage)
    source = scene if scene is not None else stage  # the scene layer alone: where the photo shows each object
    cache = UsdGeom.XformCache(Usd.TimeCode(stage.GetStartTimeCode()))
    cam = stage.GetPrimAtPath("/World/Camera")
    camera_moves = bool(cam) and (transform_may_vary(cam) or not np.allclose(
        np.array(cache.GetLocalToWorldTransform(cam)), read_photo_camera_matrix(stage), atol=1e-6))
    out = []
    for o in objects:
        drawn = None
        if o.prim is not None and o.prim.GetCustomDataByKey("physomni:liftedShape") in SLABS:
            prim = source.GetPrimAtPath(o.path)
            if prim:
                matrix = np.array(cache.GetLocalToWorldTransform(prim))
                moves = camera_moves or transform_may_vary(o.prim) or not np.allclose(
                    np.array(cache.GetLocalToWorldTransform(o.prim)), matrix, atol=1e-6)
                if moves:
                    drawn = pillow(o, camera, matrix)
        out.append(drawn if drawn is not None else o)
    return out
