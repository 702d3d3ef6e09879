"""An object's unseen sides: a turn shows them textured at the photo's density, not its rim smeared."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

from physomni_usd.rendering.video import ShotRenderer
from physomni_usd.settings import RenderSettings

from .conftest import cli


@pytest.fixture(scope="module")
def slab(tmp_path_factory):
    """A patterned box-like object with a plain rim (as painted edges are), extruded, in the middle of a plain
    floor: a side textured from the rim would be plain."""
    d = tmp_path_factory.mktemp("sides")
    rng = np.random.default_rng(3)
    photo = np.full((180, 240, 3), 150, np.uint8)
    photo[:70] = 185  # a wall behind
    pattern = rng.integers(30, 230, (20, 25, 3)).astype(np.uint8)
    photo[60:140, 80:160] = (90, 60, 40)
    photo[66:134, 86:154] = cv2.resize(pattern, (68, 68), interpolation=cv2.INTER_NEAREST)
    mask = np.zeros((180, 240), np.uint8)
    mask[60:140, 80:160] = 255
    cv2.imwrite(str(d / "photo.png"), photo)
    cv2.imwrite(str(d / "slab.png"), mask)
    cli("build", d / "photo.png", "-o", d / "shot", "--mask", f"{d / 'slab.png'}:box", "--shape", "extrude",
        "--pitch", "20", "--camera-height", "1", "-q", check=True)
    return d / "shot"


def _gradient(frame: np.ndarray, where: np.ndarray) -> float:
    grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY).astype(np.float32)
    g = np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1))
    inner = cv2.erode(where.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert inner.sum() > 100
    return float(g[inner].mean())


def _faces_toward(renderer: ShotRenderer, camera, prim: Usd.Prim, edge_on_in_photo: bool) -> np.ndarray:
    """(H, W) bool: where the object's faces that face the frame's ``camera`` project — only those the photo saw
    edge-on when ``edge_on_in_photo`` (its sides), whatever its texture's alpha lets through."""
    mesh = UsdGeom.Mesh(prim)
    local = np.asarray(mesh.GetPointsAttr().Get(), float)
    faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(0)))
    pts = local @ m[:3, :3] + m[3, :3]
    tri, tri0 = pts[faces], local[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n0 = np.cross(tri0[:, 1] - tri0[:, 0], tri0[:, 2] - tri0[:, 0])  # unturned (the prim has no rotation of its own)
    cam, photo_cam = camera.origin, renderer.photo_camera.origin
    toward = np.einsum("ij,ij->i", n / np.linalg.norm(n, axis=1, keepdims=True),
                       (cam - tri.mean(1)) / np.linalg.norm(cam - tri.mean(1), axis=1, keepdims=True)) > 0.3
    if edge_on_in_photo:
        c0 = tri0.mean(1) + m[3, :3]
        d0 = (photo_cam - c0) / np.linalg.norm(photo_cam - c0, axis=1, keepdims=True)
        toward &= np.abs(np.einsum("ij,ij->i", n0 / np.linalg.norm(n0, axis=1, keepdims=True), d0)) < 0.3
    uv, _ = camera.project(pts)
    out = np.zeros((renderer.height, renderer.width), np.uint8)
    for f in faces[toward]:  # one at a time: fillPoly would cancel where faces overlap
        cv2.fillConvexPoly(out, np.round(uv[f] * 16).astype(np.int32), 1, shift=4)
    return out > 0


def test_a_quarter_turn_shows_a_side_as_detailed_as_the_front(slab):
    stage = Usd.Stage.Open(str(slab / "shot.usda"))
    prim = next(p for p in Usd.PrimRange(stage.GetPrimAtPath("/World/Objects")) if p.IsA(UsdGeom.Mesh))
    assert prim.GetAttribute("primvars:st").GetMetadata("interpolation") == UsdGeom.Tokens.faceVarying
    settings = RenderSettings(max_size=240)
    r = ShotRenderer(stage, settings)
    front, state = r.render(0.0)
    front_g = _gradient(front, _faces_toward(r, state.camera, prim, edge_on_in_photo=False))
    ratios = []
    for angle in (90.0, -90.0):
        stage.GetSessionLayer().Clear()
        stage.SetEditTarget(stage.GetSessionLayer())
        q = Gf.Rotation(Gf.Vec3d(0, 0, 1), angle).GetQuat()
        prim.GetAttribute("xformOp:orient").Set(Gf.Quatf(q))
        r = ShotRenderer(stage, settings)
        turned, state = r.render(0.0)
        side = _faces_toward(r, state.camera, prim, edge_on_in_photo=True)
        ratios.append(_gradient(turned, side) / front_g)
        # the side is solid (no see-through where its texture's alpha would cut it) and shows the object's
        # pattern, not its plain rim drawn out
        solid = float((r.caster.depth[side] < 1e5).mean())
        rim = float((np.abs(turned[side].astype(int) - (90, 60, 40)).max(axis=1) < 25).mean())
        assert solid > 0.9 and rim < 0.5, (angle, solid, rim)
    stage.GetSessionLayer().Clear()
    assert all(0.5 <= x <= 2.0 for x in ratios), ratios


def test_the_texture_holds_the_photo_and_an_opaque_copy(slab):
    tex = cv2.imread(str(next((slab / "textures").glob("box_*.png"))), cv2.IMREAD_UNCHANGED)
    h, w = tex.shape[:2]
    left, right = tex[:, : w // 2], tex[:, w // 2:]
    assert (left[..., 3] == 0).any() and (right[..., 3] == 255).all()
    layer = Sdf.Layer.FindOrOpen(str(slab / "scene.usda"))
    assert "unseenSides" in layer.ExportToString()


def test_preview_keeps_each_faces_side_of_the_texture():
    """The preview's GLB gives faceVarying st one vertex per corner: a face mapped into the unseen-side copy
    keeps its own coordinates instead of the mean with its photo-mapped neighbour's."""
    import io

    import trimesh

    from physomni_usd.preview.scene import Drawn, textured_glb

    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    faces = np.array([[0, 2, 1], [0, 1, 3]])
    corner_st = np.array([[[0.1, 0.1], [0.1, 0.4], [0.4, 0.1]],   # photo half
                          [[0.6, 0.1], [0.9, 0.1], [0.6, 0.4]]])  # unseen-side copy
    texture = np.full((8, 16, 4), 200, np.uint8)
    d = Drawn("/World/Objects/t", "t", points, faces, np.full((4, 2), 0.5), texture, np.eye(4), corner_st)
    scene = trimesh.load(io.BytesIO(textured_glb(d)), file_type="glb")
    mesh = next(iter(scene.geometry.values()))
    assert len(mesh.vertices) == 6
    uv = np.asarray(mesh.visual.uv)
    assert np.allclose(np.sort(uv[:, 0]), np.sort(corner_st.reshape(-1, 2)[:, 0]), atol=1e-6)


def test_the_opaque_copy_takes_the_interior_reflected_not_the_rim_drawn_out():
    """Outside a disc, every texel of the copy comes from inside it, and neighbours from different places
    (the nearest rim pixel would give a whole ray of texels one colour)."""
    from physomni_usd.texture.sides import copy_sources, filled_copy

    y, x = np.mgrid[:60, :80]
    mask = (x - 40) ** 2 + (y - 30) ** 2 < 18 ** 2
    src = copy_sources(mask)
    out = ~mask
    sx, sy = np.rint(src[..., 0]).astype(int), np.rint(src[..., 1]).astype(int)
    assert mask[sy[out], sx[out]].mean() > 0.95
    same = (np.abs(np.diff(src, axis=1)).max(-1) < 0.5) & out[:, 1:] & out[:, :-1]
    assert same.sum() < 0.05 * out.sum(), same.sum()
    rgba = np.dstack([np.random.default_rng(0).integers(0, 255, (60, 80, 3)).astype(np.uint8), mask * 255])
    filled = filled_copy(rgba.astype(np.uint8))
    assert (filled[..., 3] == 255).all() and np.array_equal(filled[mask, :3], rgba[mask, :3])


def test_an_edge_on_face_over_the_background_between_two_parts_stays_transparent():
    """Two parts of one mask with background between them (a mirror and a tail): a wall a lofted row lays across
    the gap keeps the photo's projection, which is transparent there; a wall on a part takes the opaque
    planar map."""
    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.texture.sides import corner_st

    camera = PinholeCamera(200, 200, 60.0, 0.0)  # level, at (0, 0, 1), looking along +y
    mask = np.zeros((100, 100), bool)
    mask[40:60, 5:20] = mask[40:60, 80:95] = True
    # two vertical walls along y, edge-on to the camera: one straight ahead, one 0.6 m to its left
    wall = np.array([[0.0, 3.0, 1.0], [0.0, 3.2, 1.0], [0.0, 3.0, 1.05]])
    points = np.vstack([wall, wall + [-0.6, 0.0, 0.0]])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    uv, _ = camera.project(points)
    origin = (int(round(uv[:3, 0].mean())) - 50, int(round(uv[:, 1].mean())) - 50)
    centres = np.stack([(uv[f] - origin).mean(0) for f in faces]).astype(int)
    assert not mask[centres[0, 1], centres[0, 0]] and mask[centres[1, 1], centres[1, 0]], centres
    plain = corner_st(points, faces, camera, (100, 100), origin).reshape(2, 3, 2)
    cut = corner_st(points, faces, camera, (100, 100), origin, mask=mask).reshape(2, 3, 2)
    assert (plain[..., 0] >= 0.5).all(), plain  # without the mask both take the opaque copy's planar map
    assert (cut[0, :, 0] < 0.5).all(), cut[0]  # over the gap: the photo's half, transparent there
    assert (cut[1, :, 0] >= 0.5).all(), cut[1]  # on a part: still the planar map


def test_a_side_continues_the_front_beside_it():
    """A box whose front is red on its left third, green in the middle, blue on its right: seen edge-on, its left
    side takes the red beside it and its right side the blue, not the front's middle on both (the motorcycle's
    rear wall showed its tank and engine)."""
    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.texture.sides import corner_st, two_sided_texture

    camera = PinholeCamera(200, 200, 60.0, 0.0)  # level, at (0, 0, 1), looking along +y
    x0, x1, y0, y1, z0, z1 = -0.3, 0.3, 3.0, 3.1, 0.8, 1.2
    points = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], float)
    import trimesh

    box = trimesh.convex.convex_hull(points)
    points, faces = np.asarray(box.vertices, float), np.asarray(box.faces)
    front = points[np.isclose(points[:, 1], y0)]
    uv, _ = camera.project(front)
    origin = (int(np.floor(uv[:, 0].min())) - 4, int(np.floor(uv[:, 1].min())) - 4)
    w, h = int(np.ceil(uv[:, 0].max())) - origin[0] + 5, int(np.ceil(uv[:, 1].max())) - origin[1] + 5
    mask = np.zeros((h, w), np.uint8)
    hull = cv2.convexHull(np.round(uv - origin).astype(np.int32))
    cv2.fillConvexPoly(mask, hull, 1)
    mask = mask > 0
    xs = np.nonzero(mask.any(0))[0]
    third = (xs.max() - xs.min() + 1) / 3.0
    rgba = np.zeros((h, w, 4), np.uint8)
    col = np.arange(w)
    rgba[:, col < xs.min() + third, :3] = (220, 20, 20)
    rgba[:, (col >= xs.min() + third) & (col < xs.min() + 2 * third), :3] = (20, 220, 20)
    rgba[:, col >= xs.min() + 2 * third, :3] = (20, 20, 220)
    rgba[..., 3] = mask * 255
    texture = two_sided_texture(rgba)
    st = corner_st(points, faces, camera, (w, h), origin, mask=mask).reshape(-1, 3, 2)
    tri = points[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)

    def colour(sel):
        s = st[sel].reshape(-1, 2)
        tx = np.clip((s[:, 0] * 2 * w).astype(int), 0, 2 * w - 1)
        ty = np.clip(((1.0 - s[:, 1]) * h).astype(int), 0, h - 1)
        assert (tx >= w).all()  # in the opaque copy
        return texture[ty, tx, :3].astype(float).mean(0)

    left, right = colour(n[:, 0] < -0.9), colour(n[:, 0] > 0.9)
    assert left[0] > 2 * max(left[1], left[2]), left
    assert right[2] > 2 * max(right[0], right[1]), right
