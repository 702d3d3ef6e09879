"""What is left where an object stood: bench look's figures, on a made-up frame and on the desk example."""

from __future__ import annotations

import json
import pathlib
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from physomni_usd.bench import look
from physomni_usd.bench.look import TARGETS, contact_sheet, revealed_figures, within_targets

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def _state(face: np.ndarray, **more) -> SimpleNamespace:
    """A made-up frame's state whose every face on a ray is opaque: the first face is the one shown."""
    return SimpleNamespace(mesh_face=face, face=face, **more)


def _frame(fill: str) -> tuple:
    """A 120×160 wood-like frame whose disc (where an object stood, now gone) is filled as ``fill`` says."""
    rng = np.random.default_rng(3)
    y, x = np.mgrid[:120, :160]
    wood = 120 + 25 * np.sin(x / 3.0 + 2 * np.sin(y / 17.0)) + rng.normal(0, 4, (120, 160))
    img = np.repeat(wood[..., None], 3, -1)
    disc = (x - 80) ** 2 + (y - 60) ** 2 < 25 ** 2
    if fill == "flat":
        img[disc] = img[disc].mean(0)
    img = np.clip(img, 0, 255).astype(np.uint8)
    tex = np.zeros((120, 160, 4), np.uint8)
    tex[..., 3] = disc * 255
    obj = SimpleNamespace(origin=(0, 0), texture=tex, two_sided=False, path="/World/Objects/ball")
    renderer = SimpleNamespace(objects=[obj], width=160, height=120, to_frame=(1.0, 1.0))
    state = _state(np.full((120, 160), -1, np.int32))
    return renderer, img, state


def test_a_fill_that_continues_the_surface_is_on_target_and_a_flat_patch_is_not():
    good = revealed_figures(*_frame("texture"))
    flat = revealed_figures(*_frame("flat"))
    assert len(good) == len(flat) == 1
    assert within_targets(good[0]), good
    assert flat[0]["gradient_ratio"] < 0.6 and not within_targets(flat[0]), flat


def test_an_objects_cut_outs_over_the_plate_cover_nothing():
    """A face whose texel there is transparent (a slab's back seen between a wheel's spokes) shows the plate
    behind it: the area is read as revealed where the caster's opaque hit (``FrameState.face``) says so, whatever
    the first face on the ray."""
    renderer, img, state = _frame("texture")
    seen = len(revealed_figures(renderer, img, state))
    over = np.full((120, 160), 0, np.int32)  # one face over the whole frame, transparent everywhere
    cut_out = SimpleNamespace(mesh_face=over, face=np.full((120, 160), -1, np.int32))
    assert len(revealed_figures(renderer, img, cut_out)) == seen == 1
    assert revealed_figures(renderer, img, _state(over)) == []  # opaque: the object covers it


def _across_the_horizon(fill: str) -> tuple:
    """A 480×320 frame like the cloth example's: a grey-blue backdrop above row 150 that lightens downward, a
    brown grained floor below that darkens downward; where an object stood, 140×200 px across the horizon
    (53 % of it backdrop), the plate shows, filled as ``fill`` says ("right": the surfaces themselves,
    "offset": 12 levels too bright, "flat": one colour); the object now lies on the floor to the left of it,
    across the area's lower left and the ring beside it, and a crate stands in place to the right. Its ring
    is 68 % backdrop."""
    h, w, horizon = 320, 480, 150
    rng = np.random.default_rng(4)
    y, x = np.mgrid[:h, :w].astype(float)
    back = np.stack([172 + 0.12 * y, 177 + 0.12 * y, 187 + 0.12 * y], -1) + rng.normal(0, 3, (h, w, 1))
    grain = 8 * np.sin(x / 4.0 + 3 * np.sin(y / 23.0)) + rng.normal(0, 4, (h, w))
    floor = np.stack([138 - 0.25 * (y - horizon)] * 3, -1) * [1.0, 0.87, 0.73] + grain[..., None]
    img = np.where((y < horizon)[..., None], back, floor)
    stood = np.zeros((h, w), bool)
    stood[75:275, 130:270] = True
    if fill == "offset":
        img[stood] += 12.0
    elif fill == "flat":
        img[stood] = img[stood].mean(0)
    img = np.clip(img, 0, 255).astype(np.uint8)
    face = np.full((h, w), -1, np.int32)
    face[170:290, 60:200], img[170:290, 60:200] = 0, (200, 40, 40)  # the object, lying
    face[195:265, 270:390], img[195:265, 270:390] = 1, (90, 70, 50)  # the crate, in place
    tex, crate = np.zeros((h, w, 4), np.uint8), np.zeros((h, w, 4), np.uint8)
    tex[..., 3], crate[195:265, 270:390, 3] = stood * 255, 255
    objs = [SimpleNamespace(origin=(0, 0), texture=t, two_sided=False, path=f"/World/Objects/{n}")
            for t, n in ((tex, "towel"), (crate, "crate"))]
    renderer = SimpleNamespace(objects=objs, width=w, height=h, to_frame=(1.0, 1.0))
    return renderer, img, _state(face)


def test_an_area_across_two_surfaces_is_compared_with_each_surface_where_it_lies():
    """The ring of an area across the horizon holds the backdrop and the floor in other proportions than the
    area: by plain means the right fill is 13 levels off and one 12 levels too bright passes; compared with
    the ring near each of its pixels, the right fill is on target, the bright one is not, and a flat patch
    still fails its gradient."""
    right, offset, flat = (revealed_figures(*_across_the_horizon(f)) for f in ("right", "offset", "flat"))
    assert [f["object"] for f in right + offset + flat] == ["/World/Objects/towel"] * 3
    right, offset, flat = right[0], offset[0], flat[0]
    assert right["colour_difference_plain"] > 8 and offset["colour_difference_plain"] <= 8, (right, offset)
    assert within_targets(right) and right["colour_difference"] < 2, right
    assert offset["colour_difference"] > 10 and not within_targets(offset), offset
    assert flat["gradient_ratio"] < 0.6 and not within_targets(flat), flat


def _wide_on_the_floor(fill: str) -> tuple:
    """A 480×320 frame like the water example's: the backdrop and floor of :func:`_across_the_horizon`, an
    area 200 px wide whose top 20 rows are backdrop and the rest floor, filled as ``fill`` says; what stood
    there now lies in front of it, over its lower rows and the ring below. The floor just under the horizon
    is 100 px from the floor beside the area and 20-40 px from the backdrop above it."""
    h, w, horizon = 320, 480, 150
    rng = np.random.default_rng(6)
    y, x = np.mgrid[:h, :w].astype(float)
    back = np.stack([172 + 0.12 * y, 177 + 0.12 * y, 187 + 0.12 * y], -1) + rng.normal(0, 3, (h, w, 1))
    floor = np.stack([138 - 0.25 * (y - horizon)] * 3, -1) * [1.0, 0.87, 0.73] + rng.normal(0, 4, (h, w, 1))
    img = np.where((y < horizon)[..., None], back, floor)
    stood = np.zeros((h, w), bool)
    stood[130:265, 100:300] = True
    if fill == "offset":
        img[stood] += 12.0
    img = np.clip(img, 0, 255).astype(np.uint8)
    face = np.full((h, w), -1, np.int32)
    face[230:300, 60:340], img[230:300, 60:340] = 0, (60, 110, 200)  # the water, spread in front
    tex = np.zeros((h, w, 4), np.uint8)
    tex[..., 3] = stood * 255
    obj = SimpleNamespace(origin=(0, 0), texture=tex, two_sided=False, path="/World/Objects/water")
    renderer = SimpleNamespace(objects=[obj], width=w, height=h, to_frame=(1.0, 1.0))
    return renderer, img, _state(face)


def test_a_wide_area_on_the_floor_is_compared_with_the_floor_beside_it_not_the_backdrop_above(monkeypatch):
    """Nearest by plain distance, the floor under the horizon meets the backdrop above the area, and the right
    fill reads more than 8 levels off; with distances across the ring's bands (its colour changes with height)
    counted up to ``look.MAX_ANISOTROPY`` times, it meets the floor beside it: the right fill is on target and one 12
    levels too bright is not."""
    right, offset = (revealed_figures(*_wide_on_the_floor(f))[0] for f in ("right", "offset"))
    assert within_targets(right) and right["colour_difference"] < 2, right
    assert offset["colour_difference"] > 10 and not within_targets(offset), offset
    monkeypatch.setattr(look, "MAX_ANISOTROPY", 1.0)
    plain = revealed_figures(*_wide_on_the_floor("right"))[0]
    assert plain["colour_difference"] > 8, plain


def test_the_shadow_of_an_object_beside_the_area_is_not_the_fill_s_colour_or_grain():
    """An object moved a few pixels leaves a crescent of plain surface hugging it; its contact shadow, darkest
    next to it, darkens the crescent more than the ring farther out and falls off across it: the figures read
    the frame rendered without the shadow, where the fill is the surface, and give the frame as shown beside."""
    renderer, _, _ = _frame("texture")
    rng = np.random.default_rng(1)
    plain = np.clip(np.array([150.0, 140, 130]) + rng.normal(0, 4, (120, 160, 1)), 0, 255).astype(np.uint8)
    y, x = np.mgrid[:120, :160]
    obj = (x - 74) ** 2 + (y - 60) ** 2 < 20 ** 2  # the disc at (80, 60), radius 25, moved 6 px left
    plain[obj] = (200, 40, 40)
    state = _state(np.where(obj, 0, -1).astype(np.int32))
    away = cv2.distanceTransform((~obj).astype(np.uint8), cv2.DIST_L2, 5)
    shaded = np.clip(plain * (1.0 - 0.4 * np.exp(-away / 4.0))[..., None], 0, 255).astype(np.uint8)
    as_shown = revealed_figures(renderer, shaded, state)[0]
    unshaded = revealed_figures(renderer, shaded, state, plain)[0]
    assert as_shown["colour_difference"] > 8, as_shown
    assert unshaded["colour_difference"] < 1 < 8 < unshaded["colour_difference_plain"], unshaded
    assert within_targets(unshaded), unshaded
    # its fall-off across the crescent reads as grain as shown
    assert unshaded["gradient_ratio_as_shown"] == as_shown["gradient_ratio"] > 1.25 * unshaded["gradient_ratio"]
    assert unshaded["border_ratio_as_shown"] == as_shown["border_ratio"]


def test_against_a_ring_of_one_colour_the_local_colour_is_the_plain_one():
    renderer, img, state = _frame("texture")
    disc = renderer.objects[0].texture[..., 3] > 0
    img = np.where(disc[..., None], img, np.array([120, 90, 60], np.uint8))
    f = revealed_figures(renderer, img, state)[0]
    assert f["colour_difference"] == f["colour_difference_plain"] > 8, f


def test_pixels_drawn_over_by_particles_are_an_object_in_the_frame():
    """Water's particles are no mesh faces: where they lie over the area left behind, the area is not
    revealed, and their blue does not count against the fill."""
    renderer, img, state = _frame("texture")
    y, x = np.mgrid[:120, :160]
    splash = (y > 65) & (x > 50) & (x < 110)
    img[splash] = (40, 90, 220)
    alpha = np.where(splash, 1.0, 0.0).astype(np.float32)
    blind = revealed_figures(renderer, img, state)[0]  # the particles unseen, as mesh faces alone saw them
    seen = revealed_figures(renderer, img, _state(state.mesh_face, particle_alpha=alpha))[0]
    assert blind["colour_difference"] > 8, blind
    disc = renderer.objects[0].texture[..., 3] > 0
    assert seen["revealed_px"] <= int((disc & ~splash).sum()) < blind["revealed_px"], (seen, blind)
    assert within_targets(seen), seen


def _partly_moved(fill: str, part: float = 0.5) -> tuple:
    """The made-up wood frame of an object that has moved only 0.5 of the way the renderer fades it over (as the
    desk's cap, knocked 1.6 px): the photo shows it as a dark disc with its contact shadow, a darker crescent, to
    its lower right; the plate is the wood (``fill`` "texture") or one flat colour over the disc and the
    shadow; the object is drawn 2 px to the right, and the frame without contact shadows is, by design, half the
    photo and half the plate around it. With ``part`` 0.1 (moved 0.95 px) the object is drawn 1 px to the right
    and the frame around it is the photo's own pixels, as the renderer shows an object nudged that little."""
    renderer, wood, _ = _frame("texture")
    y, x = np.mgrid[:120, :160]
    disc = renderer.objects[0].texture[..., 3] > 0
    shade = ((x - 84) ** 2 + (y - 64) ** 2 < 33 ** 2) & ~disc
    photo = wood.astype(np.float32)
    photo[shade] *= 0.6
    photo[disc] = (30, 60, 70)
    plate = wood.astype(np.float32)
    if fill == "flat":
        plate[disc | shade] = plate[disc | shade].mean(0)
    now = (x - (82 if part >= 0.5 else 81)) ** 2 + (y - 60) ** 2 < 25 ** 2
    frame = photo + (part if part >= 0.5 else 0.0) * (plate - photo)
    frame[now] = (30, 60, 70)
    renderer.photo, renderer.plate, renderer.owner = photo, plate, np.zeros((120, 160), np.int32)
    renderer._moved_since_start = lambda camera, points, particles: (np.array([part, 1.0]), [])
    state = _state(np.where(now, 0, -1).astype(np.int32), points=np.zeros((1, 3)), camera=None)
    image = np.clip(frame + 0.5, 0, 255).astype(np.uint8)
    return renderer, image, state, image


def test_an_object_moved_part_of_the_way_is_judged_by_its_plate_not_the_photo_s_fading_shadow():
    """Where its object has moved only part of the way, the frame is partly the photo still, its own shadow
    fading out: that remnant is the photo's, and the fill is read as it shows once the object has left (a
    fill as good as the surface passes; a flat one does not)."""
    good = revealed_figures(*_partly_moved("texture"))
    flat = revealed_figures(*_partly_moved("flat"))
    assert len(good) == len(flat) == 1
    assert within_targets(good[0]), good  # read on the frame, the half-faded shadow: 29 levels off, border 2.6x
    assert not within_targets(flat[0]) and flat[0]["gradient_ratio"] < 0.6, flat
    # nudged under a pixel of the fade the frame is the photo still: nothing was revealed, whatever the plate
    # holds (the sweets' candies, moved 0.9-1.1 px, would otherwise each gain a row read on their whole plate hole)
    assert revealed_figures(*_partly_moved("texture", 0.1)) == [], revealed_figures(*_partly_moved("texture", 0.1))
    assert revealed_figures(*_partly_moved("flat", 0.1)) == []


def test_contact_sheet_is_one_row_of_equal_heights():
    sheet = contact_sheet([("a", np.zeros((100, 150, 3), np.uint8)), ("missing", None)])
    assert sheet.shape[0] == 240 and sheet.shape[2] == 3 and sheet.shape[1] > 240 + 360


@pytest.mark.slow  # 74 s (builds the desk example) on a loaded 2-core machine
def test_where_the_desk_ball_stood_the_plate_continues_the_wood(tmp_path):
    """The bundled desk example, its ball pushed for half a second: in the last frame the area it left
    has the wood's grain, no outline and the wood's colour, at 480 px and at the photo's own 640 px (the
    size a render of 880 px gives it: frames are never larger than the photo). The ball strikes the cap,
    which takes its share of the blow and slides 1.2 mm (1.6 px at 480, 2.1 px at 640, a jolt a viewer sees):
    what the cap left must continue the wood too (moved less than the renderer's fade, its figures are read on
    its plate: the frame there is partly the photo's own shadow), and nothing that stayed in place reveals its plate."""
    import physomni_usd as api
    from pxr import UsdGeom
    from physomni_usd.rendering.video import ShotRenderer
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    folder = EXAMPLES / "desk"
    spec = json.loads((folder / "example.json").read_text())
    result = api.build(folder / spec["photo"], tmp_path / "shot", (), spec["boxes"], pushes=spec["push"])
    api.simulate(result.shot, SimulateSettings(seconds=0.6))
    stage = layers.open_shot(result.shot)
    start, end = UsdGeom.XformCache(stage.GetStartTimeCode()), UsdGeom.XformCache(stage.GetEndTimeCode())
    # the objects the take moved at all, by their pose: only these may show their plate (the cap's plate shows
    # because the ball knocked it aside, not because the ball's shadow or the photo's slabs say so)
    moved = {p.GetName().split("_")[0] for p in stage.GetPrimAtPath("/World/Objects").GetChildren()
             if p.IsA(UsdGeom.Xformable) and not np.allclose(start.GetLocalToWorldTransform(p),
                                                            end.GetLocalToWorldTransform(p), atol=1e-6)}
    assert "ball" in moved, moved
    for size in (480, 880):
        renderer = ShotRenderer(stage, RenderSettings(max_size=size))
        image, state = renderer.render(float(stage.GetEndTimeCode()))
        # the ball's contact shadow darkens the photo around what stays in place: that reveals nothing
        unshaded = ShotRenderer(stage, RenderSettings(max_size=size, shadow_strength=0.0)).frame(
            float(stage.GetEndTimeCode()))
        figures = {f["object"].rsplit("/", 1)[-1].split("_")[0]: f
                   for f in revealed_figures(renderer, image, state, unshaded)}
        assert "ball" in figures and set(figures) <= moved, (size, moved, figures)
        for name, figure in figures.items():
            assert within_targets(figure), (size, renderer.width, name, figure)


@pytest.mark.slow  # 27 s (builds the motorcycle example) on a loaded 2-core machine
def test_where_the_motorcycle_stood_the_plate_continues_the_floor(tmp_path):
    """The bundled motorcycle, pushed along its length (1.4 m/s: it slides 14 cm on its wheels, upright) for
    0.6 s: in the last frame, at the photo's own 741 px, the area it left shows no outline (border within
    bench look's target). Its grain and colour miss their targets, on main as here (0.522 / 8.59 before the
    plate was given back beyond the seam, covered pixels counted by opaque hits; given back, the ring beside
    the fill is the shelves' and their shade, which the top-down floor fill does not continue: measured 52,552 px revealed, gradient 0.513 of the ring's (target
    ≥ 0.6), border 1.27 (≤ 1.3; 1.37 when the fill stopped within one pixel at the seam), colour 9.94 levels
    (≤ 8)): they are held at today's figures so that they cannot silently get worse."""
    import physomni_usd as api
    from physomni_usd.rendering.video import ShotRenderer
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    folder = EXAMPLES / "motorcycle"
    spec = json.loads((folder / "example.json").read_text())
    result = api.build(folder / spec["photo"], tmp_path / "shot", [str(folder / m) for m in spec["masks"]], (),
                       pushes=["motorcycle=1.4,0,0"])
    api.simulate(result.shot, SimulateSettings(seconds=0.6))
    stage = layers.open_shot(result.shot)
    renderer = ShotRenderer(stage, RenderSettings(max_size=880))
    image, state = renderer.render(float(stage.GetEndTimeCode()))
    figures = {f["object"].rsplit("/", 1)[-1].split("_")[0]: f for f in revealed_figures(renderer, image, state)}
    assert "motorcycle" in figures, figures
    bike = figures["motorcycle"]
    assert bike["revealed_px"] > 45000, bike  # the area the bike left, as the frame shows it
    assert bike["border_ratio"] <= TARGETS["border_ratio"][1], bike
    assert bike["gradient_ratio"] >= 0.49 and bike["colour_difference"] <= 10.5, bike  # today's, not the targets


def _two_surfaces() -> np.ndarray:
    """A 120×160 plate: a striped wall above, a speckled floor below (different colours and grains)."""
    rng = np.random.default_rng(5)
    y, x = np.mgrid[:120, :160]
    wall = np.stack([150 + 30 * np.sin(x / 2.5 + rng.normal(0, 0.2, x.shape))] * 3, -1) * [1.0, 0.8, 0.6]
    floor = 110 + rng.normal(0, 18, (120, 160, 1)) * [1, 1, 1]
    plate = np.where((y < 50)[..., None], wall, cv2.GaussianBlur(floor, (0, 0), 1.0))
    return np.clip(plate, 0, 255).astype(np.uint8)


def _ncc(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a.astype(float).ravel() - a.mean(), b.astype(float).ravel() - b.mean()
    return float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b) + 1e-9))


def test_exemplar_margins_continue_each_surface_and_mirror_nothing():
    from physomni_usd.texture.outpaint import exemplar_outpaint, mirror_outpaint

    plate = _two_surfaces()
    m = (60, 60, 80, 80)
    wide, mirrored = exemplar_outpaint(plate, m), mirror_outpaint(plate, m)
    assert wide.shape == (240, 320, 3) and np.array_equal(wide[60:180, 80:240], plate)
    # the left margin beside the floor, past the seam, against the floor's mirror image
    margin = (slice(130, 175), slice(50, 76))
    mirror_of_it = plate[70:115, 4:31][:, ::-1][:, :26]
    assert _ncc(mirrored[margin], mirror_of_it) > 0.6  # the check sees a mirror where there is one
    assert abs(_ncc(wide[margin], mirror_of_it)) < 0.3
    # below the floor: the floor's colour and grain; above the wall: the wall's
    grad = lambda im: float(np.abs(np.diff(im.astype(float).mean(-1), axis=1)).mean())
    below, floor = wide[190:235, 100:220], plate[60:120]
    above, wall = wide[5:55, 100:220], plate[:50]
    assert np.abs(below.reshape(-1, 3).mean(0) - floor.reshape(-1, 3).mean(0)).max() < 10
    assert np.abs(above.reshape(-1, 3).mean(0) - wall.reshape(-1, 3).mean(0)).max() < 15
    assert 0.5 < grad(below) / grad(floor) < 1.5 and 0.5 < grad(above) / grad(wall) < 1.5


def test_particles_read_as_one_shaded_surface_without_their_lattice():
    """A ball of particles on a regular lattice (as MPM seeds them), drawn over grey: its interior is
    smooth (no disc or highlight per particle), and it is lit from above on the left, shaded below right."""
    from physomni_usd.geometry.camera import RenderCamera
    from physomni_usd.rendering.video import ShotRenderer

    w, h = 200, 160
    cam = RenderCamera(w, h, 400.0, 400.0, np.zeros(3), np.eye(3))  # looking along +z, y down
    g = np.arange(-0.15, 0.151, 0.02)
    pts = np.stack(np.meshgrid(g, g, g), -1).reshape(-1, 3)
    pts = pts[np.linalg.norm(pts, axis=1) <= 0.15] + [0.0, 0.0, 1.0]
    fake = SimpleNamespace(width=w, height=h)
    fake._on_screen = lambda uv, z: ShotRenderer._on_screen(fake, uv, z)
    part = SimpleNamespace(colour=np.array([200.0, 170.0, 120.0]), width=0.02)
    drawn = np.zeros((h, w), np.float32)
    out = ShotRenderer._splat(fake, np.full((h, w, 3), 90.0, np.float32), cam, [(part, pts)], None, drawn)
    grey = cv2.cvtColor(np.clip(out, 0, 255).astype(np.uint8), cv2.COLOR_RGB2GRAY).astype(float)
    y, x = np.mgrid[:h, :w]
    r = np.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2)
    inside = r < 0.7 * 0.15 * 400 / 1.0
    detail = grey - cv2.GaussianBlur(grey, (0, 0), 6)
    assert detail[inside].std() < 4.0, detail[inside].std()  # a disc and a highlight per particle: 23
    upper_left = inside & (x < w / 2) & (y < h / 2)
    lower_right = inside & (x >= w / 2) & (y >= h / 2)
    assert grey[upper_left].mean() - grey[lower_right].mean() > 10
    # what the splat covers is told beside the image: all of the ball, nothing far from it
    assert (drawn[inside] > 0.99).all() and not drawn[r > 0.15 * 400 * 1.3].any()
    assert np.array_equal(drawn > 0, np.any(np.abs(out - 90.0) > 0.01, axis=-1))


def test_the_default_build_widens_the_world_without_a_mirrored_copy_of_the_photo(shot):
    """The wide plate ``build`` writes with its default outpainter: no margin is the photo reflected (the
    same check finds the mirror outpainter's reflection in it)."""
    from physomni_usd.metrics import mirror_similarity
    from physomni_usd.texture.outpaint import mirror_outpaint
    from physomni_usd.rendering.stage import read_wide_plate
    from physomni_usd.usd import layers

    wide, margins = read_wide_plate(layers.open_shot(shot["shot"]))
    t, b, l, r = margins
    assert min(margins) > 0 and wide.shape[:2] == (H := 180 + t + b, 240 + l + r), (wide.shape, margins)
    plate = wide[t:H - b, l:l + 240]
    assert mirror_similarity(mirror_outpaint(plate, margins), margins) > 0.6  # the check sees a mirror
    assert mirror_similarity(wide, margins) < 0.3


def _one_quad(texture_corners: np.ndarray) -> tuple:
    """A 100×80 frame fully covered by one object's two triangles, their corners at the frame's corners and at
    ``texture_corners`` (4, 2) in its 100×80 texture (the photo crop at photo pixel (0, 0)): the renderer
    and frame state :func:`orbit_walls` reads."""
    w, h = 100, 80
    screen = np.array([[0, 0], [w, 0], [w, h], [0, h]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    y, x = np.mgrid[:h, :w] + 0.5
    p = np.stack([x, y], -1)
    face = np.where(x * h >= y * w, 0, 1).astype(np.int32)  # above the diagonal: the first triangle
    bary = np.zeros((h, w, 2), np.float32)
    for k, f in enumerate(faces):  # point = u·p0 + v·p1 + (1 − u − v)·p2
        a, b, c = screen[f]
        m = np.linalg.inv(np.stack([a - c, b - c], 1))
        uv = (p - c) @ m.T
        bary[face == k] = uv[face == k]
    tex = np.full((h, w, 4), 255, np.uint8)
    obj = SimpleNamespace(origin=(0, 0), texture=tex, two_sided=False, path="/World/Objects/slab")
    renderer = SimpleNamespace(objects=[obj], caster=object(), corner_px=texture_corners[faces].reshape(-1, 2),
                               atlas_alpha=np.ones((h, w), np.float32), atlas_rgb=np.zeros((h, w, 3), np.float32),
                               face_object=np.zeros(2, np.int32), to_frame=(1.0, 1.0))
    return renderer, _state(face, bary=bary)


def test_orbit_walls_find_a_photo_column_smeared_across_the_frame_and_nothing_in_a_plain_view():
    from physomni_usd.bench.look import orbit_walls

    plain = orbit_walls(*_one_quad(np.array([[0, 0], [100, 0], [100, 80], [0, 80]], float)))
    assert plain[0]["wall_fraction"] == 0 and plain[0]["stretched_px"] == 0, plain
    # the texture's 5 columns at its left edge drawn across the whole width: a wall 100 % of the frame
    smeared = orbit_walls(*_one_quad(np.array([[0, 0], [5, 0], [5, 80], [0, 80]], float)))
    assert smeared[0]["wall_fraction"] > 0.85 and smeared[0]["stretched_px"] > 6500, smeared
    # one texel over everything: repeated
    one = orbit_walls(*_one_quad(np.array([[3, 3], [3.1, 3], [3.1, 3.1], [3, 3.1]], float)))
    assert one[0]["repeated_px"] > 6500 and one[0]["wall_fraction"] > 0.85, one


def test_under_an_orbit_the_motorcycle_example_shows_no_wall_of_stretched_pixels(tmp_path, built_case):
    """The bundled motorcycle (its bench top and its own extruded sides were walls of stretched pixels 5.7 %
    and 9 % of the frame wide) orbited left for a few frames: at the orbit's end no object shows a wall
    wider than 2 % of the frame. (Built from its masks: a copy of the session's build, simulated here.)"""
    import physomni_usd as api
    from physomni_usd.bench.look import MAX_WALL, orbit_walls
    from physomni_usd.rendering.video import ShotRenderer, write_camera_move
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    from .conftest import copy_of

    result = copy_of(built_case("example:motorcycle")[0], tmp_path / "shot")
    api.simulate(result.shot, SimulateSettings(seconds=0.2))
    stage = layers.open_shot(result.shot)
    write_camera_move(tmp_path / "shot", stage, "orbit-left", 1.0)
    stage = layers.open_shot(result.shot)
    renderer = ShotRenderer(stage, RenderSettings(max_size=600))
    _, state = renderer.render(float(stage.GetEndTimeCode()))
    assert not renderer._is_photo_camera(state.camera)
    walls = orbit_walls(renderer, state)
    assert {w["object"].rsplit("/", 1)[-1].split("_")[0] for w in walls} >= {"motorcycle", "bench"}, walls
    assert all(w["wall_fraction"] <= MAX_WALL for w in walls), walls


def test_a_turned_surface_keeps_the_light_where_it_was():
    """A ball turned half round about the camera's axis: the face that was lit now faces away and is shaded
    down to the ambient; the face that was in shade faces the light and is brightened no more than the cap;
    unturned, nothing changes."""
    import trimesh

    from physomni_usd.geometry.camera import RenderCamera
    from physomni_usd.rendering.video import PARTICLE_AMBIENT, TURN_BRIGHTEN, ShotRenderer

    ball = trimesh.creation.icosphere(subdivisions=3)
    rest = np.asarray(ball.vertices, np.float64) + [0.0, 0.0, 5.0]
    cam = RenderCamera(8, 8, 40.0, 40.0, np.zeros(3), np.eye(3))  # looking along +z, y down
    to_light = -np.array([0.4, 0.7, 0.6]) / np.linalg.norm([0.4, 0.7, 0.6])
    lit = int(np.argmax(ball.face_normals @ to_light))
    dark = int(np.argmin(ball.face_normals @ to_light))
    half_turn = np.diag([-1.0, -1.0, 1.0])
    turned = (rest - [0.0, 0.0, 5.0]) @ half_turn.T + [0.0, 0.0, 5.0]

    def factor(points, f):
        fake = SimpleNamespace(points_at=lambda t: rest, stage=SimpleNamespace(GetStartTimeCode=lambda: 0.0),
                               faces=np.asarray(ball.faces), photo_camera=cam, _rest_normals=None)
        state = SimpleNamespace(points=points, bary=np.full((1, 1, 2), 1.0 / 3.0, np.float32),
                                mesh_face=np.array([[f]]), camera=cam)
        return float(ShotRenderer._turned_shading(fake, np.array([[f]]), state)[0, 0])

    assert factor(rest, lit) == pytest.approx(1.0) and factor(rest, dark) == pytest.approx(1.0)
    assert factor(turned, lit) == pytest.approx(PARTICLE_AMBIENT, abs=0.05)
    assert 1.0 < factor(turned, dark) <= TURN_BRIGHTEN + 1e-6


def test_the_novel_view_figure_counts_each_object_by_its_worse_side(monkeypatch, tmp_path):
    """The truth scenes' novel-view figure: an object counts when both its -45° and +45° silhouettes reach the
    limit; one side below it, or a scene that did not build, does not."""
    from physomni_usd.bench import general

    built = {7000: {"built": True, "objects": [{"label": "cup", "iou_left": 0.9, "iou_right": 0.8},
                                                {"label": "book", "iou_left": 0.95, "iou_right": 0.5}]},
             7001: {"built": False, "error": "no camera", "objects": []}}
    calls = []

    def rows(index, seed, folder, modes, seconds, echo):
        calls.append((index, pathlib.Path(folder).parent.name, modes))
        return [built[seed * 1000 + index]]

    monkeypatch.setattr(general, "scene_rows", rows)
    said = []
    fig = look.novel_view_figure([{"seed": 7000, "index": 0}, {"seed": 7001, "index": 1}], 7, tmp_path,
                                 echo=said.append)
    assert calls == [(0, "scene_000", ("masks",)), (1, "scene_001", ("masks",))]
    assert [o["iou_novel"] for o in fig["objects"]] == [0.8, 0.5]
    assert fig["held"] == 1 and fig["limit"] == general.LIMITS["iou_novel"]
    assert any("not built" in s for s in said) and "1 of 2" in said[-1]
