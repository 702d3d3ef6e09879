"""A photo above the working resolution is perceived and placed on a reduced copy (perceive/working.py): its
objects come out as the small photo's do, its plate, textures and inputs keep the photo's own pixels, and a
mask file keeps its own edge where the texture shows it."""

import json
import pathlib

import cv2
import numpy as np
import pytest

from physomni_usd.building import build_shot
from physomni_usd.texture.carry import FILL_PIXELS, carry_plate
from physomni_usd.perceive.working import Working, working
from physomni_usd.settings import BuildSettings

EXAMPLE = pathlib.Path(__file__).resolve().parent.parent / "examples" / "cloth"


def test_a_photo_at_or_under_the_working_size_is_used_as_it_is():
    assert working((320, 480, 3), 480 * 320) is None
    w = working((640, 960, 3), 480 * 320)
    assert w.work == (320, 480) and w.fx == 2.0 and w.fy == 2.0


def test_boxes_and_clicks_are_taken_to_working_pixels():
    w = Working((1000, 2000), (250, 500))
    assert w.box_spec("100,40,1001,999:cup:+400,200:-1999,999") == "25,10,251,250:cup:+100,50:-499,249"


def test_the_carried_plate_keeps_the_photo_outside_and_the_copied_detail_inside():
    rng = np.random.default_rng(1)
    photo = rng.integers(0, 256, (400, 400, 3), dtype=np.uint8)  # all detail, finer than a working pixel
    work = Working((400, 400), (100, 100))
    small = work.down(photo)
    plate = small.copy()
    sources = np.full((100, 100, 2), -1, np.int32)
    ys, xs = np.mgrid[30:70, 40:70]
    plate[ys, xs] = small[ys, xs - 30]  # a fill copied from 30 working pixels to the left
    sources[ys, xs, 0], sources[ys, xs, 1] = ys, xs - 30
    out = carry_plate(photo, work, small, plate, sources)
    changed = np.zeros((100, 100), bool)
    changed[30:70, 40:70] = True
    outside = ~work.up_mask(cv2.dilate(changed.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool))
    assert np.array_equal(out[outside], photo[outside])
    # deep inside, the photo's own pixels from 120 photo pixels to the left, not an upsampled blur of them
    inner = (slice(140, 260), slice(180, 260))
    left = (slice(140, 260), slice(60, 140))
    err = np.abs(out[inner].astype(int) - photo[left].astype(int))
    assert np.median(err) <= 1
    blur = work.up(plate)[inner]
    assert np.median(np.abs(blur.astype(int) - photo[left].astype(int))) > 20  # what detail transfer adds



def test_the_carry_keeps_filled_the_rim_the_small_plate_kept_filled():
    """The built-in plate takes the photo back around an object's edge where it looks like the floor, but keeps
    filled a dark rim the mask missed (``texture.fill._world_back``), so the photo's pixels it left lie beside
    ones it filled. Carried up by the plate's own share of the fill, the rim stays filled at the photo's size
    (measured max 13 levels off the floor); read from the distance to the pixels left as they were, the carry
    took the rim for the seam and brought the photo's edge back (48)."""
    from physomni_usd.texture.fill import background_plate

    rng = np.random.default_rng(5)
    h, w = 600, 800
    floor = np.clip(150 + rng.normal(0, 3, (h, w, 1)) * np.ones(3), 0, 255)
    mask, body, outer = (np.zeros((h, w), np.uint8) for _ in range(3))
    cv2.circle(mask, (400, 260), 100, 1, -1)
    cv2.circle(body, (400, 260), 109, 1, -1)  # the mask lies 9 px inside the object
    cv2.circle(outer, (400, 260), 112, 1, -1)
    dark = (outer > 0) & ~(body > 0)
    photo = floor.copy()
    photo[body > 0] = 156
    photo[dark] = 60
    photo = photo.astype(np.uint8)
    work = Working((h, w), (300, 400))
    small = work.down(photo)
    small_mask = cv2.resize(mask * 255, (400, 300), interpolation=cv2.INTER_AREA) > 0
    sources = np.full((300, 400, 2), -1, np.int32)
    weight = np.full((300, 400), -1.0, np.float32)
    plate = background_plate(small, [small_mask], 0.015, shadows=False, sources=sources, weight=weight)
    assert (weight >= 0).all() and (weight[small_mask] == 1).all()
    out = carry_plate(photo, work, small, plate, sources if (sources[..., 0] >= 0).any() else None, weight)
    assert np.abs(out[dark].astype(float) - floor[dark]).max() < 30
    far = ~work.up_mask(cv2.dilate((weight > 0).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool))
    assert np.array_equal(out[far], photo[far])

def test_a_plugin_inpainter_fills_the_photo_itself_above_the_fill_size():
    """The reduced fill copy is the built-in's (whose exemplar search it pays for); a plugin's fill carried up
    from it would be an upsampled blur, since a plugin says nothing of where it copied from."""
    from types import SimpleNamespace

    from physomni_usd.building import _plate

    seen = []

    class Grey:
        kind, name = "inpainter", "grey"

        def inpaint(self, photo, hole):
            seen.append(photo.shape)
            return np.full_like(photo, 128)

    photo = np.random.default_rng(0).integers(0, 255, (640, 960, 3)).astype(np.uint8)
    assert working(photo.shape, FILL_PIXELS) is not None and working(photo.shape) is None
    mask = np.zeros(photo.shape[:2], bool)
    mask[200:400, 300:500] = True
    scene = SimpleNamespace(photo=photo, full_photo=photo, work=None, masks=[mask], small_plate=None, objects=[],
                            settings=BuildSettings(plate_dilation=0.0), backends={"inpainter": Grey()})
    _plate(scene)
    assert seen == [photo.shape] and scene.small_plate is None
    assert (scene.plate[mask] == 128).all() and np.array_equal(scene.plate[~mask], photo[~mask])


def test_a_part_narrower_than_a_fill_pixel_is_filled():
    """A wire one photo pixel wide is under half a pixel of the reduced fill copy: it is still in the hole."""
    from types import SimpleNamespace

    from physomni_usd.backends.builtin import BuiltinInpainter
    from physomni_usd.building import _plate

    rng = np.random.default_rng(0)
    photo = (120 + rng.integers(-6, 7, (640, 960, 3))).astype(np.uint8)
    mask = np.zeros(photo.shape[:2], bool)
    mask[322, 200:760] = True  # a row split between two rows of the fill copy: under half of either
    photo[mask] = (40, 40, 230)
    assert not working(photo.shape, FILL_PIXELS).down_mask(mask).any()  # what a majority rule would keep
    scene = SimpleNamespace(photo=photo, full_photo=photo, work=None, masks=[mask], small_plate=None, objects=[],
                            settings=BuildSettings(plate_dilation=0.0), backends={"inpainter": BuiltinInpainter()})
    _plate(scene)
    assert scene.plate.shape == photo.shape
    # the wire's colour is 110 levels off the grey (left as it was, before); the carry brings back a share of
    # the photo's own detail where the fill equals the photo around it, the flat grey's case
    assert np.median(np.abs(scene.plate[mask].astype(int) - 120).max(axis=1)) <= 40


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """The cloth example as it is, and at twice its size with a notch one photo pixel wide cut into the crate's
    mask (half a working pixel: the working copy cannot hold it), worked on at the example's own size."""
    spec = json.loads((EXAMPLE / "example.json").read_text())
    tmp = tmp_path_factory.mktemp("working")
    masks = [str(EXAMPLE / m) for m in spec["masks"]]
    small = build_shot(EXAMPLE / spec["photo"], tmp / "small", masks=masks, pushes=spec["push"])
    photo = cv2.imread(str(EXAMPLE / spec["photo"]))
    h, w = photo.shape[:2]
    cv2.imwrite(str(tmp / "photo.png"), cv2.resize(photo, (2 * w, 2 * h), interpolation=cv2.INTER_CUBIC))
    big_masks, given = [], {}
    for m in spec["masks"]:
        path, _, label = m.partition(":")
        mask = cv2.resize(cv2.imread(str(EXAMPLE / path), cv2.IMREAD_GRAYSCALE), (2 * w, 2 * h),
                          interpolation=cv2.INTER_NEAREST) > 0
        if label == "crate":
            ys, xs = np.nonzero(mask)
            cx = int(np.median(xs))
            mask[ys.min():ys.min() + (ys.max() - ys.min()) // 2, cx] = False  # a slit 1 pixel wide
        given[label] = mask
        cv2.imwrite(str(tmp / f"{label}.png"), mask.astype(np.uint8) * 255)
        big_masks.append(f"{tmp / label}.png:{label}")
    big = build_shot(tmp / "photo.png", tmp / "big", masks=big_masks, pushes=spec["push"],
                     settings=BuildSettings(working_pixels=w * h))
    return small, big, given, (w, h)


def test_a_large_photos_objects_are_the_small_ones(builds):
    small, big, _, _ = builds
    for a, b in zip(small.objects, big.objects):
        assert a["name"] == b["name"] and a["shape"] == b["shape"]
        size = np.array(a["size_m"])
        assert np.allclose(b["size_m"], size, rtol=0.05, atol=0.01), (a["name"], a["size_m"], b["size_m"])
        assert np.linalg.norm(np.subtract(b["position_m"], a["position_m"])) <= 0.05 * max(size.max(), 0.1)


def test_the_large_photos_shot_keeps_its_pixels(builds):
    _, big, _, (w, h) = builds
    report = json.loads((big.folder / "report.json").read_text())
    assert (report["shot"]["width"], report["shot"]["height"]) == (2 * w, 2 * h)
    assert report["shot"]["working_size"] == [w, h]
    for name in ("textures/plate.png", "inputs/photo.png"):
        assert cv2.imread(str(big.folder / name)).shape[:2] == (2 * h, 2 * w), name
    # the wide plate is the plate filled on the working copy (under texture.carry.FILL_PIXELS: never a finer
    # fill than the working size) and its margins
    assert w * h < FILL_PIXELS
    assert cv2.imread(str(big.folder / "textures" / "plate_wide.png")).shape[:2] == (2 * h, 2 * w)


def test_a_photo_under_the_fill_size_but_above_the_working_size_keeps_its_pixels(tmp_path):
    spec = json.loads((EXAMPLE / "example.json").read_text())
    photo = cv2.imread(str(EXAMPLE / spec["photo"]))
    assert 65_536 < photo.shape[0] * photo.shape[1] <= FILL_PIXELS
    shot = build_shot(EXAMPLE / spec["photo"], tmp_path / "shot", masks=[str(EXAMPLE / m) for m in spec["masks"]],
                      pushes=spec["push"], settings=BuildSettings(working_pixels=65_536))
    plate = cv2.imread(str(shot.folder / "textures" / "plate.png"))
    assert plate.shape == photo.shape  # filled on the working copy and carried up, not the working copy's size


def test_a_full_size_mask_keeps_its_own_edge(builds):
    _, big, given, _ = builds
    crate = next(o for o in big.objects if o["label"] == "crate")
    kept = cv2.imread(str(big.folder / "inputs" / "masks" / f"{crate['name']}.png"), cv2.IMREAD_GRAYSCALE) > 0
    assert np.array_equal(kept, given["crate"])
    # the texture's cut-out is the given mask, slit included, where the photo shows the crate
    texture = cv2.imread(str(big.folder / "textures" / f"{crate['name']}.png"), cv2.IMREAD_UNCHANGED)
    from pxr import Usd

    stage = Usd.Stage.Open(str(big.folder / "scene.usda"))
    x0, y0 = next(p.GetCustomDataByKey("physomni:textureOrigin") for p in stage.Traverse()
                  if p.GetName() == crate["name"] and p.GetCustomDataByKey("physomni:textureOrigin") is not None)
    th, tw = texture.shape[0], texture.shape[1] // 2
    alpha = texture[:, :tw, 3] == 255
    assert np.array_equal(alpha, given["crate"][y0:y0 + th, x0:x0 + tw])


def test_run_takes_the_render_size(tmp_path):
    from physomni_usd.cli.cmd_run import run_arguments

    photo = EXAMPLE.parent / "motorcycle" / "photo.png"
    args = [str(photo), "-o", str(tmp_path / "shot"), "--mask", str(photo.parent / "bin.png")]
    assert run_arguments(args)["render_settings"].max_size == 1280
    assert run_arguments(args + ["--max-size", "640"])["render_settings"].max_size == 640


def test_a_photo_above_the_fill_size_is_filled_small_and_keeps_its_pixels_outside_the_hole(tmp_path):
    """A 0.6 MP photo (the tests' tiny synthetic scene, upscaled) is worked on as it is but filled on a 0.4 MP
    copy (texture.carry.FILL_PIXELS): its plate has the photo's size and is the photo, pixel for pixel, wherever
    the fill copy's hole does not reach."""
    from physomni_usd.texture.fill import plate_hole

    from .conftest import synthetic_photo

    tiny = synthetic_photo(tmp_path / "tiny")
    size = (900, 675)
    photo = cv2.resize(cv2.imread(str(tiny["photo"])), size, interpolation=cv2.INTER_CUBIC)
    assert working(photo.shape) is None and working(photo.shape, FILL_PIXELS) is not None
    cv2.imwrite(str(tmp_path / "photo.png"), photo)
    masks = []
    for label in ("cup", "box"):
        mask = cv2.resize(cv2.imread(str(tiny[label]), cv2.IMREAD_GRAYSCALE), size, interpolation=cv2.INTER_NEAREST)
        cv2.imwrite(str(tmp_path / f"{label}.png"), mask)
        masks.append(mask > 0)
    shot = build_shot(tmp_path / "photo.png", tmp_path / "shot",
                      masks=[f"{tmp_path / label}.png:{label}" for label in ("cup", "box")])
    plate = cv2.imread(str(shot.folder / "textures" / "plate.png"))
    assert plate.shape == photo.shape
    fill = working(photo.shape, FILL_PIXELS)
    hole = plate_hole(fill.down(cv2.cvtColor(photo, cv2.COLOR_BGR2RGB)),
                      [fill.down(m.astype(np.uint8) * 255) > 0 for m in masks], BuildSettings().plate_dilation)
    outside = fill.up(hole.astype(np.uint8) * 255, cv2.INTER_LINEAR) == 0
    assert 0.5 < outside.mean() < 0.95
    assert np.array_equal(plate[outside], photo[outside])
    gone = np.any(plate != photo, axis=2)
    assert all(gone[m].mean() > 0.9 for m in masks)  # the objects are filled over
