"""render --passes against the stage: depth, motion and object ids checked with independent geometry."""

from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom

from physomni_usd.rendering.passes import read_exr
from physomni_usd.geometry.mesh import triangulate
from physomni_usd.rendering.stage import read_camera

from .conftest import cli, first_frames

FRAMES = 6  # the first frames of the shared shot: the push moves the box from frame 0 on


@pytest.fixture(scope="module")
def passes(shot, tmp_path_factory):
    """A copy of the shared shot, cut to its first frames, rendered with every pass."""
    d = first_frames(shot["dir"], tmp_path_factory.mktemp("passes") / "shot", FRAMES)
    cli("render", d / "shot.usda", "--max-size", "240", "--passes", "depth,normal,flow,mask",
        "--passes-dir", d / "out", "-q", check=True)
    info = json.loads((d / "out" / "passes.json").read_text())
    frames = [read_exr(d / "out" / f"passes.{t:04d}.exr") for t in info["frames"]]
    return {"dir": d, "info": info, "frames": frames, "stage": Usd.Stage.Open(str(d / "shot.usda"))}


def meshes(stage, t):
    """Object prim path → (world points (N, 3), triangles (M, 3)) at time code ``t``."""
    out = {}
    for prim in stage.GetPrimAtPath("/World/Objects").GetChildren():
        for p in Usd.PrimRange(prim):
            if p.IsA(UsdGeom.Mesh):
                mesh = UsdGeom.Mesh(p)
                pts = np.asarray(mesh.GetPointsAttr().Get(t), float)
                m = np.array(UsdGeom.Xformable(p).ComputeLocalToWorldTransform(t))
                faces = triangulate(np.asarray(mesh.GetFaceVertexCountsAttr().Get()),
                                    np.asarray(mesh.GetFaceVertexIndicesAttr().Get()))
                out[str(p.GetPath())] = (pts @ m[:3, :3] + m[3, :3], faces)
    return out


def camera(p, t):
    z = p["frames"][0]["Z"]
    return read_camera(p["stage"], Usd.TimeCode(t), z.shape[1], z.shape[0])


def test_writes_the_channels_files_and_previews(passes):
    info = passes["info"]
    assert info["channels"] == ["Z", "N.X", "N.Y", "N.Z", "motion.X", "motion.Y", "objectId"]
    assert info["frames"] == list(range(FRAMES))
    assert set(info["objects"].values()) == {"environment", "/World/Objects/cup_0", "/World/Objects/box_1"}
    for name in ("depth", "normal", "flow", "mask"):
        assert (passes["dir"] / "out" / f"{name}.mp4").stat().st_size > 0
    for f in passes["frames"]:
        assert sorted(f) == sorted(info["channels"]) and all(c.dtype == np.float32 for c in f.values())
        assert np.isfinite(f["Z"]).all() and (f["Z"] > 0).all()
        n = np.stack([f["N.X"], f["N.Y"], f["N.Z"]], -1)
        assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-4)
    assert not np.any(passes["frames"][-1]["motion.X"]) and not np.any(passes["frames"][-1]["motion.Y"])


def test_z_at_each_objects_centre_is_its_depth_along_the_optical_axis(passes):
    for k in (0, FRAMES // 2):
        cam = camera(passes, k)
        z = passes["frames"][k]["Z"]
        for path, (pts, faces) in meshes(passes["stage"], k).items():
            u, v = cam.project(pts.mean(0)[None])[0][0]
            ray = np.array([(int(u) + 0.5 - 0.5 * cam.width) / cam.fx, (int(v) + 0.5 - 0.5 * cam.height) / cam.fy,
                            1.0]) @ cam.axes
            ray /= np.linalg.norm(ray)
            hits, _, _ = trimesh.Trimesh(pts, faces, process=False).ray.intersects_location(
                [cam.origin], [ray])
            assert len(hits), path
            expected = min(float((h - cam.origin) @ cam.axes[2]) for h in hits)
            assert z[int(v), int(u)] == pytest.approx(expected, rel=0.02), (path, k)


def test_mean_motion_of_the_moving_box_is_its_centres_projected_displacement(passes):
    info = passes["info"]
    box_id = next(int(i) for i, p in info["objects"].items() if p.endswith("box_1"))
    checked = 0
    for k in range(FRAMES - 1):
        f = passes["frames"][k]
        on = f["objectId"] == box_id
        c0 = meshes(passes["stage"], k)["/World/Objects/box_1"][0].mean(0)
        c1 = meshes(passes["stage"], k + 1)["/World/Objects/box_1"][0].mean(0)
        expected = camera(passes, k + 1).project(c1[None])[0][0] - camera(passes, k).project(c0[None])[0][0]
        got = np.array([f["motion.X"][on].mean(), f["motion.Y"][on].mean()])
        assert np.linalg.norm(got - expected) <= max(0.5, 0.1 * np.linalg.norm(expected)), (k, got, expected)
        checked += np.linalg.norm(expected) > 0.5
        # the camera holds still, so the environment does not move
        env = f["objectId"] == 0
        assert np.abs(f["motion.X"][env]).max() < 1e-3 and np.abs(f["motion.Y"][env]).max() < 1e-3
    assert checked, "the box never moved half a pixel: the test compared nothing"


def test_object_ids_cover_each_objects_rasterised_silhouette(passes):
    info = passes["info"]
    for k in (0, FRAMES - 1):
        cam = camera(passes, k)
        ids = passes["frames"][k]["objectId"]
        for path, (pts, faces) in meshes(passes["stage"], k).items():
            uv, _ = cam.project(pts)
            mask = np.zeros(ids.shape, np.uint8)
            # cv2 puts pixel centres on integers, the renderer at +0.5
            for tri in np.round((uv[faces] - 0.5) * 256).astype(np.int32):
                cv2.fillConvexPoly(mask, tri, 1, lineType=cv2.LINE_8, shift=8)
            oid = next(int(i) for i, p in info["objects"].items() if p == path)
            mine, theirs = ids == oid, mask > 0
            iou = (mine & theirs).sum() / (mine | theirs).sum()
            assert iou >= 0.95, (path, k, iou)


def test_only_the_requested_passes_are_written(shot, tmp_path):
    d = tmp_path / "shot"
    shutil.copytree(shot["dir"], d)
    stage = Usd.Stage.Open(str(d / "shot.usda"))
    stage.SetEndTimeCode(stage.GetStartTimeCode() + 1)
    stage.GetRootLayer().Save()
    cli("render", d / "shot.usda", "--max-size", "96", "--passes", "depth", "-q", check=True)
    assert sorted(p.name for p in (d / "passes").iterdir()) == ["depth.mp4", "passes.0000.exr",
                                                                  "passes.0001.exr", "passes.json"]
    assert list(read_exr(d / "passes" / "passes.0000.exr")) == ["Z"]
    report = json.loads((d / "report.json").read_text())["stages"]["render"]
    assert report["passes"]["channels"] == ["Z"]


@pytest.mark.parametrize("args, word", [(["--passes", "depth,colour"], "--passes"),
                                         (["--passes", ""], "--passes"),
                                         (["--passes-dir", "x"], "--passes-dir")])
def test_bad_passes_are_one_line_and_write_nothing(shot, tmp_path, args, word):
    before = (shot["dir"] / "report.json").read_bytes()
    proc = cli("render", shot["shot"], "-o", tmp_path / "v.mp4", *args)
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and word in errors[0], proc.stderr
    assert list(tmp_path.iterdir()) == [] and (shot["dir"] / "report.json").read_bytes() == before


def test_an_unwritable_passes_dir_is_one_line_and_writes_nothing(shot, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    before = (shot["dir"] / "report.json").read_bytes()
    proc = cli("render", shot["shot"], "-o", tmp_path / "v.mp4", "--passes", "all", "--passes-dir", blocker / "p")
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "file" in errors[0], proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
    assert (shot["dir"] / "report.json").read_bytes() == before
