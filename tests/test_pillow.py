"""The pillow a slab-lifted object is drawn with (rendering/pillow.py): closed, no face edge-on to the photo's
rays (no wall to draw a texel out across), a thin part thin, every point on the ray of the pixel it textures,
and never deeper than the lifted mesh."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import trimesh

from physomni_usd.geometry.camera import RenderCamera
from physomni_usd.rendering.pillow import pillow
from physomni_usd.rendering.stage import RenderObject

SIZE, F = 200, 200.0


def _slab_object():
    """A disc with a thin stalk (4 px wide) in a 200 px photo, lifted as a 0.4 m slab 2 m away, and the camera
    (looking along +y, z up)."""
    camera = RenderCamera(SIZE, SIZE, F, F, np.zeros(3), np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]))
    mask = np.zeros((SIZE, SIZE), np.uint8)
    cv2.circle(mask, (80, 100), 40, 1, -1)
    mask[98:102, 120:180] = 1  # the stalk, 4 px wide
    texture = np.zeros((SIZE, SIZE, 4), np.uint8)
    texture[..., :3] = 128
    texture[..., 3] = mask * 255
    box = trimesh.creation.box(extents=(2.0, 0.4, 2.0))
    box.apply_translation((0.0, 2.2, 0.0))
    obj = RenderObject("/World/Objects/thing_0", np.asarray(box.faces), np.zeros((len(box.vertices), 2)), texture,
                       None, np.asarray(box.vertices, np.float64), 2.0, None, (0, 0), None, False)
    return obj, camera, mask.astype(bool)


def test_the_pillow_is_closed_without_walls_and_thin_where_the_outline_is():
    obj, camera, mask = _slab_object()
    drawn = pillow(obj, camera, np.eye(4))
    assert drawn is not None and drawn.body == "pillow"
    pts, faces = drawn.static_points, drawn.faces
    # closed: no edge on one face only, so no ray slips between front and back (a part a cell or two wide is
    # a sheet there twice, its edges on four faces)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts % 2 == 0).all()
    # no wall: every face turned at least 0.25 in cosine to the ray from the camera, a texel drawn out at most
    # 4 times once it faces a camera (a slab's walls are 0: drawn out without end)
    tri = pts[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ray = tri.mean(1) / np.linalg.norm(tri.mean(1), axis=1, keepdims=True)
    assert np.abs(np.einsum("ij,ij->i", n, ray)).min() >= 0.25
    # every point on the ray of the pixel whose texel it takes, inside the mask
    uv, z = camera.project(pts)
    st = drawn.st * [SIZE, -SIZE] + [0.0, SIZE]
    assert np.abs(uv - st).max() < 1e-6
    assert mask[np.clip(uv[:, 1].astype(int), 0, SIZE - 1), np.clip(uv[:, 0].astype(int), 0, SIZE - 1)].all()
    # depth along each pixel's ray: the front on the slab's front (2 m), no point behind its back (2.4 m)
    dist = np.linalg.norm(pts, axis=1)
    ray_depth = pts[:, 1]
    assert ray_depth.min() > 2.0 - 5e-3 and ray_depth.max() <= 2.4 + 5e-3  # the mesh read on a coarser grid
    disc = uv[:, 0] < 120
    stalk = uv[:, 0] > 130
    assert ray_depth[disc].max() - 2.0 > 0.15  # the disc bulges (40 px radius: 0.4 m across)
    # the stalk (4 px: 4 cm wide) no thicker than half its width, and a little for the grid's cells
    assert ray_depth[stalk].max() - 2.0 <= 0.02 + 0.01
    assert np.isfinite(dist).all()


def test_a_box_like_outline_stays_its_slab():
    obj, camera, _ = _slab_object()
    square = np.zeros_like(obj.texture)
    square[50:150, 50:150] = 255
    assert pillow(dataclasses.replace(obj, texture=square), camera, np.eye(4)) is None
