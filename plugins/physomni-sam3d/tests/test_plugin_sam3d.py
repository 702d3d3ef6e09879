"""The sam3d lifter with a stand-in SAM 3D Objects: its poses become build --meshes input and align."""

from __future__ import annotations

import json
import sys
import types

import numpy as np
import pytest

physomni_sam3d = pytest.importorskip("physomni_sam3d")
trimesh = pytest.importorskip("trimesh")

from click.testing import CliRunner  # noqa: E402

from physomni_usd.cli import main  # noqa: E402
from physomni_usd.rotations import from_wxyz  # noqa: E402
from tests.conftest import synthetic_photo  # noqa: E402

#: A quarter turn about the vertical (PyTorch3D's y), as SAM 3D Objects would give it.
QUARTER_Y = [np.cos(np.pi / 8), 0.0, np.sin(np.pi / 8), 0.0]


class FakePipeline:
    """Returns, per mask, a 0.2 m box and a pose 2 m in front of the camera, in PyTorch3D camera axes."""

    def __init__(self):
        self.calls = []

    def run(self, rgba, _mask, seed, **kwargs):
        self.calls.append((rgba.shape, int((rgba[..., 3] > 0).sum()), kwargs))
        return {"glb": trimesh.creation.box((0.2, 0.2, 0.2)), "rotation": np.array([QUARTER_Y]),
                "translation": np.array([[0.1, -0.2, 2.0]]), "scale": np.array([[1.5, 1.5, 1.5]])}


@pytest.fixture
def fake_sam3d(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "sam3d_objects", types.ModuleType("sam3d_objects"))
    config = tmp_path / "pipeline.yaml"
    config.write_text("# stand-in\n")
    monkeypatch.setenv("PHYSOMNI_SAM3D_CONFIG", str(config))
    pipeline = FakePipeline()
    monkeypatch.setattr(physomni_sam3d, "load_pipeline", lambda path: pipeline)
    return pipeline


def test_pose_is_turned_into_opencv_camera_axes():
    out = physomni_sam3d.to_camera_pose({"glb": trimesh.creation.box((1, 1, 1)), "rotation": [QUARTER_Y],
                                         "translation": [[0.1, -0.2, 2.0]], "scale": [[1.5, 1.5, 1.5]]})
    assert np.allclose(out.translation, [-0.1, 0.2, 2.0])
    assert out.scale == 1.5
    flip = np.diag([-1.0, -1.0, 1.0])
    assert np.allclose(from_wxyz(out.rotation_wxyz), flip @ from_wxyz(QUARTER_Y))
    assert len(out.vertices) == 8 and len(out.faces) == 12


def test_not_ready_without_the_package(monkeypatch):
    monkeypatch.setattr(physomni_sam3d, "MODULES", ("no_such_sam3d_module",))
    assert "sam3d_objects" in physomni_sam3d.Sam3DLifter.missing()


def test_build_aligns_the_lifters_meshes(tmp_path, fake_sam3d):
    paths = synthetic_photo(tmp_path / "in")
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["build", str(paths["photo"]), "-o", str(out), "--mask",
                                       f"{paths['cup']}:cup", "--mask", f"{paths['box']}:box", "--lifter", "sam3d",
                                       "-q"])
    assert result.exit_code == 0, result.output
    assert [c[1] for c in fake_sam3d.calls] == [_mask_pixels(paths[k]) for k in
                                                 ("cup", "box")]
    poses = json.loads((out / "inputs" / "lifted" / "poses.json").read_text())
    assert set(poses) == {"cup", "box"}
    assert np.allclose(poses["cup"]["translation"], [-0.1, 0.2, 2.0]) and poses["cup"]["scale"] == 1.5
    report = json.loads((out / "report.json").read_text())
    assert report["stages"]["build"]["backends"]["lifter"]["name"] == "sam3d"
    assert "align.place" in report["stages"]["build"]["seconds"]  # placed from the posed meshes: shapes "external"
    assert all(o["shape"] == "external" for o in report["objects"])


def test_lifter_and_meshes_together_are_refused(tmp_path, fake_sam3d):
    paths = synthetic_photo(tmp_path / "in")
    result = CliRunner().invoke(main, ["build", str(paths["photo"]), "-o", str(tmp_path / "out"), "--mask",
                                       str(paths["cup"]), "--lifter", "sam3d", "--meshes", str(tmp_path)])
    assert result.exit_code == 2
    assert not (tmp_path / "out").exists()


def _mask_pixels(path) -> int:
    import cv2

    return int((cv2.imread(str(path), cv2.IMREAD_GRAYSCALE) > 0).sum())
