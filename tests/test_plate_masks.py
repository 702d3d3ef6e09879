"""The plate (exemplar fill, contact shadows), masks from boxes (thin diagonal objects, quality, contact sheet)
and frame 0 reproducing the photo."""

from __future__ import annotations

import json
import pathlib

import cv2
import numpy as np
import pytest
from pxr import Usd

from physomni_usd.bench.plate import MAX_COLOUR_DIFF, RATIO_RANGE, gradient_ratio, measure
from physomni_usd.metrics import ssim
from physomni_usd.perceive.masks import _grabcut, mask_from_box, mask_quality
from physomni_usd.texture.exemplar import SHADING_DEPTH, SHADING_SIGMA, SHADING_TRUST, match_shading
from physomni_usd.texture.fill import background_plate, feather_px, fill_hole, plate_hole
from physomni_usd.texture.grain import match_grain
from physomni_usd.rendering.video import ShotRenderer

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def test_exemplar_fill_keeps_the_surface_grain():
    """A small saucer-shaped hole in a real photo of gravel: the exemplar fill keeps the stones' gradients,
    Telea smears them."""
    from skimage import data

    photo = np.ascontiguousarray(np.repeat(data.gravel()[96:288, 96:288, None], 3, 2))
    hole = np.zeros(photo.shape[:2], np.uint8)
    cv2.ellipse(hole, (96, 96), (34, 22), 30, 0, 360, 1, -1)
    hole = hole > 0
    exemplar = measure(photo, hole, "exemplar", 0.015)
    telea = measure(photo, hole, "telea", 0.015)
    assert telea["gradient_ratio"] < 0.5
    assert RATIO_RANGE[0] <= exemplar["gradient_ratio"] <= RATIO_RANGE[1]
    assert exemplar["colour_diff"] <= MAX_COLOUR_DIFF
    plate = background_plate(photo, [hole], 0.015)
    outside = ~plate_hole(photo, [hole], 0.015)
    assert np.array_equal(plate[outside], photo[outside])  # the plate is the photo outside the hole


def _border_ratio(img: np.ndarray, hole: np.ndarray) -> float:
    """Mean gradient along the edge of ``hole`` over that of a ring of surface 6-12 px outside it."""
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32)
    g = np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1))
    h8 = hole.astype(np.uint8)
    disk = lambda r: cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    ring = (cv2.dilate(h8, disk(12)) > 0) & ~(cv2.dilate(h8, disk(6)) > 0)
    edge = (cv2.dilate(h8, disk(1)) > 0) & ~(cv2.erode(h8, disk(1)) > 0)
    return float(g[edge].mean() / g[ring].mean())


def test_a_flat_or_a_busy_fill_takes_the_grain_of_the_surface_around_it():
    """A disc filled flat (white paper's fate) or with grain three times the surface's (copied shelf edges):
    after grain matching both lie within 0.6-1.6x of the surface's gradient, keep its mean and leave every
    pixel outside the hole as it was."""
    rng = np.random.default_rng(7)
    y, x = np.mgrid[:120, :160]
    surface = np.clip(140 + rng.normal(0, 1.5, (120, 160)), 0, 255)
    r2 = (x - 80) ** 2 + (y - 60) ** 2
    hole, ring = r2 < 30 ** 2, (r2 < 42 ** 2) & (r2 >= 30 ** 2)
    inner = cv2.erode(hole.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    img = np.repeat(surface[..., None], 3, -1).astype(np.uint8)

    def grad(a):
        a = a[..., 0].astype(np.float32)
        return np.hypot(cv2.Sobel(a, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(a, cv2.CV_32F, 0, 1, ksize=3))

    for fill in (np.full_like(surface, 140.0), surface + rng.normal(0, 4.5, surface.shape)):
        f = np.repeat(np.clip(np.where(hole, fill, surface), 0, 255)[..., None], 3, -1).astype(np.uint8)
        before = grad(f)[inner].mean() / grad(img)[ring].mean()
        out = match_grain(img, f, hole)
        ratio = grad(out)[inner].mean() / grad(img)[ring].mean()
        assert not 0.6 <= before <= 1.6 and 0.6 <= ratio <= 1.6, (before, ratio)
        assert abs(out[inner].mean() - f[inner].mean()) < 1.5
        assert np.array_equal(out[~hole], f[~hole])


def test_the_fill_meets_the_surface_without_an_outline():
    """Where the desk's ball stood (a crop of the bundled photo): faded into the photo over its seam, the
    fill shows no outline along the hole's edge; the exemplar fill cut in hard does, the blend's feathered not."""
    photo = cv2.cvtColor(cv2.imread(str(EXAMPLES / "desk" / "photo.jpg")), cv2.COLOR_BGR2RGB)[60:320, 260:520]
    ball = np.zeros(photo.shape[:2], np.uint8)
    cv2.circle(ball, (135, 126), 60, 1, -1)
    hole = plate_hole(photo, [ball > 0], 0.01)
    soft = fill_hole(photo, hole, "exemplar", feather=feather_px(photo.shape))
    hard = fill_hole(photo, hole, "exemplar")
    assert _border_ratio(hard, hole) > 1.4  # measured 1.68
    assert _border_ratio(soft, hole) < 1.3  # measured 1.13; bench look's target
    assert np.array_equal(soft[~hole], photo[~hole])
    # the default (blend) fill meets it without one too (its hard cut measured 1.15: its copies meet softly)
    assert _border_ratio(fill_hole(photo, hole, feather=feather_px(photo.shape)), hole) < 1.3


def test_contact_shadow_is_removed_from_the_plate():
    """A dark patch on the floor under an object goes with it: no dark ghost where it stood."""
    rng = np.random.default_rng(1)
    h, w = 160, 200
    floor = np.clip(150 + rng.normal(0, 5, (h, w, 1)) * np.ones(3), 0, 255)
    obj = np.zeros((h, w), np.uint8)
    cv2.rectangle(obj, (80, 40), (120, 100), 1, -1)
    photo, dark = _shadowed(floor, obj, (100, 104), (36, 12), 2)
    hole = plate_hole(photo, [obj > 0], 0.01)
    assert hole[dark].mean() > 0.95
    without = plate_hole(photo, [obj > 0], 0.01, shadows=False)
    assert without[dark].mean() < 0.5  # the mask's dilation alone would leave most of the shadow
    plate = background_plate(photo, [obj > 0], 0.01)
    assert abs(plate[dark].mean() - floor[dark].mean()) < 10
    assert gradient_ratio(plate, hole) > 0.3


def test_the_floor_shadow_of_an_object_that_fills_the_photo_is_removed_too():
    """A large object (two wheels under a body, most of the photo's width and height) whose band of shadow
    candidates fills nearly all of the floor around its shadow: the floor's lightness is read from farther
    out, and the shadow goes with the object (it stayed in the plate as a hard patch behind a pushed bike)."""
    rng = np.random.default_rng(2)
    h, w = 240, 360
    floor = np.clip(170 + rng.normal(0, 4, (h, w, 1)) * np.ones(3), 0, 255)
    floor[:110] = 90  # a wall behind, darker than the floor
    obj = np.zeros((h, w), np.uint8)
    cv2.circle(obj, (80, 170), 45, 1, -1)
    cv2.circle(obj, (280, 170), 45, 1, -1)
    cv2.rectangle(obj, (60, 20), (300, 120), 1, -1)
    cv2.rectangle(obj, (150, 120), (210, 175), 1, -1)
    photo, dark = _shadowed(floor, obj, (180, 200), (120, 16), 3)
    assert dark.sum() > 1500
    without = plate_hole(photo, [obj > 0], 0.01, shadows=False)
    assert without[dark].mean() < 0.5
    assert plate_hole(photo, [obj > 0], 0.01)[dark].mean() > 0.95
    plate = background_plate(photo, [obj > 0], 0.01)
    assert abs(plate[dark].mean() - floor[dark].mean()) < 12


def test_the_shading_match_does_not_spread_a_horizon_across_the_hole():
    """A grey-blue backdrop over a brown floor, the horizon straight across a tall hole: the exemplar copies
    the horizon from beside the hole, and away from it (4 rows or more) each row of the fill stays within
    4 levels of the same row beside the hole. A shading match that took the fill's low frequencies from a
    smooth fill of the border's colours smeared the backdrop down into the floor (6.9 levels 10 rows below
    the horizon; now 2.5)."""
    rng = np.random.default_rng(3)
    h, w = 200, 300
    img = np.empty((h, w, 3), np.float32)
    img[:70] = (185, 191, 201)
    img[70:] = (136, 120, 101)
    photo = np.clip(img + rng.normal(0, 2.0, (h, w, 1)), 0, 255).astype(np.uint8)
    hole = np.zeros((h, w), bool)
    hole[25:175, 100:190] = True
    out = fill_hole(photo, hole, "exemplar", 4)
    inside = out[:, 105:185].astype(np.float32).mean(1)
    beside = np.concatenate([photo[:, 60:95], photo[:, 195:230]], 1).astype(np.float32).mean(1)
    rows = np.arange(25, 175)
    rows = rows[np.abs(rows - 70) >= 4]
    glow = np.abs(inside[rows] - beside[rows]).max(1)
    assert glow.max() < 4.0, (glow.max(), rows[glow.argmax()])
    assert np.array_equal(out[~hole], photo[~hole])


def test_a_darker_patch_copied_into_a_tall_hole_takes_the_sky_beside_it():
    """A sky that brightens downwards (noise 2 levels), a tall hole 60 pixels wide whose fill is the sky 30
    levels darker, as shift-map copies darker sky from above a rocket into its column: after the shading
    match each row's middle is within 4 levels of the same row beside the hole. The border step faded
    with its depth into the hole alone (1/e at a tenth of the diagonal) left the middle 12.9 levels dark (now 2.0)."""
    rng = np.random.default_rng(11)
    h, w = 400, 300
    rows = np.linspace(120.0, 200.0, h)[:, None, None] * np.array([0.8, 0.9, 1.0])
    photo = np.clip(rows + rng.normal(0, 2.0, (h, w, 1)), 0, 255).astype(np.uint8)
    hole = np.zeros((h, w), bool)
    hole[40:360, 120:180] = True
    filled = photo.copy()
    filled[hole] = np.clip(photo[hole].astype(np.int16) - 30, 0, 255).astype(np.uint8)
    out = match_shading(photo, filled, hole, max(3.0, SHADING_SIGMA * 60), SHADING_DEPTH * np.hypot(h, w),
                         SHADING_TRUST)
    middle = out[60:340, 140:160].astype(np.float32).mean(1)
    beside = np.concatenate([photo[60:340, 80:110], photo[60:340, 190:220]], 1).astype(np.float32).mean(1)
    off = np.abs(middle - beside).max(1)
    assert off.max() < 4.0, (off.max(), off.mean())
    assert np.array_equal(out[~hole], photo[~hole])


def test_the_hole_takes_a_soft_shade_until_it_fades_into_the_paper():
    """White paper (noise 0.3 levels, in whole levels as a photo stores it) with a red disc whose shade below
    it fades from dark to the paper's 254 in one-level steps: the hole's lower edge lies where those steps
    have ended, its photo gradient within 3x the paper's (measured 2.5x; with the penumbra cut at 0.96 of the
    paper's lightness alone, 3.4x, on the steps)."""
    rng = np.random.default_rng(5)
    h, w = 140, 140
    yy, xx = np.mgrid[:h, :w]
    r = np.hypot(yy - 55, xx - 70)
    disc = r < 22
    lum = 254.0 - 150.0 * np.exp(-np.maximum(r - 22, 0) / 2.5) * (yy > 55)
    grey = np.clip(np.round(lum + rng.normal(0, 0.3, (h, w))), 0, 255)
    photo = np.repeat(grey[..., None], 3, -1).astype(np.uint8)
    photo[disc] = (200, 20, 30)
    hole = plate_hole(photo, [disc], 0.015)
    edge = hole & ~(cv2.erode(hole.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0) & (yy > 60)
    g = cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY).astype(np.float32)
    g = np.hypot(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3))
    paper = (r > 55) & (yy > 60)
    assert edge.sum() > 50
    assert g[edge].mean() / g[paper].mean() < 3.0


def _thin_diagonal(width: int = 4, colour=(70, 60, 50)):
    """A table lit from above the middle of the box, and a thin pencil lying along the box's diagonal."""
    rng = np.random.default_rng(0)
    h, w = 240, 320
    yy, xx = np.mgrid[0:h, 0:w]
    light = 0.55 + 0.6 * np.exp(-((xx - 160) ** 2 + (yy - 120) ** 2) / (2 * 60.0 ** 2))
    grain = 1 + 0.12 * np.sin(xx / 5.0 + 3 * np.sin(yy / 30.0)) + rng.normal(0, 0.05, (h, w))
    img = np.stack([170 * light * grain, 120 * light * grain, 80 * light * grain], 2)
    truth = np.zeros((h, w), np.uint8)
    cv2.line(truth, (70, 50), (250, 190), 1, width)
    img[truth > 0] = np.array(colour) * light[truth > 0][:, None]
    return np.clip(img, 0, 255).astype(np.uint8), truth > 0, (62, 42, 258, 198)


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


def test_thin_diagonal_object_in_a_box():
    photo, truth, box = _thin_diagonal()
    plain = _grabcut(cv2.cvtColor(photo, cv2.COLOR_RGB2BGR), box, None)
    assert _iou(plain, truth) < 0.5  # GrabCut from the box takes the lit table
    q = mask_quality(photo, plain, box)
    assert q["warning"] and "background" in q["warning"]
    obj = mask_from_box(photo, ",".join(map(str, box)) + ":pencil", 0)
    assert _iou(obj.mask, truth) > 0.8
    assert obj.quality["method"] != "grabcut" and obj.quality["warning"] is None
    assert obj.quality["box_fraction"] < 0.1


def test_mask_that_looks_like_background_is_named(tmp_path):
    """A pencil the colour of the table: no segmentation can be sure, and build says which object."""
    from tests.conftest import cli

    photo, _, box = _thin_diagonal(3, (170, 120, 80))
    path = tmp_path / "photo.png"
    cv2.imwrite(str(path), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    proc = cli("build", path, "-o", tmp_path / "shot", "--box", ",".join(map(str, box)) + ":pencil")
    assert proc.returncode == 0, proc.stderr
    assert "warning: mask of pencil_0" in proc.stderr
    report = json.loads((tmp_path / "shot" / "report.json").read_text())
    assert report["objects"][0]["mask_quality"]["warning"]
    sheet = cv2.imread(str(tmp_path / "shot" / report["stages"]["build"]["masks_sheet"]))
    assert sheet is not None and sheet.shape[:2] == photo.shape[:2]


def test_contact_sheet_beside_the_shot(shot):
    report = json.loads((shot["dir"] / "report.json").read_text())
    assert report["stages"]["build"]["masks_sheet"] == "masks.png"
    sheet = cv2.cvtColor(cv2.imread(str(shot["dir"] / "masks.png")), cv2.COLOR_BGR2RGB)
    photo = cv2.cvtColor(cv2.imread(str(shot["photo"])), cv2.COLOR_BGR2RGB)
    cup = cv2.imread(str(shot["cup"]), cv2.IMREAD_GRAYSCALE) > 0
    assert sheet.shape == photo.shape
    # the masks are tinted, the rest dimmed
    assert np.abs(sheet[cup].astype(int) - photo[cup]).mean() > 10
    for obj in report["objects"]:
        assert {"box_fraction", "edge_agreement", "background_like"} <= set(obj["mask_quality"])


def test_frame_zero_is_the_photo(shot):
    """Rendered (not encoded) frame 0 against the photo: nothing has moved, so nothing may differ."""
    stage = Usd.Stage.Open(str(shot["shot"]))
    renderer = ShotRenderer(stage)
    frame0 = renderer.frame(float(stage.GetStartTimeCode()))
    photo = cv2.cvtColor(cv2.imread(str(shot["photo"])), cv2.COLOR_BGR2RGB)
    assert frame0.shape == photo.shape
    assert cv2.PSNR(frame0, photo) >= 35.0
    assert ssim(frame0, photo) >= 0.98
    # no synthetic shadow over the photo's own, no halo at the masks' edges: not even a few pixels differ
    assert np.percentile(np.abs(frame0.astype(int) - photo).max(2), 99.9) <= 2
    # the pushed box has moved: where it stood and no object is now seen, the frame shows the plate
    last = renderer.frame(float(stage.GetEndTimeCode()))
    box = cv2.imread(str(shot["box"]), cv2.IMREAD_GRAYSCALE) > 0
    left = box & (renderer.caster.depth >= 1e5)
    plate = cv2.cvtColor(cv2.imread(str(shot["dir"] / "textures" / "plate.png")), cv2.COLOR_BGR2RGB)
    assert left.sum() > 50
    assert np.median(np.abs(last.astype(int) - plate).max(2)[left]) <= 2


@pytest.mark.parametrize("method", ["exemplar", "telea"])
def test_fill_methods_fill_only_the_hole(method):
    rng = np.random.default_rng(2)
    photo = rng.integers(0, 255, (64, 80, 3), dtype=np.uint8)
    hole = np.zeros((64, 80), bool)
    hole[20:40, 30:50] = True
    from physomni_usd.texture.fill import fill_hole

    out = fill_hole(photo, hole, method)
    assert np.array_equal(out[~hole], photo[~hole])
    assert not np.array_equal(out[hole], photo[hole])
    with pytest.raises(ValueError):
        fill_hole(photo, hole, "nonsense")


def _shadowed(floor, obj, centre, axes, blur):
    """``floor`` (H, W, 3 float) with a red object ``obj`` (H, W, 0/1) and its soft elliptic floor shadow
    (``centre``, ``axes`` px, blurred by ``blur`` px) half as bright: the photo (uint8) and where the shadow is dark."""
    shadow = np.zeros(obj.shape, np.float32)
    cv2.ellipse(shadow, centre, axes, 0, 0, 360, 1.0, -1)
    shadow = cv2.GaussianBlur(shadow, (0, 0), blur) * (1 - obj)
    photo = floor * (1 - 0.5 * shadow[..., None])
    photo[obj > 0] = (200, 40, 40)
    return photo.astype(np.uint8), shadow > 0.5


#: How far a dark rim's pixels may lie off the floor in the plate, by how far (px) inside the object its mask
#: lies. The fill stays only out to the seam beyond the kept edge (3 + 8 px here) and gives way over a ramp
#: centred on the seam's outer edge (texture.fill.RIM_RAMP): a rim the mask missed by 8 px stays filled (measured
#: max 12 and 14 levels off the floor, rims of 1 and 2 px), one 10 px in is half given back (38 and 69; 9 and
#: 18 when the whole widening could stay filled), one 12 px in is the photo's (96 and 100; 28 and 35). Accepted:
#: beyond the seam a dark band along the outline (a rim) and one crossing it (a shelf's post beside the pushed
#: motorcycle) are both the world, told apart by distance alone; a mask 12 px inside its object leaves a ghost
#: outline once the object moves.
RIM_LIMITS = {8: 30, 10: 75}


@pytest.mark.parametrize("rim", [1, 2])
@pytest.mark.parametrize("inset", [8, 10, pytest.param(12, marks=pytest.mark.xfail(
    strict=True, reason="a rim 12 px beyond the mask lies past the seam: given back as the photo (96 and 100 "
                        "levels off the floor; 28 and 35 with the whole widening filled), see RIM_LIMITS"))])
def test_a_dark_rim_the_mask_missed_stays_filled(rim, inset):
    """A segmenter's mask often lies a few pixels inside the object: here a grey disc on a grey floor, its
    mask ``inset`` px inside its edge, its edge a dark rim ``rim`` px wide. Beyond the widened mask the plate
    takes the photo back where it looks like the floor, but not the rim within the seam: shown from the photo it
    would stay behind as a ghost outline once the object moved (71 and 60 levels off the floor at 8 px when the
    floor around the rim voted it back into the plate). Limits by inset: :data:`RIM_LIMITS`."""
    rng = np.random.default_rng(4)
    h, w = 480, 640
    floor = np.clip(150 + rng.normal(0, 3, (h, w, 1)) * np.ones(3), 0, 255)
    body, outer, mask = (np.zeros((h, w), np.uint8) for _ in range(3))
    cv2.circle(mask, (320, 200), 80, 1, -1)
    cv2.circle(body, (320, 200), 80 + inset, 1, -1)
    cv2.circle(outer, (320, 200), 80 + inset + rim, 1, -1)
    dark = (outer > 0) & ~(body > 0)
    photo = floor.copy()
    photo[body > 0] = 156
    photo[dark] = 60
    photo = photo.astype(np.uint8)
    assert plate_hole(photo, [mask > 0], 0.015, shadows=False)[dark].all()  # the rim lies in the plate's hole
    plate = background_plate(photo, [mask > 0], 0.015, shadows=False)
    assert np.abs(plate[dark].astype(float) - floor[dark]).max() < RIM_LIMITS.get(inset, 30)


def test_the_world_beyond_the_seam_is_the_photo_however_far_off_the_fill():
    """A thin dark post stands 16 px beside a disc's mask, in the hole's widening (12 px and a seam of 8 at this
    size) but beyond the kept edge and its seam: the fill misses the post, yet it is the world, not a rim the
    mask missed, and the plate shows it as the photo does (kept filled, the pushed motorcycle's shelf posts and
    box edges changed once the bike moved although nothing there did)."""
    rng = np.random.default_rng(4)
    h, w = 480, 640
    photo = np.clip(150 + rng.normal(0, 3, (h, w, 1)) * np.ones(3), 0, 255)
    mask = np.zeros((h, w), np.uint8)
    cv2.circle(mask, (320, 200), 80, 1, -1)
    post = np.zeros((h, w), bool)
    post[185:216, 415:417] = True
    photo[post] = 60
    photo = photo.astype(np.uint8)
    assert plate_hole(photo, [mask > 0], 0.015, shadows=False)[post].all()  # the post lies in the plate's hole
    plate = background_plate(photo, [mask > 0], 0.015, shadows=False)
    assert np.abs(plate[post].astype(int) - photo[post]).max() <= 1


def test_the_fill_gives_way_to_the_world_over_a_ramp_at_the_seam():
    """A dark bar runs out from a disc's mask across the hole's widening: within the seam beyond the kept edge
    the plate fills it (it could be a rim the mask missed), beyond the seam it is the photo; the plate passes
    from one to the other over a few pixels, not in one step (a hard seam round the pushed motorcycle: bench
    look's border 1.37 of its surroundings, 1.25 with the ramp). Measured: 95 levels in one pixel stopped
    within one pixel, at most 44 with the ramp."""
    rng = np.random.default_rng(4)
    h, w = 480, 640
    photo = np.clip(150 + rng.normal(0, 3, (h, w, 1)) * np.ones(3), 0, 255)
    mask = np.zeros((h, w), np.uint8)
    cv2.circle(mask, (320, 200), 80, 1, -1)
    photo[198:203, 395:440] = 60
    photo = photo.astype(np.uint8)
    plate = background_plate(photo, [mask > 0], 0.015, shadows=False).astype(int)
    row = plate[200, 400:440].mean(-1)
    assert row[0] > 120 and row[-1] < 70  # filled at the mask, the photo beyond the seam
    assert np.abs(np.diff(row)).max() < 60, row.round()
