"""Shared fixtures: a tiny synthetic photo with known objects, a shot built from it once per session, each
bundled example and bench photo built once per session as a user would build it, and the rendered cup on its
saucer built once per session."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import cv2
import numpy as np
import pytest

from physomni_usd.geometry.camera import PinholeCamera

W, H = 240, 180


def synthetic_photo(folder: pathlib.Path) -> dict:
    """A wall-and-floor photo with a round 'cup' and a 'box' standing on the floor; writes photo and masks."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    img = np.zeros((H, W, 3), np.float32)
    horizon = 70
    img[:horizon] = np.linspace(150, 190, horizon)[:, None, None] * np.array([0.9, 0.95, 1.0])
    img[horizon:] = np.linspace(120, 80, H - horizon)[:, None, None] * np.array([1.0, 0.85, 0.7])
    img += rng.normal(0, 4, (H, W, 1))  # sensor-like (luma) grain, so that SSIM has structure to compare
    cup = np.zeros((H, W), np.uint8)
    cv2.ellipse(cup, (70, 80), (24, 10), 0, 0, 360, 1, -1)  # rim
    cv2.ellipse(cup, (70, 128), (20, 8), 0, 0, 360, 1, -1)  # base
    cv2.rectangle(cup, (46, 80), (94, 110), 1, -1)
    cv2.fillConvexPoly(cup, np.array([[46, 110], [94, 110], [90, 128], [50, 128]]), 1)
    box = np.zeros((H, W), np.uint8)
    cv2.rectangle(box, (130, 75), (200, 140), 1, -1)
    shade_x = np.linspace(0.7, 1.1, W)[None, :, None]
    img = np.where(cup[..., None] > 0, np.array([200, 60, 50]) * shade_x, img)
    img = np.where(box[..., None] > 0, np.array([70, 110, 190]) * shade_x, img)
    img[box > 0] += rng.normal(0, 6, (int(box.sum()), 1))
    photo = np.clip(img, 0, 255).astype(np.uint8)
    paths = {"photo": folder / "photo.png", "cup": folder / "cup.png", "box": folder / "box.png"}
    cv2.imwrite(str(paths["photo"]), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    cv2.imwrite(str(paths["cup"]), cup * 255)
    cv2.imwrite(str(paths["box"]), box * 255)
    return paths


def rendered_blocks(folder: pathlib.Path, camera, truth, label: str = "block") -> list[str]:
    """Render the ``truth`` meshes through ``camera`` (``bench.synthetic.render_truth``, seed 5), write the photo
    and each object's mask (``block{k}.png``) into ``folder``; returns the ``--mask`` specs, labelled ``label``."""
    from physomni_usd.bench.synthetic import render_truth

    photo, masks = render_truth(camera, truth, np.random.default_rng(5))
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    specs = []
    for k, m in enumerate(masks):
        cv2.imwrite(str(folder / f"block{k}.png"), m.astype(np.uint8) * 255)
        specs.append(f"{folder / f'block{k}.png'}:{label}")
    return specs


def ball_seen_low(deg: float, x: float = 0.0, radius: float = 0.035):
    """A camera ``deg`` degrees above a ball of ``radius`` (m) resting on the ground 0.6 m ahead of it (``x`` m to
    its right): the camera, the ball's silhouette (bool, 480 × 640) and its centre (3,) m."""
    import math

    import trimesh

    camera = PinholeCamera(640, 480, 50.0, deg, (0.0, -0.6, radius + 0.6 * math.tan(math.radians(deg))))
    ball = trimesh.creation.icosphere(4, radius)
    ball.vertices += [x, 0.0, radius]
    uv, _ = camera.project(ball.vertices)
    mask = np.zeros((camera.height, camera.width), np.uint8)
    for tri in ball.faces:
        cv2.fillPoly(mask, [np.round(uv[tri] * 16).astype(np.int32)], 1, shift=4)
    return camera, mask > 0, np.array([x, 0.0, radius])


def cli(*args, check=False, env=None) -> subprocess.CompletedProcess:
    """Run ``physomni-usd ARGS`` in a fresh interpreter; returns the completed process."""
    code = ("import sys\nfrom physomni_usd.cli import main\n"
            "try:\n    main(sys.argv[1:], prog_name='physomni-usd')\n"
            "finally:\n    print('TORCH_IMPORTED=' + str('torch' in sys.modules), file=sys.stderr)\n")
    proc = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, env=env)
    if check and proc.returncode != 0:
        raise AssertionError(f"physomni-usd {' '.join(map(str, args))} failed:\n{proc.stdout}\n{proc.stderr}")
    return proc


@pytest.fixture(scope="session")
def photo(tmp_path_factory) -> dict:
    return synthetic_photo(tmp_path_factory.mktemp("photo"))


@pytest.fixture(scope="session")
def shot(tmp_path_factory, photo) -> dict:
    """A shot run end to end once: build + simulate (1.5 s) + render, through the CLI."""
    out = tmp_path_factory.mktemp("shot")
    proc = cli("run", photo["photo"], "-o", out, "--mask", f"{photo['cup']}:cup", "--mask", f"{photo['box']}:box",
               "--push", "box=0.6,0,0", "--seconds", "1.5", "--fps", "20",
               "--camera-height", "1",  # a fixed scale: tests below hold it to absolute lengths
               check=True)
    return {"dir": out, "shot": out / "shot.usda", "proc": proc, **photo}


def first_frames(shot_dir: pathlib.Path, dest: pathlib.Path, frames: int) -> pathlib.Path:
    """A copy of the shot at ``shot_dir`` in ``dest``, its frame range cut to its first ``frames``."""
    import shutil

    from pxr import Usd

    shutil.copytree(shot_dir, dest)
    stage = Usd.Stage.Open(str(dest / "shot.usda"))
    stage.SetEndTimeCode(stage.GetStartTimeCode() + frames - 1)
    stage.GetRootLayer().Save()
    return dest


EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def build_case(case: str, folder: pathlib.Path):
    """(build result, lines the build echoed) of ``case`` ('example:NAME': the example's masks, boxes and sizes
    as its example.json gives them; 'photo:NAME': the bench photo's records), built as a user would build it:
    no pushes, no forces, no settings."""
    import json

    import physomni_usd as api
    from physomni_usd.bench.real_photos import load_photo, load_truth, write_inputs

    kind, name = case.split(":", 1)
    said = []
    if kind == "example":
        spec_path = EXAMPLES / name / "example.json"
        spec = json.loads(spec_path.read_text())
        masks = [str(spec_path.parent / m) for m in spec.get("masks", [])]
        return api.build(spec_path.parent / spec["photo"], folder / "shot", masks, spec.get("boxes", []),
                         sizes=spec.get("size", []), echo=said.append), said
    record = load_truth()[name]
    if record["photo"].startswith("skimage:"):
        pytest.importorskip("skimage")
    path, masks, boxes = write_inputs(record, load_photo(record), folder / "input")
    return api.build(path, folder / "shot", masks, boxes, echo=said.append), said


@pytest.fixture(scope="session")
def built_case(tmp_path_factory):
    """case → (build result, echoed lines) of :func:`build_case`, each case built once per session.

    The same builds are checked by several modules (frame 0 in tests/test_examples_frame0.py and
    tests/test_frame0_gallery.py, rest and sizes in tests/test_gallery_rest.py, the slabs' texture, the
    estimate's rules, an orbit): a build of an example takes 10-80 s on a loaded 2-core machine, so building
    each once saves minutes. The shot is shared: a test that changes it (simulates it, writes into its folder)
    works on :func:`copy_of` it."""
    cache = {}

    def get(case):
        if case not in cache:
            cache[case] = build_case(case, tmp_path_factory.mktemp(case.replace(":", "-")))
        return cache[case]
    return get


def copy_of(result, dest: pathlib.Path):
    """A build result like ``result`` for a copy of its folder at ``dest`` (the shared build left as built)."""
    import dataclasses
    import shutil

    shutil.copytree(result.folder, dest)
    return dataclasses.replace(result, folder=dest, shot=dest / result.shot.relative_to(result.folder))


@pytest.fixture(scope="session")
def motorcycle_run(tmp_path_factory) -> tuple[subprocess.CompletedProcess, pathlib.Path]:
    """(the finished process, its output folder) of ``bash examples/motorcycle/run.sh OUT``, run once per
    session: its video and its shot are read (never changed) by tests/test_motion.py,
    tests/test_still_world.py and tests/test_pillow.py, and the run (build, simulate, render) takes a minute on a loaded 2-core machine."""
    out = tmp_path_factory.mktemp("motorcycle-run") / "moto"
    proc = subprocess.run(["bash", str(EXAMPLES / "motorcycle" / "run.sh"), str(out)], capture_output=True, text=True)
    return proc, out


#: The camera the cup on its saucer (:func:`cup_saucer_truth`) is rendered through.
TRUTH_CAMERA = PinholeCamera(320, 240, 50.0, 40.0, (0.0, -0.35, 0.35))


def cup_saucer_truth():
    """A 15 cm saucer, an 8 cm cup standing on it and an 11 cm spoon lying in it, metres, world (z up)."""
    import trimesh

    saucer = trimesh.creation.cylinder(0.075, 0.015, sections=48)
    saucer.apply_translation([0, 0, 0.0075])
    cup = trimesh.creation.cylinder(0.04, 0.09, sections=48)
    cup.apply_translation([-0.01, 0.0, 0.015 + 0.045])
    spoon = trimesh.creation.box((0.11, 0.018, 0.006))
    spoon.apply_transform(trimesh.transformations.rotation_matrix(0.5, [0, 0, 1]))
    spoon.apply_translation([0.025, -0.035, 0.015 + 0.003])
    return [saucer, cup, spoon]


@pytest.fixture(scope="session")
def cup_saucer_build(tmp_path_factory) -> dict:
    """The cup on its saucer rendered through :data:`TRUTH_CAMERA` (rng seed 3), its three *visible* masks
    written as saucer/cup/spoon.png and the shot built from them (``out``), once per session: tests/test_cup_saucer.py
    checks the build and tests/test_cloth_sheet.py makes its objects cloth. Shared: a test that changes the shot
    works on a copy of it."""
    from physomni_usd.bench.synthetic import render_truth
    from physomni_usd.building import build_shot

    folder = tmp_path_factory.mktemp("cup_saucer")
    photo, masks = render_truth(TRUTH_CAMERA, cup_saucer_truth(), np.random.default_rng(3))  # visible parts only
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    specs = []
    for name, m in zip(("saucer", "cup", "spoon"), masks):
        cv2.imwrite(str(folder / f"{name}.png"), m.astype(np.uint8) * 255)
        specs.append(f"{folder / name}.png:{name}")
    out = folder / "shot"
    build_shot(folder / "photo.png", out, masks=specs)
    return {"out": out, "photo": photo, "masks": masks}
