"""Frame 0 is the photo on photos the project was not tuned for, whatever their lift: every real bench photo
(``bench real-photos``' gallery), the synthetic ``bench photos`` scenes, a fresh ``bench general`` scene
rendered by Blender (built from its masks, and again with a lift wrong on purpose), and the coffee cup built
with a lift that is wrong on purpose (a near-level camera for a photo taken from 52° above, and slabs for round
things). ``bench general`` reports the same figure for every scene it builds (tests/test_bench_general.py).

Each shot is built as a user would build it (its masks or boxes; a gallery photo's build is the session's,
``built_case``, which tests/test_gallery_rest.py checks at rest) and its frame 0 rendered before encoding
(``ShotRenderer``): PSNR against the photo at least 40 dB. (The bundled examples are checked in
tests/test_examples_frame0.py, the top-down desk with slabs in tests/test_frame0_photo.py.)"""

from __future__ import annotations

import os
import pathlib

import cv2
import numpy as np
import pytest
from pxr import Usd

import physomni_usd as api
from physomni_usd.bench.real_photos import load_photo, load_truth, write_inputs
from physomni_usd.rendering.video import ShotRenderer
from physomni_usd.settings import BuildSettings, CameraSettings, LiftSettings

PHOTOS = load_truth()
#: Quick enough for the quick set (their builds took 4-17 s on a shared 2-core machine); the rest are slow.
QUICK = {"smarties", "football", "rubberwhale"}
MIN_PSNR_DB = 40.0


def _frame0(shot) -> tuple[np.ndarray, ShotRenderer, object]:
    stage = Usd.Stage.Open(str(shot))
    renderer = ShotRenderer(stage)
    image, state = renderer.render(float(stage.GetStartTimeCode()))
    return image, renderer, state


def _inputs(name: str, folder: pathlib.Path):
    record = PHOTOS[name]
    if record["photo"].startswith("skimage:"):
        pytest.importorskip("skimage")
    photo = load_photo(record)
    path, masks, boxes = write_inputs(record, photo, folder)
    return photo, path, masks, boxes


@pytest.mark.parametrize("name", [pytest.param(n, marks=[] if n in QUICK else [pytest.mark.slow]) for n in PHOTOS])
def test_frame_zero_of_every_gallery_photo_is_the_photo(name, built_case):
    result, _ = built_case(f"photo:{name}")  # its masks or boxes (tests/conftest.py's build_case)
    photo = load_photo(PHOTOS[name])
    frame0, _, _ = _frame0(result.shot)
    assert frame0.shape == photo.shape, name
    print(f"{name}: frame 0 against the photo {cv2.PSNR(frame0, photo):.1f} dB")  # the figure, under -s
    assert cv2.PSNR(frame0, photo) >= MIN_PSNR_DB, (name, cv2.PSNR(frame0, photo))


@pytest.mark.parametrize("pitch", [5.0, 30.0, pytest.param(60.0, marks=pytest.mark.slow),
                                   pytest.param(85.0, marks=pytest.mark.slow)])
def test_frame_zero_of_the_bench_photos_scenes_is_the_photo(pitch, tmp_path):
    from physomni_usd.bench.photos import make_known_scene, write_scene

    scene = make_known_scene(pitch, 320, 240)
    specs = write_scene(scene, tmp_path / "input")
    result = api.build(tmp_path / "input" / "photo.png", tmp_path / "shot", specs)
    frame0, _, _ = _frame0(result.shot)
    print(f"pitch {pitch:g}: frame 0 against the photo {cv2.PSNR(frame0, scene.photo):.1f} dB")
    assert cv2.PSNR(frame0, scene.photo) >= MIN_PSNR_DB, (pitch, cv2.PSNR(frame0, scene.photo))


def test_frame_zero_is_the_photo_under_a_deliberately_wrong_lift(tmp_path):
    """The coffee cup and saucer (truth: 52° pitch) built as if seen from 5° above through a 100° lens, every
    object an extruded slab twice as deep as wide: the meshes stand far from where the photo shows the cup, yet
    frame 0 is the photo."""
    photo, path, masks, boxes = _inputs("coffee", tmp_path / "input")
    wrong = BuildSettings(camera=CameraSettings(pitch_deg=5.0, fov_deg=100.0),
                          lift=LiftSettings(shape="extrude", depth_ratio=2.0))
    result = api.build(path, tmp_path / "shot", masks, boxes, wrong)
    frame0, renderer, state = _frame0(result.shot)
    print(f"coffee, wrong lift: frame 0 against the photo {cv2.PSNR(frame0, photo):.1f} dB")
    assert cv2.PSNR(frame0, photo) >= MIN_PSNR_DB, cv2.PSNR(frame0, photo)
    # the lift is as poor as the test needs: the meshes' silhouettes are not the objects' outlines
    given = np.zeros(photo.shape[:2], bool)
    for spec in masks:
        given |= cv2.imread(spec.rsplit(":", 1)[0], cv2.IMREAD_GRAYSCALE) > 0
    drawn = cv2.resize((state.mesh_face >= 0).astype(np.uint8), photo.shape[1::-1],
                       interpolation=cv2.INTER_NEAREST) > 0
    iou = (given & drawn).sum() / max((given | drawn).sum(), 1)
    print(f"coffee, wrong lift: the meshes against the masks IoU {iou:.2f}")
    assert iou < 0.8, iou


@pytest.fixture(scope="module")
def general_scene(tmp_path_factory):
    """A fresh ``bench general`` scene (a new seed each run), rendered by Blender's Cycles: (folder, seed, truth)."""
    from physomni_usd.bench import general

    if "PHYSOMNI_BLENDER_PYTHON" not in os.environ:
        try:
            general.blender_python()
        except general.NoBlender:
            pytest.skip("no Blender Python (PHYSOMNI_BLENDER_PYTHON) to render a general scene")
    seed = int(np.random.default_rng().integers(1, 10**8))
    folder = tmp_path_factory.mktemp("general")
    return folder, seed, general.render_scene(general.describe_scene(seed), folder)


#: A lift wrong on purpose: a near-level camera through a 100° lens, every object a slab twice as deep as wide.
POOR_LIFT = BuildSettings(camera=CameraSettings(pitch_deg=5.0, fov_deg=100.0),
                          lift=LiftSettings(shape="extrude", depth_ratio=2.0))


@pytest.mark.slow  # a Cycles render (about 20 s) and a build each
@pytest.mark.parametrize("lift", ["as built", "poor"])
def test_frame_zero_of_a_fresh_bench_general_scene_is_the_photo(general_scene, lift, tmp_path):
    """Built from its visible masks as a user would, and again with :data:`POOR_LIFT` (the scene's true pitch
    and lens are drawn at random, so the poor lift is wrong for it): frame 0 is the photo either way."""
    folder, seed, truth = general_scene
    masks = [f"{folder / o['modal']}:{o['label']}" for o in truth["objects"]]
    settings = POOR_LIFT if lift == "poor" else BuildSettings()
    result = api.build(folder / "photo.png", tmp_path / "shot", masks, (), settings)
    photo = cv2.cvtColor(cv2.imread(str(folder / "photo.png")), cv2.COLOR_BGR2RGB)
    frame0, _, _ = _frame0(result.shot)
    print(f"general scene {seed}, {lift}: frame 0 against the photo {cv2.PSNR(frame0, photo):.1f} dB")
    assert cv2.PSNR(frame0, photo) >= MIN_PSNR_DB, (f"seed {seed}, {lift}", cv2.PSNR(frame0, photo))
