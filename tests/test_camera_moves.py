"""render --camera: the ten moves written to render.usda, played from the composed stage, over a world that
reaches past the photo's frame."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

from physomni_usd.rendering.moves import MOVES, move_matrices
from physomni_usd.rendering.passes import read_exr
from physomni_usd.rendering.video import ShotRenderer, render_shot
from physomni_usd.settings import RenderSettings

from .conftest import cli, first_frames

FRAMES = 4
SMALL = RenderSettings(max_size=96)


@pytest.fixture(scope="module")
def short_shot(shot, tmp_path_factory):
    """A copy of the shared shot cut to its first frames (each test copies it again before writing)."""
    return first_frames(shot["dir"], tmp_path_factory.mktemp("moves") / "shot", FRAMES)


def _copy(src, tmp_path):
    d = tmp_path / "shot"
    shutil.copytree(src, d)
    return d


def _camera_origins(shot_dir):
    stage = Usd.Stage.Open(str(shot_dir / "shot.usda"))
    cam = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Camera"))
    return np.array([np.array(cam.ComputeLocalToWorldTransform(Usd.TimeCode(t)))[3, :3] for t in range(FRAMES)])


def test_every_move_is_time_sampled_moves_the_camera_and_sees_something_everywhere(short_shot, tmp_path):
    d = _copy(short_shot, tmp_path)
    static = ShotRenderer(Usd.Stage.Open(str(d / "shot.usda")), SMALL).frame(0.0)
    for move in MOVES:
        if move == "static":
            continue
        section = render_shot(d, d / f"{move}.mp4", SMALL, passes=("depth",), passes_dir=d / move, camera=move)
        assert section["camera"]["move"] == move
        stage = Usd.Stage.Open(str(d / "shot.usda"))
        attr = stage.GetPrimAtPath("/World/Camera").GetAttribute("xformOp:transform")
        assert attr.GetNumTimeSamples() == FRAMES, move
        origins = _camera_origins(d)
        assert np.linalg.norm(origins[-1] - origins[0]) > 0.05, move  # the camera goes somewhere
        assert np.allclose(origins[0], _camera_origins(short_shot)[0])  # from the photo's own camera
        for t in range(FRAMES):
            z = read_exr(d / move / f"passes.{t:04d}.exr")["Z"]
            assert np.isfinite(z).all() and (z > 0).all(), (move, t)
        # the first frame of a move is the photo's frame
        first = ShotRenderer(stage, SMALL).frame(0.0)
        assert np.abs(first.astype(int) - static.astype(int)).max() <= 1, move
    layer = Sdf.Layer.FindOrOpen(str(d / "shot.usda"))
    assert [p.split("/")[-1] for p in layer.subLayerPaths][:3] == ["edits.usda", "render.usda", "sim.usdc"]


def test_moves_go_where_their_names_say():
    fwd = np.array([0.0, 3.0, -1.5]) / np.linalg.norm([0.0, 3.0, -1.5])
    right = np.array([1.0, 0.0, 0.0])
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3], m[3, :3] = right, np.cross(right, fwd), -fwd, (0.0, -3.0, 1.5)
    end = {mv: move_matrices(m, np.zeros(3), mv, 1.0, 3)[-1] for mv in MOVES}
    o = {mv: e[3, :3] for mv, e in end.items()}
    assert o["orbit-left"][0] < 0 < o["orbit-right"][0] and o["truck-left"][0] < 0 < o["truck-right"][0]
    assert o["orbit-up"][2] > 1.5 > o["orbit-down"][2] and o["crane-down"][2] < 1.5
    assert np.linalg.norm(o["dolly-in"]) < 3.354 < np.linalg.norm(o["dolly-out"])
    assert np.allclose(o["static"], m[3, :3])
    for mv in ("orbit-left", "orbit-up"):  # an orbit keeps the objects' centre straight ahead
        ahead = -end[mv][2, :3]
        to_centre = -o[mv] / np.linalg.norm(o[mv])
        assert np.dot(ahead, to_centre) > 0.999


def test_artist_keys_win_and_static_removes_the_move(short_shot, tmp_path):
    d = _copy(short_shot, tmp_path)
    proc = cli("render", d / "shot.usda", "--camera", "truck-right", "--max-size", "64", "-q")
    assert proc.returncode == 0, proc.stderr
    moved = _camera_origins(d)
    edits = Sdf.Layer.FindOrOpen(str(d / "edits.usda"))
    before = (d / "render.usda").read_bytes()
    stage = Usd.Stage.Open(str(d / "shot.usda"))
    stage.SetEditTarget(Usd.EditTarget(edits))
    keyed = Gf.Matrix4d(stage.GetPrimAtPath("/World/Camera").GetAttribute("xformOp:transform")
                        .Get(Usd.TimeCode(0))).SetTranslateOnly(Gf.Vec3d(0.5, -4.0, 1.0))
    stage.GetPrimAtPath("/World/Camera").GetAttribute("xformOp:transform").Set(keyed, Usd.TimeCode(0))
    edits.Save()
    assert np.allclose(_camera_origins(d)[-1], (0.5, -4.0, 1.0))  # the artist's key, not the truck
    assert (d / "render.usda").read_bytes() == before
    edits_bytes = (d / "edits.usda").read_bytes()
    proc = cli("render", d / "shot.usda", "--camera", "static", "--max-size", "64", "-q")
    assert proc.returncode == 0, proc.stderr
    assert (d / "edits.usda").read_bytes() == edits_bytes
    assert "xformOp:transform" not in (d / "render.usda").read_text()
    report = json.loads((d / "report.json").read_text())["stages"]["render"]
    assert report["camera"]["move"] == "static" and report["seconds_per_frame"] > 0
    assert not np.allclose(moved[-1], moved[0])


def test_bad_amount_is_one_line_and_writes_nothing(short_shot, tmp_path):
    d = _copy(short_shot, tmp_path)
    before = {p.name: p.read_bytes() for p in d.iterdir() if p.is_file()}
    proc = cli("render", d / "shot.usda", "--camera", "orbit-left", "--camera-amount", "9", "-q")
    errors = [ln for ln in proc.stderr.splitlines() if ln.strip() and not ln.startswith("TORCH_IMPORTED")]
    assert proc.returncode == 2 and len(errors) == 1 and "--camera-amount" in errors[0]
    assert {p.name: p.read_bytes() for p in d.iterdir() if p.is_file()} == before


def test_a_shot_without_a_wide_plate_still_fills_every_pixel(short_shot, tmp_path):
    d = _copy(short_shot, tmp_path)
    scene = Sdf.Layer.FindOrOpen(str(d / "scene.usda"))
    spec = scene.GetPrimAtPath("/World/Background")
    data = dict(spec.customData)
    data.pop("physomni", None)
    spec.customData = data
    scene.Save()
    (d / "textures" / "plate_wide.png").unlink()
    render_shot(d, d / "o.mp4", SMALL, passes=("depth",), passes_dir=d / "p", camera="orbit-right",
                camera_amount=2.0)
    frame = ShotRenderer(Usd.Stage.Open(str(d / "shot.usda")), SMALL).frame(float(FRAMES - 1))
    assert frame.min(axis=2).max() > 0 and (frame.sum(axis=2) > 0).mean() > 0.99
    assert np.isfinite(read_exr(d / "p" / f"passes.{FRAMES - 1:04d}.exr")["Z"]).all()
