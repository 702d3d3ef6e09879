"""What a slab (an extruded outline: the bundled motorcycle) shows once it moves or a camera orbits it: nothing
painted behind objects its placed mesh stands in front of, an open back rather than its front again, no wall
drawn out when it turns, and no floor shadow of it left in the plate."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from physomni_usd.bench.look import MAX_WALL, orbit_walls, photo_masks
from physomni_usd.rendering.stage import read_objects, read_photo_camera, world_points
from physomni_usd.rendering.video import ShotRenderer
from physomni_usd.settings import RenderSettings


def _keyed(stage: Usd.Stage) -> Usd.Stage:
    """``stage`` with every object's transform keyed (where it stands, at the first and last frame) in its
    session layer: a shot whose objects the physics may move, as a simulated one's are."""
    stage.SetEditTarget(stage.GetSessionLayer())
    for prim in Usd.PrimRange(stage.GetPrimAtPath("/World/Objects")):
        if prim.IsA(UsdGeom.Mesh):
            for op in UsdGeom.Xformable(prim).GetOrderedXformOps():
                value = op.Get(Usd.TimeCode(0))
                for t in (stage.GetStartTimeCode(), stage.GetEndTimeCode() + 1):
                    op.Set(value, Usd.TimeCode(t))
    return stage


@pytest.fixture(scope="module")
def motorcycle(built_case):
    """The motorcycle example built from its masks: the session's build (tests/conftest.py), read only; its
    renderer for a shot in which the objects may move (keyed in the session layer)."""
    result, _ = built_case("example:motorcycle")
    stage = _keyed(Usd.Stage.Open(str(result.shot)))
    return json.loads((result.folder / "report.json").read_text()), ShotRenderer(stage)


@pytest.fixture(scope="module")
def still_motorcycle(built_case):
    """The same build's stage as built (nothing keyed: every object stays where the photo shows it)."""
    result, _ = built_case("example:motorcycle")
    return Usd.Stage.Open(str(result.shot))


def test_nothing_is_painted_behind_what_the_placed_meshes_put_behind(motorcycle):
    # the motorcycle's convex closure takes in the bench and the bin behind it, so the photo's order says they
    # hide it; its mesh stands in front of both, and a grey fill there would follow it as a slab once it moves
    report, renderer = motorcycle
    order = {(o["front"], o["behind"]): o["kept"] for o in report["stages"]["build"]["occlusion"]}
    bike = next(o for o in report["objects"] if o["name"].startswith("motorcycle"))
    assert set(bike["occluded_by"]) == {"bench_1", "bin_2"}
    assert all(order[(k, bike["name"])] < 0.5 for k in bike["occluded_by"])
    assert bike["completed"]["pixels"] == 0
    k = next(i for i, o in enumerate(renderer.objects) if o.path.endswith(bike["name"]))
    photo_half = renderer.objects[k].texture[:, : renderer.objects[k].texture.shape[1] // 2, 3]
    assert not (photo_half == 254).any()


def test_a_ragged_slab_is_drawn_as_a_pillow_whose_back_is_its_front_mirrored(motorcycle):
    """The bike's outline is ragged (it fills 65 % of its hull): it is drawn as a pillow of its mask, its back
    taking the texel of the pixel it lies behind; the bin's box-like outline stays its slab, whose walls the
    unseen sides' copy textures."""
    _, r = motorcycle
    bodies = {o.path.split("/")[-1].rsplit("_", 1)[0]: o.body for o in r.objects}
    assert bodies == {"motorcycle": "pillow", "bench": "pillow", "bin": "mesh"}
    pts = r.points_at(Usd.TimeCode(0))[r.faces]
    n = np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    to_cam = r.photo_camera.origin - pts.mean(1)
    cos = np.einsum("ij,ij->i", n, to_cam / np.linalg.norm(to_cam, axis=1, keepdims=True))
    corner = r.corner_px.reshape(-1, 3, 2)
    k = next(i for i, o in enumerate(r.objects) if "motorcycle" in o.path)
    mine = r.face_object == k
    back, front = mine & (cos <= -0.3), mine & (cos >= 0.3)
    assert back.sum() > 1000 and front.sum() > 1000
    # no face edge-on to the photo's rays where a slab's walls were (a quarter of the slab's faces)
    assert (mine & (np.abs(cos) < 0.1)).sum() < 0.01 * mine.sum()
    # the back's texels are the front's own: the same place in the photo crop, not its unseen sides' copy
    assert (corner[back][..., 0] < r.photo_width[k]).all()
    alpha = r.atlas_alpha[corner[..., 1].astype(int), corner[..., 0].astype(int)]  # (F, 3)
    assert (alpha[back] > 0).any(axis=1).mean() > 0.9


def test_a_still_shot_draws_its_slabs_and_builds_no_pillow(still_motorcycle):
    """Nothing moves and the camera stays: frame 0 (the preview's opening frame, a bench's frame-0 score) is
    the slabs as built, the photo itself, and no pillow is built for it."""
    r = ShotRenderer(still_motorcycle)
    assert {o.body for o in r.objects} == {"mesh"}


def test_the_usd_keeps_an_extrusions_back_transparent(still_motorcycle):
    """The USD the shot hands to Blender or usdview still carries the slab (texture/sides.py): its back faces
    take a transparent texel of the crop, so a ray through the front's cut-outs leaves through the back, and
    its front the photo."""
    stage = still_motorcycle
    obj = next(o for o in read_objects(stage) if "motorcycle" in o.path)
    time = Usd.TimeCode(stage.GetStartTimeCode())
    pts = world_points(obj, UsdGeom.XformCache(time), stage, time)[obj.faces]
    n = np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    camera = read_photo_camera(stage, 64, 64)
    to_cam = camera.origin - pts.mean(1)
    cos = np.einsum("ij,ij->i", n, to_cam / np.linalg.norm(to_cam, axis=1, keepdims=True))
    h, w = obj.texture.shape[:2]
    st = obj.corner_st if obj.corner_st is not None else obj.st[obj.faces]
    x = np.clip(st[..., 0] * w, 0, w - 1).astype(int)
    y = np.clip((1.0 - st[..., 1]) * h, 0, h - 1).astype(int)
    alpha = obj.texture[y, x, 3]  # (F, 3)
    back, front = cos <= -0.3, cos >= 0.3
    assert back.sum() > 100 and front.sum() > 100
    assert (alpha[back] == 0).all()
    assert (alpha[front] > 0).any(axis=1).mean() > 0.5


def test_the_bikes_floor_shadow_goes_with_it(motorcycle):
    """Under the bike (between its outermost columns, within a quarter of its height of it) the photo's floor is
    dark (its shadow) where the plate is lit: a pushed bike leaves no hard dark patch behind (the plate kept
    79 % of it)."""
    _, r = motorcycle
    masks = photo_masks(r)
    k = next(i for i, o in enumerate(r.objects) if "motorcycle" in o.path)
    bike = masks[k]
    others = np.zeros_like(bike)
    for j, m in enumerate(masks):
        if j != k and m is not None:
            others |= m
    ys, xs = np.nonzero(bike)
    near = cv2.distanceTransform((~bike).astype(np.uint8), cv2.DIST_L2, 5) <= 0.25 * (ys.max() - ys.min() + 1)
    near[: (ys.min() + ys.max()) // 2] = False
    near[:, : xs.min()] = False
    near[:, xs.max() + 1:] = False
    near &= ~bike & ~others

    def lightness(image):
        return cv2.cvtColor(np.clip(image, 0, 255).astype(np.uint8), cv2.COLOR_RGB2Lab)[..., 0].astype(float)

    photo, plate = lightness(r.photo), lightness(r.plate)
    floor = np.zeros_like(bike)
    floor[int(0.85 * r.height):] = True
    lit = np.median(photo[floor & ~bike & ~others])
    shade_in_photo = (near & (photo < 0.7 * lit)).sum()
    assert shade_in_photo > 0.1 * near.sum()  # the photo does show a floor shadow there
    assert (near & (plate < 0.7 * lit)).sum() < 0.3 * shade_in_photo


@pytest.mark.parametrize("angle", [45.0, -45.0])
def test_a_turned_slab_draws_no_wall_out(motorcycle, angle):
    """Turned by 45 degrees where it stands, the bike's walls face the camera: no texel of them is drawn out
    into a wall (folded per vertex round the front wheel, one was 6.8 % of the frame wide)."""
    _, r = motorcycle
    stage = r.stage
    prim = next(p for p in Usd.PrimRange(stage.GetPrimAtPath("/World/Objects"))
                if p.IsA(UsdGeom.Mesh) and "motorcycle" in str(p.GetPath()))
    orient = prim.GetAttribute("xformOp:orient")
    q0 = orient.Get(Usd.TimeCode(0))
    turned = Gf.Rotation(Gf.Vec3d(0, 0, 1), angle).GetQuat() * Gf.Quatd(q0.GetReal(), Gf.Vec3d(q0.GetImaginary()))
    stage.GetSessionLayer().Clear()
    stage.SetEditTarget(stage.GetSessionLayer())
    try:
        orient.Set(Gf.Quatf(turned))
        renderer = ShotRenderer(stage, RenderSettings(shadow_strength=0.0))
        _, state = renderer.render(0.0)
        walls = {w["object"]: w for w in orbit_walls(renderer, state)}
    finally:
        stage.GetSessionLayer().Clear()
    bike = next(w for path, w in walls.items() if "motorcycle" in path)
    assert bike["pixels"] > 50000  # the bike is in view, turned
    assert bike["wall_fraction"] <= MAX_WALL, bike
