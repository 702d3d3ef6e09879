"""Support: a cup standing on its saucer in the photo stands on it in the scene, and stays there."""

from __future__ import annotations

import json

import numpy as np

from physomni_usd.align.support import find_supports
from physomni_usd.bench.photos import make_cup_on_saucer, make_known_scene, write_scene
from physomni_usd.metrics.geometry import max_penetration, world_meshes
from physomni_usd.usd import layers

from .conftest import cli


def test_supports_are_found_from_the_masks_and_side_by_side_objects_are_not():
    for pitch in (20.0, 45.0, 80.0):
        scene = make_cup_on_saucer(pitch)
        assert find_supports(scene.masks) == {0: (1, find_supports(scene.masks)[0][1])}, pitch
    assert find_supports(make_known_scene(30.0).masks) == {}


def _cup_and_saucer(stage, t):
    meshes = world_meshes(stage, t)
    cup = next(m for k, m in meshes.items() if k.startswith("cup"))
    saucer = next(m for k, m in meshes.items() if k.startswith("saucer"))
    return cup, saucer, meshes


def test_a_cup_on_its_saucer_stays_on_it(tmp_path):
    scene = make_cup_on_saucer(20.0)
    specs = write_scene(scene, tmp_path / "in")
    masks = [a for s in specs for a in ("--mask", s)]
    out = tmp_path / "shot"
    cli("build", tmp_path / "in" / "photo.png", "-o", out, "-q", *masks, check=True)
    report = json.loads((out / "report.json").read_text())
    assert report["shot"]["alignment"]["supports"] == {"cup_0": {"on": "saucer_1", "seen": "contact"}}
    stage = layers.open_shot(out)
    cup, saucer, meshes = _cup_and_saucer(stage, 0)
    top = saucer.vertices[:, 2].max()
    assert abs(cup.vertices[:, 2].min() - top) <= 0.005
    # it stands where the photo shows it: above the saucer, not pushed off onto the ground
    assert np.linalg.norm(cup.centroid[:2] - saucer.centroid[:2]) < 0.5 * np.ptp(saucer.vertices[:, 0])
    assert max_penetration(meshes) <= 0.002

    cli("simulate", out / "shot.usda", "--seconds", "2", "-q", check=True)
    stage = layers.open_shot(out)
    end = int(stage.GetEndTimeCode())
    cup, saucer, _ = _cup_and_saucer(stage, end)
    assert abs(cup.vertices[:, 2].min() - saucer.vertices[:, 2].max()) <= 0.005
    sim = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    assert sim["max_penetration_m"] <= 0.002


def _camera():
    from physomni_usd.geometry.camera import PinholeCamera

    return PinholeCamera(320, 240, 50.0, 20.0, (0.0, 0.0, 1.0))


def _block(centre, half):
    """A mesh-like thing (``vertices`` only) of an axis-aligned block standing on the ground."""
    from types import SimpleNamespace

    import trimesh

    box = trimesh.creation.box(extents=(2 * half[0], 2 * half[1], 2 * half[2]))
    return SimpleNamespace(vertices=np.asarray(box.vertices) + [centre[0], centre[1], half[2]])


def test_a_foot_its_occluder_hides_stands_behind_it_unless_it_lands_inside_its_footprint():
    from physomni_usd.align.photo_scene import behind_what_hides_it

    camera = _camera()
    upper = np.zeros((240, 320), bool)
    upper[80:160, 140:180] = True  # foot at row 160
    g = camera.ground_points(160.0, 160.0)
    in_front = _block((g[0], g[1] - 0.6), (0.4, 0.3, 0.3))  # the lemon before the lime: its footprint ends short
    around = _block((g[0], g[1]), (0.4, 0.3, 0.1))  # the bowl under the ball: the foot lands inside it
    assert behind_what_hides_it(in_front, upper, camera)
    assert not behind_what_hides_it(around, upper, camera)


def test_an_object_that_would_topple_off_its_supporter_does_not_balance_on_it():
    from types import SimpleNamespace

    from physomni_usd.align.photo_scene import balances_on

    peak = SimpleNamespace(vertices=np.array([[-0.2, -0.2, 0.0], [0.2, -0.2, 0.0], [0.2, 0.2, 0.0], [-0.2, 0.2, 0.0],
                                              [0.0, 0.0, 0.3], [0.01, 0.0, 0.3], [0.0, 0.01, 0.3]]))
    slab = _block((0.0, 0.0), (0.2, 0.2, 0.15))
    box = _block((0.1, 0.0), (0.1, 0.1, 0.1))
    box.vertices[:, 2] += 0.3
    assert balances_on(box, slab, 0.3)
    assert not balances_on(box, peak, 0.3)  # a box on the crown of a crumpled bag


def test_an_object_over_several_supporters_balances_on_them_together():
    """A board bridging two boxes, a fruit in the hollow on top of three: no one supporter holds its centre,
    the hull of its contacts with all of them does; a box beside it, or one under its end but far below, does
    not."""
    from types import SimpleNamespace

    import trimesh

    from physomni_usd.align.photo_scene import balances_on

    left, right = _block((-0.3, 0.0), (0.2, 0.2, 0.15)), _block((0.3, 0.0), (0.2, 0.2, 0.15))
    board = _block((0.0, 0.0), (0.45, 0.15, 0.02))
    board.vertices[:, 2] += 0.3
    assert not balances_on(board, left, 0.3) and not balances_on(board, right, 0.3)
    assert balances_on(board, left, 0.3, [right])
    far = _block((1.5, 0.0), (0.2, 0.2, 0.15))  # on the ground beside, under nothing
    assert not balances_on(board, left, 0.3, [far])
    low = _block((0.3, 0.0), (0.2, 0.2, 0.05))  # under the board's end but far below it: no contact
    assert not balances_on(board, left, 0.3, [low])

    def ball(x, y, z, r):
        return SimpleNamespace(vertices=np.asarray(trimesh.creation.icosphere(3, r).vertices) + [x, y, z])

    r = 0.04
    d = 1.15 * r  # the three under it touch; it touches each of them, its lowest point in their hollow
    pile = [ball(d * np.cos(a), d * np.sin(a), r, r) for a in np.radians([90.0, 210.0, 330.0])]
    top = ball(0.0, 0.0, r + np.sqrt(4.0 * r * r - d * d), r)
    base = float(top.vertices[:, 2].min())
    for k, under in enumerate(pile):
        assert not balances_on(top, under, base)
        assert balances_on(top, under, base, [p for j, p in enumerate(pile) if j != k])


def test_a_hidden_foot_reaches_down_behind_its_occluder_through_hidden_pixels_only():
    from physomni_usd.align.photo_scene import foot_behind

    camera = _camera()
    occluder = np.zeros((240, 320), bool)
    occluder[120:240, 60:260] = True
    book = np.zeros((240, 320), bool)
    book[10:121, 100:200] = True  # its lower part hidden: the visible outline ends on the occluder's edge
    g = camera.ground_points(160.0, 180.0)  # the occluder's back meets the ground where row 180 looks
    behind = _block((g[0], g[1] - 0.3), (1.0, 0.3, 0.2))
    out = foot_behind(book, [occluder], [behind], camera)
    assert out is not None
    added = out & ~book
    assert added.any() and not (added & ~occluder).any()
    rows = np.nonzero(added.any(axis=1))[0]
    assert abs(int(rows.max()) - 179) <= 2
    # its foot shows: nothing to reach down for; a round outline keeps its completed foot
    assert foot_behind(book, [np.zeros_like(occluder)], [behind], camera) is None
    disc = np.zeros((240, 320), bool)
    import cv2

    cv2.circle(disc.view(np.uint8), (160, 90), 35, 1, -1)
    assert foot_behind(disc, [occluder], [behind], camera) is None


def test_an_object_is_not_read_as_resting_on_what_hides_it():
    """A ball in a bowl, its lowest outline partly over the ball in front of it (which hides it): it rests on
    the bowl, not on that ball; without the occlusion order the ball in front reads as the one between."""
    from physomni_usd.bench.synthetic import make_stack
    from physomni_usd.perceive.amodal import complete, occlusion_order

    scene = make_stack("bowl_of_spheres", 480, 360)
    hides = occlusion_order(scene.masks)
    amodal = [c.amodal for c in complete(scene.masks, hides)]
    bowl = scene.labels.index("bowl")
    behind = [(a, b) for a, b in hides if b != bowl and scene.labels[a] == scene.labels[b] == "ball"]
    assert behind, hides  # the scene still has a ball hiding another
    front, back = behind[0]
    assert find_supports(amodal)[back][0] == front  # the reading the order corrects
    found = find_supports(amodal, hides)
    assert all(found[i][0] == bowl for i, label in enumerate(scene.labels) if label == "ball"), found


def test_a_board_over_two_boxes_rests_on_them_not_on_the_floor(tmp_path):
    """Neither box alone holds the board's centre, nor touches most of its lowest outline: it rests on them
    together, so it stands on their tops instead of reaching down to the floor behind them."""
    import cv2
    import trimesh

    from physomni_usd.bench.synthetic import render_truth
    from physomni_usd.building import build_shot
    from physomni_usd.geometry.camera import PinholeCamera

    def box(size, at):
        b = trimesh.creation.box(size)
        b.apply_translation([at[0], at[1], at[2] + size[2] / 2])
        return b

    camera = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -0.55, 0.35))
    truth = [box((0.10, 0.12, 0.08), (-0.09, 0.0, 0.0)), box((0.10, 0.12, 0.08), (0.09, 0.0, 0.0)),
             box((0.26, 0.08, 0.03), (0.0, 0.0, 0.08))]
    photo, masks = render_truth(camera, truth, np.random.default_rng(5))
    cv2.imwrite(str(tmp_path / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    specs = []
    for k, (m, label) in enumerate(zip(masks, ["box", "box", "board"])):
        cv2.imwrite(str(tmp_path / f"m{k}.png"), m.astype(np.uint8) * 255)
        specs.append(f"{tmp_path / f'm{k}.png'}:{label}")
    assert find_supports([np.asarray(m, bool) for m in masks]).get(2, (None,))[0] in (0, 1)
    build_shot(tmp_path / "photo.png", tmp_path / "shot", masks=specs)
    starts = {o["name"]: o["start"] for o in json.loads((tmp_path / "shot" / "report.json").read_text())["objects"]}
    assert starts["board_2"]["support"] in ("box_0", "box_1"), starts
    meshes = world_meshes(layers.open_shot(tmp_path / "shot"), 0)
    tops = [meshes[n].vertices[:, 2].max() for n in ("box_0", "box_1")]
    assert meshes["board_2"].vertices[:, 2].min() >= min(tops) - 0.01


def test_a_fruit_over_several_stands_on_them_only_where_a_hollow_among_them_holds_it():
    """The footprints' balance over several (``balances_on`` with others) reads no heights: a neighbour taller
    than the supporter's top, under the fruit, counts as holding it, where in fact the fruit would sit on that
    neighbour alone. ``held_in_hollow`` asks the steadying pass's own question (``into_hollow``): where no
    hollow holds it, the build stands it on the ground (a lemon stood on an apple beside a taller lemon was
    shifted onto the apple's dome and fell 19 cm)."""
    from types import SimpleNamespace

    import trimesh

    from physomni_usd.align.photo_scene import balances_on, held_in_hollow

    def ball(x, y, z, r, tall=1.0):
        m = trimesh.creation.icosphere(3, r)
        v = np.asarray(m.vertices) * [1.0, 1.0, tall] + [x, y, z]
        return SimpleNamespace(vertices=v, faces=np.asarray(m.faces))

    eye = SimpleNamespace(origin=np.array([0.0, -1.0, 0.5]))
    r = 0.04
    d = 1.15 * r
    pile = [ball(d * np.cos(a), d * np.sin(a), r, r) for a in np.radians([90.0, 210.0, 330.0])]
    top = ball(0.0, 0.0, r + np.sqrt(4.0 * r * r - d * d), r)
    assert balances_on(top, pile[0], float(top.vertices[:, 2].min()), pile[1:])
    assert held_in_hollow(top, pile[0], pile[1:], eye, 1.0)

    under = ball(0.0, 0.0, r, r)  # the one it was read as on
    taller = ball(0.06, 0.0, 1.25 * r, r, tall=1.25)  # its top 1 cm above the other's, under the fruit's side
    fruit = ball(0.035, 0.0, 2 * r + r, r)  # stood on ``under``'s top, its centre beyond it
    base = float(fruit.vertices[:, 2].min())
    assert not balances_on(fruit, under, base)
    assert balances_on(fruit, under, base, [taller])  # the footprints say held
    assert not held_in_hollow(fruit, under, [taller], eye, 1.0)  # it would rest on the taller one alone


def _balls(camera, centres, radii):
    """Each ball's whole outline and what the camera sees of it: its mask and its visible mask."""
    v, u = np.mgrid[0:camera.height, 0:camera.width]
    rays, eye = camera.rays(u + 0.5, v + 0.5), camera.origin
    hits = []
    for c, r in zip(centres, radii):  # where each ray first meets each ball
        b = rays @ (eye - c)
        disc = b * b - (np.sum((eye - c) ** 2) - r * r)
        hits.append(np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0.0)), np.inf))
    hits = np.stack(hits)
    masks = [np.isfinite(h) for h in hits]
    return masks, [m & (np.argmin(hits, axis=0) == k) for k, m in enumerate(masks)]


def _pile_of_four(rider=None):
    """Three fruit of radius 5.5 cm in a ring on the ground and a fourth in their hollow, seen 63° down, with
    ``rider`` (azimuth°, elevation° from the top one's crown, radius) resting on the top one."""
    from physomni_usd.geometry.camera import PinholeCamera

    camera = PinholeCamera(320, 240, 28.0, 63.0, (0.0, 0.0, 1.0))
    r, y0 = 0.055, 1.0 / np.tan(np.radians(63.0))
    d = 1.15 * r
    centres = [np.array([d * np.cos(a), y0 + d * np.sin(a), r]) for a in np.radians([210.0, 90.0, 330.0])]
    top = np.array([0.0, y0, r + np.sqrt(4 * r * r - d * d)])
    centres.append(top)
    radii = [r] * 4
    if rider is not None:
        a, e, rr = np.radians(rider[0]), np.radians(rider[1]), rider[2]
        centres.append(top + (r + rr) * np.array([np.sin(e) * np.sin(a), np.sin(e) * np.cos(a), np.cos(e)]))
        radii.append(rr)
    return camera, centres, radii, *_balls(camera, centres, radii)


def test_the_top_fruit_of_a_pile_rests_on_the_three_under_it_not_the_one_it_hides_on_it():
    """Seen from above, the top fruit of a pile hides the three under it, the back one all but a sliver over its
    crown. That sliver's completed disc sits on the top one's outline and reads as resting on it; the top one
    then had two fruit to hold it, stood on the ground a fruit's length behind the pile it hides, and the back
    one rode on it and rolled off. Where it hides that foot, the one read on it is weighed as one that may hold
    it: the top one rests in the hollow, the back one on the ground, marked as holding it."""
    from physomni_usd.align.photo_scene import lift_all
    from physomni_usd.perceive.amodal import occlusion_order
    from physomni_usd.settings import BuildSettings

    camera, centres, radii, masks, visible = _pile_of_four()
    r = radii[0]
    hides = occlusion_order(visible)
    supports = find_supports(masks, hides)
    assert supports[1][0] == 3 and (3, 1) in hides  # the back one read as on the top one, which hides it
    out = lift_all(masks, ["orange", "lemon", "lemon", "orange"], camera, BuildSettings(), 0.67, supports,
                   hides=hides, visible=visible)
    assert 1 not in supports and supports.get(3, (None,))[0] in (0, 1, 2)
    for k, c in enumerate(centres):
        assert np.linalg.norm(out[k].vertices.mean(axis=0) - c) < 0.5 * r, k
    assert out[1].info.get("holds") == [3]  # nothing raises it from under the top one (support.raise_unseen)


def test_of_the_ones_a_pile_top_hides_on_it_only_those_it_needs_go_to_the_ground():
    """The top fruit of a pile hides the back one's foot and a lime's resting on its crown; both read as on it.
    Without the back one it falls, the lime it does not need: the lime stays on it, not grounded far behind the
    pile because the back one holds the top one (it stood 8 of its radii from where it is)."""
    from physomni_usd.align import photo_scene
    from physomni_usd.settings import BuildSettings

    camera, centres, radii, masks, visible = _pile_of_four(rider=(0.0, 20.0, 0.03))
    hides = {(3, 0), (3, 1), (3, 2), (3, 4)}
    supports = {1: (3, "contact"), 3: (0, "contact"), 4: (3, "contact")}
    behind = photo_scene.behind_what_hides_it
    # the lime's foot read where it is, on the top one (its hidden foot cast on the ground lands behind the pile)
    photo_scene.behind_what_hides_it = lambda lower, m, cam: False if m is masks[4] else behind(lower, m, cam)
    try:
        out = photo_scene.lift_all(masks, ["orange", "lemon", "lemon", "orange", "lime"], camera, BuildSettings(),
                                   0.67, supports, hides=hides, visible=visible)
    finally:
        photo_scene.behind_what_hides_it = behind
    assert 1 not in supports and supports.get(4, (None,))[0] == 3
    for k, (c, r) in enumerate(zip(centres, radii)):
        assert np.linalg.norm(out[k].vertices.mean(axis=0) - c) < (0.5 if k < 4 else 1.0) * r, k


def test_a_grape_read_on_the_back_fruit_of_a_pile_goes_with_it():
    """A grape on the top fruit's crown, misread as on the back fruit the top one hides, no longer keeps the back
    one on the top one: the top one, held by no one fruit under it, stood behind the pile (1.8 radii off)."""
    from physomni_usd.align.photo_scene import lift_all
    from physomni_usd.perceive.amodal import occlusion_order
    from physomni_usd.settings import BuildSettings

    camera, centres, radii, masks, visible = _pile_of_four(rider=(0.0, 0.0, 0.012))
    hides = occlusion_order(visible)
    supports = find_supports(masks, hides)
    assert supports[1][0] == 3 and supports[4][0] == 1  # the grape read on the back one
    out = lift_all(masks, ["orange", "lemon", "lemon", "orange", "grape"], camera, BuildSettings(), 0.67, supports,
                   hides=hides, visible=visible)
    assert 1 not in supports and supports[4][0] == 1
    for k in range(4):
        assert np.linalg.norm(out[k].vertices.mean(axis=0) - centres[k]) < 0.5 * radii[k], k


def _stacked_boxes_seen(pitch_deg: float, stacked: bool = True):
    """Ray-cast masks of a box (index 1) on a larger one (index 0), the upper shifted so the lower shows on one
    side only (or, with ``stacked`` false, the two side by side on the ground), completed behind what hides
    them; with their occlusion order, the feet's supports and a unit-height camera at ``pitch_deg``."""
    import trimesh

    from physomni_usd.bench.general_render import _camera
    from physomni_usd.geometry.camera import PinholeCamera
    from physomni_usd.geometry.raycast import SilhouetteRenderer
    from physomni_usd.perceive.amodal import complete, occlusion_order

    lower = trimesh.creation.box([0.25, 0.19, 0.18])
    lower.apply_translation([0.0, 0.0, 0.09])
    upper = trimesh.creation.box([0.19, 0.19, 0.16])
    upper.apply_transform(trimesh.transformations.rotation_matrix(0.5, [0, 0, 1]))
    upper.apply_translation([0.05, -0.01, 0.26] if stacked else [0.3, 0.0, 0.08])
    cam = _camera(np.random.default_rng(0), [lower, upper], 320, 240, 0.2, pitch_deg, 60.0)
    ids = SilhouetteRenderer([lower.vertices, upper.vertices], [lower.faces, upper.faces]).render(cam)
    visible = [ids == 0, ids == 1]
    order = occlusion_order(visible)
    masks = [c.amodal for c in complete(visible, order)]
    unit = PinholeCamera(cam.width, cam.height, cam.fov_deg, cam.pitch_deg, (0.0, 0.0, 1.0))
    return masks, visible, order, find_supports(masks, order), unit


def test_seen_from_straight_above_what_hides_the_middle_of_another_rests_on_it():
    from physomni_usd.align.support import reaching_under, supports_from_above

    masks, visible, order, found, unit = _stacked_boxes_seen(86.0)
    assert (1, 0) in order
    assert found.get(1, (None,))[0] != 0  # the feet alone do not see the upper box on the lower one
    got = supports_from_above(masks, visible, order, unit, found)
    assert got.get(1) == (0, "above") and 0 not in got
    # the lower box reaches, behind the upper, under the upper's middle: the upper's centre is over it
    reached = reaching_under(masks, visible, got)
    ys, xs = np.nonzero(visible[1])
    assert reached[0][int(ys.mean()), int(xs.mean())] and not masks[0][int(ys.mean()), int(xs.mean())]
    assert not (reached[0] & ~masks[0] & ~visible[1]).any()  # only behind what hides it
    # from the side the same stack keeps the feet's reading, and side by side nothing rests on anything
    masks, visible, order, found, unit = _stacked_boxes_seen(35.0)
    assert supports_from_above(masks, visible, order, unit, found) == found
    masks, visible, order, found, unit = _stacked_boxes_seen(86.0, stacked=False)
    assert supports_from_above(masks, visible, order, unit, found) == found == {}
