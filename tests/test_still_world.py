"""Where nothing moved the frame stays the photo: once an object moves, no pixel away from where it stood and
where it is now (and their shadows) differs from frame 0 by more than ``bench.look.STILL_LEVELS``, however the
plate behind it was filled. The photo's surface is busy (blocks of light and dark), so that a fill reaching
past the object's edge shows at once."""

from __future__ import annotations


import cv2
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

import physomni_usd as api
from physomni_usd.bench.look import STILL_LEVELS, still_changes
from physomni_usd.rendering.video import ShotRenderer
from physomni_usd.settings import BuildSettings

H, W = 200, 300


@pytest.fixture(scope="module")
def busy_shot(tmp_path_factory):
    folder = tmp_path_factory.mktemp("busy")
    rng = np.random.default_rng(3)
    blocks = rng.integers(0, 2, (H // 6 + 1, W // 6 + 1)).astype(np.float32)
    pattern = cv2.resize(blocks, None, fx=6, fy=6, interpolation=cv2.INTER_NEAREST)[:H, :W]
    img = np.empty((H, W, 3), np.float32)
    img[:] = (60 + 150 * pattern)[..., None] * np.array([1.0, 0.9, 0.8])
    horizon = 90
    img[horizon:] = np.linspace(140, 100, H - horizon)[:, None, None] * np.array([1.0, 0.9, 0.75])
    img += rng.normal(0, 3, (H, W, 1))
    box = np.zeros((H, W), np.uint8)
    cv2.rectangle(box, (120, 60), (180, 150), 1, -1)
    img[box > 0] = np.array([60, 120, 200])
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(np.clip(img, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    cv2.imwrite(str(folder / "box.png"), box * 255)
    out = folder / "shot"
    api.build(folder / "photo.png", out, [f"{folder / 'box.png'}:box"], [], BuildSettings())
    return out


def test_nothing_but_the_moved_object_changes_the_frame(busy_shot):
    stage = Usd.Stage.Open(str(busy_shot / "shot.usda"))
    renderer = ShotRenderer(stage)
    _push(stage, renderer, 0, 1.0)  # sideways by its own width: it leaves its place entirely
    count, where, moved = still_changes(renderer, 1.0)
    assert moved == [renderer.objects[0].path]
    assert count == 0, np.argwhere(where)[:10]
    # the box did move in the frame: where it stood and where it is now changed
    first = renderer.render(0.0)[0]
    assert (np.abs(renderer.render(1.0)[0].astype(int) - first).max(-1) > STILL_LEVELS).sum() > 500


#: The motorcycle's last frame, measured (the bike pushed over and drawn as a pillow on the floor, the bench
#: knocked back): 126 pixels off by more than STILL_LEVELS where nothing moved, against 3,206 when the plate
#: showed its fill across the masks' whole widening, 809 when it kept the fill wherever the photo was unlike it
#: there (shelf posts, a box's edge), and 377 when the box's shadow beside the bike's fork was the bike's to
#: reveal (the nearer mask's) rather than shared with the box that casts it and stands (texture.fill.hole_owners).
#: Most of what is left is the 3 px ramp by which the fill gives way to the photo past the seam's outer edge
#: (the red crate's left side, 62 px; stopped within one pixel, a hard seam round the area the bike left, bench
#: look's border 1.37) and single rows at the bench's edges. Three runs gave the same count (the last with the
#: owner's own shadow no longer shared); the limit leaves a fifth more for a fall that settles a little
#: differently elsewhere.
MOTORCYCLE_STILL_PX = 150


@pytest.mark.slow
def test_the_pushed_motorcycle_leaves_the_world_as_the_photo_shows_it(motorcycle_run):
    """examples/motorcycle/run.sh as a user runs it (the session's run, tests/conftest.py)."""
    from physomni_usd.metrics.motion import video_motion
    proc, out = motorcycle_run
    assert proc.returncode == 0, proc.stderr[-2000:]
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    count, where, moved = still_changes(ShotRenderer(stage), float(stage.GetEndTimeCode()))
    assert "/World/Objects/motorcycle_0" in moved
    assert count <= MOTORCYCLE_STILL_PX, np.argwhere(where)[:10]
    motion = video_motion(out / "video.mp4")
    assert motion["with_motion"] >= motion["frames"] / 2, {k: motion[k] for k in ("frames", "with_motion")}


def _pair_picture(shades, left=(60, 130), right=(180, 240), rng=None):
    """Two boxes (columns ``left`` and ``right``, rows 50 to 200, inclusive) on a plain floor under a wall, each
    ellipse of ``shades`` ((centre, axes) in pixels) a soft dark shade on the floor, with the camera's grain
    from ``rng`` where given: the photo (240, 360, 3) uint8 and the boxes' masks (240, 360) bool each."""
    h, w = 240, 360
    img = np.empty((h, w, 3), np.float32)
    img[:] = np.array([150.0, 140.0, 125.0])
    img[:100] = np.array([110.0, 120.0, 135.0])  # a wall behind
    shade = np.zeros((h, w), np.float32)
    for centre, axes in shades:
        cv2.ellipse(shade, centre, axes, 0, 0, 360, 1.0, -1)
    img *= 1.0 - 0.6 * cv2.GaussianBlur(shade, (0, 0), 1.5)[..., None]
    if rng is not None:
        img += rng.normal(0, 2, (h, w, 1))
    masks = []
    for (x0, x1), colour in ((left, (60, 120, 200)), (right, (200, 90, 60))):
        m = np.zeros((h, w), bool)
        m[50:201, x0:x1 + 1] = True
        img[m] = np.array(colour)
        masks.append(m)
    return np.clip(img, 0, 255).astype(np.uint8), masks


def _build_pair(folder, photo, masks):
    """The shot built from ``photo`` and the two boxes' ``masks`` (:func:`_pair_picture`) in ``folder``."""
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    for name, m in zip(("left", "right"), masks):
        cv2.imwrite(str(folder / f"{name}.png"), m.astype(np.uint8) * 255)
    out = folder / "shot"
    api.build(folder / "photo.png", out, [f"{folder / 'left.png'}:box", f"{folder / 'right.png'}:crate"], [],
              BuildSettings())
    return out


def _push(stage, renderer, k: int, widths: float) -> None:
    """Object ``k`` of ``renderer`` pushed sideways by ``widths`` of its own width between times 0 and 1 (in
    the session layer of ``stage``)."""
    prim = stage.GetPrimAtPath(renderer.objects[k].path)
    translate = next(op for op in UsdGeom.Xformable(prim).GetOrderedXformOps()
                     if op.GetOpType() == UsdGeom.XformOp.TypeTranslate)
    start = Gf.Vec3d(translate.Get(Usd.TimeCode(0)))
    extent = UsdGeom.Mesh(prim).GetExtentAttr().Get()
    stage.SetEditTarget(stage.GetSessionLayer())
    translate.Set(start, Usd.TimeCode(0))
    translate.Set(start + Gf.Vec3d(widths * float(extent[1][0] - extent[0][0]), 0.0, 0.0), Usd.TimeCode(1))


#: The right box's shade, cast out to its left across the floor between the boxes, so far that its outer part
#: lies nearer the left box than the right one.
CAST_LEFT = [((182, 197), (38, 6))]
#: Each box's own shade on the floor just under it, right of its middle.
EACH_ITS_OWN = [((110, 203), (40, 6)), ((210, 203), (40, 6))]


@pytest.fixture(scope="module")
def shaded_pair(tmp_path_factory):
    """Two boxes on a plain floor, the right one casting a dark shadow out to its left (:data:`CAST_LEFT`)."""
    return _build_pair(tmp_path_factory.mktemp("pair"), *_pair_picture(CAST_LEFT, rng=np.random.default_rng(5)))


@pytest.fixture(scope="module")
def own_shadows(tmp_path_factory):
    """Two boxes on a plain floor, each with its own shadow (:data:`EACH_ITS_OWN`)."""
    return _build_pair(tmp_path_factory.mktemp("own"), *_pair_picture(EACH_ITS_OWN, left=(70, 130), right=(170, 230),
                                                                      rng=np.random.default_rng(5)))


def test_a_shadow_stays_while_the_object_that_casts_it_stands(shaded_pair):
    """The right box's shadow reaches nearer the left box than the right one: the plate removed it with the
    right box, and once the left box moves away it must stay the photo's (the pushed motorcycle left the
    box's shadow beside its fork as the plate's lit floor)."""
    stage = Usd.Stage.Open(str(shaded_pair / "shot.usda"))
    renderer = ShotRenderer(stage)
    assert [o.path.rsplit("/", 1)[-1] for o in renderer.objects][:1] == ["box_0"]
    # the case is real: the plate removed the shadow, and its outer part is nearer the left box
    differs = np.abs(renderer.plate - renderer.photo).max(-1) > STILL_LEVELS
    assert differs[185:205, 150:160].sum() > 20
    assert (renderer.owner[190:200, 150:155] == 0).all()
    _push(stage, renderer, 0, -1.0)
    count, where, moved = still_changes(renderer, 1.0)
    assert moved == [renderer.objects[0].path]
    assert count == 0, np.argwhere(where)[:10]


def test_a_pushed_object_takes_its_own_shadow_with_it(own_shadows):
    """Each box has its own shadow, the right one's close enough that its seam reaches into the left one's:
    pushed away, the left box leaves the plate's lit floor where its shadow lay, and no part of that shadow
    stays behind for the right box, which stands (it did, dark with a hard inner edge, when the right box
    shared every pixel near its shadow)."""
    stage = Usd.Stage.Open(str(own_shadows / "shot.usda"))
    renderer = ShotRenderer(stage)
    _push(stage, renderer, 0, -1.5)
    first = renderer.render(0.0)[0].astype(int)
    last = renderer.render(1.0)[0].astype(int)
    plate = renderer.plate.astype(int)
    shade = np.zeros(first.shape[:2], bool)
    shade[196:212, 100:152] = True  # the left box's shadow, right of its middle
    lit = (np.abs(plate - first).max(-1) > 30) & shade  # where the plate filled it with lit floor
    assert lit.sum() > 100
    stayed = lit & (np.abs(last - first).max(-1) < np.abs(last - plate).max(-1))  # nearer the photo still
    assert stayed.sum() == 0, np.argwhere(stayed)[:10]
    count, where, _ = still_changes(renderer, 1.0)
    assert count == 0, np.argwhere(where)[:10]


def test_a_shadow_is_shared_with_its_caster_but_no_mask_is():
    """texture.fill.hole_owners on the pair's layout, without a build: the right box's shadow where it lies
    nearer the left box is the left box's and shared in full with the right one; the left box's own pixels and
    its kept edge are its alone; far beyond the shadow nothing is shared."""
    from physomni_usd.texture.fill import hole_owners, kept_edge_px

    photo, (left, right) = _pair_picture(CAST_LEFT)
    owner, sharer, share = hole_owners(photo, [left, right], BuildSettings().plate_dilation)
    assert (owner[195:200, 146:152] == 0).all()  # nearer the left box
    assert (sharer[195:200, 146:152] == 1).all() and (share[195:200, 146:152] == 1.0).all()
    edge = kept_edge_px(photo.shape)
    assert (sharer[left] == -1).all() and (sharer[195:200, 131:131 + edge] == -1).all()
    assert (sharer[:100] == -1).all() and (sharer[:, 300:] == -1).all()


def test_an_objects_own_shadow_is_not_shared():
    """hole_owners on two boxes each with its own shadow: the left box's shadow, where the left box is nearer,
    is its alone, however near the seam round the right box's shadow reaches (the nearer shadow decides)."""
    from physomni_usd.texture.fill import hole_owners

    photo, (left, right) = _pair_picture(EACH_ITS_OWN, left=(70, 130), right=(170, 230))
    owner, sharer, share = hole_owners(photo, [left, right], BuildSettings().plate_dilation)
    shade = np.zeros(left.shape, bool)
    shade[198:209, 100:150] = True
    assert (owner[shade] == 0).all() and (share[shade] == 0).all()
    # the tip of its shadow nearer the right box is shared: the right box owns it, and the left casts it
    assert (sharer[198:209, 151:155] == 0).all() and (share[198:209, 151:155] == 1.0).all()
