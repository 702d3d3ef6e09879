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
from physomni_usd.rendering.stage import RenderObject, grounded

SIZE, F = 200, 200.0
EYE = 2.5


#: The object's pose where the photo shows it (USD row-vector form): turned 30° about z and 20° about x, moved.
_R = (trimesh.transformations.rotation_matrix(np.radians(30), (0, 0, 1))
      @ trimesh.transformations.rotation_matrix(np.radians(20), (1, 0, 0)))[:3, :3].T
POSE = np.eye(4)
POSE[:3, :3] = _R
POSE[3, :3] = (0.3, -0.2, 0.5)


def _slab_object():
    """A disc with a thin stalk (4 px wide) in a 200 px photo, lifted as a 1 m deep slab 2 m away (in the world;
    its points in its own frame, posed by :data:`POSE`), and the camera (looking along +y, z up, :data:`EYE` m
    above the floor, so that the slab stands half a metre above it where the photo shows it)."""
    camera = RenderCamera(SIZE, SIZE, F, F, np.array([0.0, 0.0, EYE]),
                          np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]))
    mask = np.zeros((SIZE, SIZE), np.uint8)
    cv2.circle(mask, (80, 100), 40, 1, -1)
    mask[98:102, 120:180] = 1  # the stalk, 4 px wide
    texture = np.zeros((SIZE, SIZE, 4), np.uint8)
    texture[..., :3] = 128
    texture[..., 3] = mask * 255
    box = trimesh.creation.box(extents=(4.0, 1.0, 4.0))
    box.apply_translation((0.0, 2.5, EYE))
    local = (np.asarray(box.vertices, np.float64) - POSE[3, :3]) @ np.linalg.inv(POSE[:3, :3])
    obj = RenderObject("/World/Objects/thing_0", np.asarray(box.faces), np.zeros((len(box.vertices), 2)), texture,
                       None, local, 2.0, None, (0, 0), None, False)
    return obj, camera, mask.astype(bool)


def test_the_pillow_is_closed_without_walls_and_thin_where_the_outline_is():
    obj, camera, mask = _slab_object()
    drawn = pillow(obj, camera, POSE)
    assert drawn is not None and drawn.body == "pillow"
    # its points in the object's own frame: posed as the photo shows it, they are in the world
    pts, faces = drawn.static_points @ POSE[:3, :3] + POSE[3, :3], drawn.faces
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
    ray = tri.mean(1) - camera.origin
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    assert np.abs(np.einsum("ij,ij->i", n, ray)).min() >= 0.25
    # every point on the ray of the pixel whose texel it takes, inside the mask
    uv, z = camera.project(pts)
    st = drawn.st * [SIZE, -SIZE] + [0.0, SIZE]
    assert np.abs(uv - st).max() < 1e-6
    assert mask[np.clip(uv[:, 1].astype(int), 0, SIZE - 1), np.clip(uv[:, 0].astype(int), 0, SIZE - 1)].all()
    # depth along each pixel's ray: within the slab (2 m to 3 m), centred on its middle (2.5 m), where the
    # physics' slab has its mass and its faces to rest on
    ray_depth = pts[:, 1]
    assert ray_depth.min() > 2.0 - 5e-3 and ray_depth.max() <= 3.0 + 5e-3  # the mesh read on a coarser grid
    disc = uv[:, 0] < 120
    stalk = uv[:, 0] > 130
    assert ray_depth[disc].max() - ray_depth[disc].min() > 0.15  # the disc bulges (40 px radius: 0.4 m across)
    assert abs(0.5 * (ray_depth[disc].max() + ray_depth[disc].min()) - 2.5) < 0.01
    # the stalk (4 px: 4 cm wide) no thicker than half its width, and a little for the grid's cells
    _, texel = np.unique(np.round(drawn.st, 9), axis=0, return_inverse=True)
    texel = texel.ravel()
    thick = np.zeros(texel.max() + 1)
    np.maximum.at(thick, texel, ray_depth)
    low = np.full(texel.max() + 1, np.inf)
    np.minimum.at(low, texel, ray_depth)
    thick -= low  # per texel: from its front point to its back point
    assert thick[texel[stalk]].max() <= 0.02 + 0.01
    assert abs(np.median(ray_depth[stalk]) - 2.5) < 0.01


def test_a_pillow_lying_down_rests_where_its_slab_does():
    """Lying on its back (the slab's front up), the pillow, thinner than the slab, is set down on the floor the
    slab stands on; lifted off it, it stays in the slab's middle."""
    obj, camera, _ = _slab_object()
    drawn = pillow(obj, camera, POSE)
    lying = np.eye(4)
    # the photo's pose, then turned 90° about x: the photo's depth (world y) now up
    lying[:3, :3] = POSE[:3, :3] @ trimesh.transformations.rotation_matrix(np.radians(90), (1, 0, 0))[:3, :3].T
    slab_low = (obj.static_points @ lying[:3, :3])[:, 2].min()
    lying[3, 2] = -slab_low  # the slab on the floor
    pts = drawn.static_points @ lying[:3, :3] + lying[3, :3]
    assert pts[:, 2].min() > 0.2  # as posed, the pillow (0.44 m thick) hangs in the slab's (1 m) middle
    assert abs(grounded(drawn, pts, lying)[:, 2].min()) < 1e-6
    lying[3, 2] += 0.5  # in the air: drawn where the body is
    up = drawn.static_points @ lying[:3, :3] + lying[3, :3]
    assert np.array_equal(grounded(drawn, up, lying), up)


def _lowest(drawn, pose):
    return grounded(drawn, drawn.static_points @ pose[:3, :3] + pose[3, :3], pose)[:, 2].min()


def test_a_pillow_is_set_down_gradually_as_its_slab_leaves_the_floor():
    """Lying down, the pillow is set down with its slab on the floor and drawn where the body is once the slab is
    GROUND_FADE_M up, rising gradually between: all or nothing at GROUND_TOUCH_M, 0.0099 m up it was drawn
    0.0099 m up, 0.0101 m up 0.26 m (its half thickness) higher."""
    from physomni_usd.rendering.stage import GROUND_FADE_M, GROUND_TOUCH_M

    obj, camera, _ = _slab_object()
    drawn = pillow(obj, camera, POSE)
    lying = np.eye(4)
    lying[:3, :3] = POSE[:3, :3] @ trimesh.transformations.rotation_matrix(np.radians(90), (1, 0, 0))[:3, :3].T
    slab_low = (obj.static_points @ lying[:3, :3])[:, 2].min()
    pillow_low = (drawn.static_points @ lying[:3, :3])[:, 2].min()
    heights = np.linspace(0.0, 0.15, 301)
    drawn_low = []
    for up in heights:
        pose = lying.copy()
        pose[3, 2] = up - slab_low
        drawn_low.append(_lowest(drawn, pose))
    drawn_low = np.array(drawn_low)
    touching = heights <= GROUND_TOUCH_M
    assert np.abs(drawn_low[touching] - heights[touching]).max() < 1e-6  # on the floor with its slab
    aloft = heights >= GROUND_FADE_M
    assert np.abs(drawn_low[aloft] - (heights[aloft] - slab_low + pillow_low)).max() < 1e-6  # where the body is
    assert np.all(np.diff(drawn_low) > 0)  # rising with the slab
    step = heights[1] - heights[0]
    assert np.diff(drawn_low).max() < 6 * step  # no jump: at most its half thickness over the fade's 9 cm
    near = [_lowest(drawn, _lifted(lying, slab_low, h)) for h in (GROUND_TOUCH_M - 1e-4, GROUND_TOUCH_M + 1e-4)]
    assert near[1] - near[0] < 1e-3


def _lifted(pose, slab_low, up):
    out = pose.copy()
    out[3, 2] = up - slab_low
    return out


def test_at_the_photos_pose_the_pillow_is_drawn_as_built():
    """Standing on the floor where the photo shows it, the pillow is drawn as built even where the mask's bottom
    pixels reach below its slab's hull (set down there, the photo's bike was lifted 1.9 px, the bench 1.1 px);
    posed elsewhere it moves by as much as its set-down changed from the photo's."""
    obj, camera, _ = _slab_object()
    drawn = pillow(obj, camera, POSE)
    pts = drawn.static_points @ POSE[:3, :3] + POSE[3, :3]
    standing = POSE.copy()
    standing[3, 2] -= pts[:, 2].min()  # the pillow's lowest point on the floor
    # a slab whose hull reaches 3 mm less far down than the mask: it stands on the floor (GROUND_TOUCH_M)
    hull = (pts + (0.0, 0.0, 0.003) - POSE[3, :3]) @ np.linalg.inv(POSE[:3, :3])
    drawn = dataclasses.replace(drawn, slab_points=hull, photo_pose=standing)
    at_photo = drawn.static_points @ standing[:3, :3] + standing[3, :3]
    assert np.array_equal(grounded(drawn, at_photo, standing), at_photo)
    # counted from nothing rather than the photo's pose, it was lifted by the 3 mm
    lifted = grounded(dataclasses.replace(drawn, photo_pose=None), at_photo, standing)
    assert abs(lifted[:, 2].min() - 0.003) < 1e-9
    # 1 cm higher, the set-down fades a little: drawn by the fade's share of the 3 mm lower than the body
    up = standing.copy()
    up[3, 2] += 0.02
    posed = drawn.static_points @ up[:3, :3] + up[3, :3]
    assert np.all(grounded(drawn, posed, up)[:, 2] <= posed[:, 2])


def test_a_slab_scaled_to_nothing_is_no_pillow():
    obj, camera, _ = _slab_object()
    flat = POSE.copy()
    flat[:3, :3] = 0.0
    assert pillow(obj, camera, flat) is None


def test_a_box_like_outline_stays_its_slab():
    obj, camera, _ = _slab_object()
    square = np.zeros_like(obj.texture)
    square[50:150, 50:150] = 255
    assert pillow(dataclasses.replace(obj, texture=square), camera, POSE) is None


def test_the_quick_starts_fallen_bike_is_drawn_on_the_floor(motorcycle_run):
    """The quick start (the bike pushed sideways, 2 m/s): at its last frame the bike lies on the floor, and its
    pillow's lowest point is the slab's, on the floor (on the slab's front, it hung 27 cm above it)."""
    from pxr import Usd, UsdGeom

    from physomni_usd.rendering.stage import read_objects, world_points
    from physomni_usd.rendering.video import ShotRenderer
    from physomni_usd.usd import layers

    proc, out = motorcycle_run
    assert proc.returncode == 0, proc.stderr[-2000:]
    stage = layers.open_shot(out / "shot.usda")
    drawn = {o.path: o for o in ShotRenderer(stage).objects}
    slab = next(o for o in read_objects(stage) if "motorcycle" in o.path)
    assert drawn[slab.path].body == "pillow"
    end = Usd.TimeCode(stage.GetEndTimeCode())
    cache = UsdGeom.XformCache(end)
    slab_pts = world_points(slab, cache, stage, end)
    pillow_pts = world_points(drawn[slab.path], cache, stage, end)
    m = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(slab.path)))
    assert abs(m[2, 2]) < 0.5  # fallen: its own up (local z) no longer the world's
    assert slab_pts[:, 2].min() < 0.01
    assert abs(pillow_pts[:, 2].min() - slab_pts[:, 2].min()) < 0.02
