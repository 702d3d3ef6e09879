"""What is left where an object stood: bench look's figures, on a made-up frame and on the desk example."""

from __future__ import annotations

import json
import pathlib
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from physomni_usd.bench.look import contact_sheet, revealed_figures, within_targets

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


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
    state = SimpleNamespace(mesh_face=np.full((120, 160), -1, np.int32))
    return renderer, img, state


def test_a_fill_that_continues_the_surface_is_on_target_and_a_flat_patch_is_not():
    good = revealed_figures(*_frame("texture"))
    flat = revealed_figures(*_frame("flat"))
    assert len(good) == len(flat) == 1
    assert within_targets(good[0]), good
    assert flat[0]["gradient_ratio"] < 0.6 and not within_targets(flat[0]), flat


def test_contact_sheet_is_one_row_of_equal_heights():
    sheet = contact_sheet([("a", np.zeros((100, 150, 3), np.uint8)), ("missing", None)])
    assert sheet.shape[0] == 240 and sheet.shape[2] == 3 and sheet.shape[1] > 240 + 360


def test_where_the_desk_ball_stood_the_plate_continues_the_wood(tmp_path):
    """The bundled desk example, its ball pushed for half a second: in the last frame the area it left
    has the wood's grain, no outline and the wood's colour, at 480 px and at the photo's own 640 px (the
    size a render of 880 px gives it: frames are never larger than the photo)."""
    import physomni_usd as api
    from physomni_usd.render.video import ShotRenderer
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    folder = EXAMPLES / "desk"
    spec = json.loads((folder / "example.json").read_text())
    result = api.build(folder / spec["photo"], tmp_path / "shot", (), spec["boxes"], pushes=spec["push"])
    api.simulate(result.shot, SimulateSettings(seconds=0.6))
    stage = layers.open_shot(result.shot)
    for size in (480, 880):
        renderer = ShotRenderer(stage, RenderSettings(max_size=size))
        image, state = renderer.render(float(stage.GetEndTimeCode()))
        # the ball's contact shadow darkens the photo around what stays in place: that reveals nothing
        unshaded = ShotRenderer(stage, RenderSettings(max_size=size, shadow_strength=0.0)).frame(
            float(stage.GetEndTimeCode()))
        figures = {f["object"].rsplit("/", 1)[-1].split("_")[0]: f
                   for f in revealed_figures(renderer, image, state, unshaded)}
        assert set(figures) == {"ball"}, (size, figures)
        assert within_targets(figures["ball"]), (size, renderer.width, figures["ball"])


def test_where_the_motorcycle_stood_the_plate_continues_the_floor(tmp_path):
    """The bundled motorcycle, pushed for 0.6 s: in the last frame, at the photo's own 741 px, the floor it
    left has the floor's grain (copied shelf edges had made it twice as busy), no outline and the floor's
    colour."""
    import physomni_usd as api
    from physomni_usd.render.video import ShotRenderer
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    folder = EXAMPLES / "motorcycle"
    spec = json.loads((folder / "example.json").read_text())
    result = api.build(folder / spec["photo"], tmp_path / "shot", [str(folder / m) for m in spec["masks"]], (),
                       pushes=spec["push"])
    api.simulate(result.shot, SimulateSettings(seconds=0.6))
    stage = layers.open_shot(result.shot)
    renderer = ShotRenderer(stage, RenderSettings(max_size=880))
    image, state = renderer.render(float(stage.GetEndTimeCode()))
    figures = {f["object"].rsplit("/", 1)[-1].split("_")[0]: f for f in revealed_figures(renderer, image, state)}
    assert "motorcycle" in figures, figures
    assert within_targets(figures["motorcycle"]), (renderer.width, figures["motorcycle"])


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
    from physomni_usd.perceive.plate import exemplar_outpaint, mirror_outpaint

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
    from physomni_usd.render.video import ShotRenderer

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
    from physomni_usd.perceive.plate import mirror_outpaint
    from physomni_usd.render.stage import read_wide_plate
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
    return renderer, SimpleNamespace(mesh_face=face, bary=bary)


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


def test_under_an_orbit_the_motorcycle_example_shows_no_wall_of_stretched_pixels(tmp_path):
    """The bundled motorcycle (its bench top and its own extruded sides were walls of stretched pixels 5.7 %
    and 9 % of the frame wide) orbited left for a few frames: at the orbit's end no object shows a wall
    wider than 2 % of the frame."""
    import physomni_usd as api
    from physomni_usd.bench.look import MAX_WALL, orbit_walls
    from physomni_usd.render.video import ShotRenderer, write_camera_move
    from physomni_usd.settings import RenderSettings, SimulateSettings
    from physomni_usd.usd import layers

    folder = EXAMPLES / "motorcycle"
    spec = json.loads((folder / "example.json").read_text())
    result = api.build(folder / spec["photo"], tmp_path / "shot", [str(folder / m) for m in spec["masks"]], ())
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
    from physomni_usd.render.video import PARTICLE_AMBIENT, TURN_BRIGHTEN, ShotRenderer

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
