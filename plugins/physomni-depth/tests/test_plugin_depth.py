"""The depth-anything estimator on a tiny random Depth Anything: its depth map, and build using it."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("transformers")
pytest.importorskip("physomni_depth")

from tests.conftest import cli, synthetic_photo  # noqa: E402


def tiny_depth(folder, metric: bool = True):
    """A random Depth Anything (DINOv2 backbone, 32 wide, 28-pixel input) and its processor."""
    from transformers import AutoModelForDepthEstimation, DepthAnythingConfig, Dinov2Config, DPTImageProcessor

    backbone = Dinov2Config(hidden_size=32, num_hidden_layers=4, num_attention_heads=2, intermediate_size=37,
                            image_size=28, patch_size=14, out_features=["stage1", "stage2", "stage3", "stage4"],
                            reshape_hidden_states=False)
    config = DepthAnythingConfig(backbone_config=backbone.to_dict(), reassemble_hidden_size=32, patch_size=14,
                                 neck_hidden_sizes=[16, 16, 32, 32], fusion_hidden_size=16, head_hidden_size=16,
                                 depth_estimation_type="metric" if metric else "relative", max_depth=20)
    torch.manual_seed(0)
    AutoModelForDepthEstimation.from_config(config).save_pretrained(folder)
    DPTImageProcessor(size={"height": 28, "width": 28}, keep_aspect_ratio=False, ensure_multiple_of=14,
                      do_pad=False).save_pretrained(folder)
    return folder


def test_depth_map_has_the_photos_size(tmp_path, monkeypatch):
    from physomni_depth import DepthAnything

    for metric in (True, False):
        monkeypatch.setenv("PHYSOMNI_DEPTH_WEIGHTS", str(tiny_depth(tmp_path / f"d{metric}", metric)))
        photo = np.random.default_rng(0).integers(0, 255, (48, 64, 3)).astype(np.uint8)
        d = DepthAnything().depth(photo)
        assert d.depth.shape == (48, 64) and d.depth.dtype == np.float32 and d.metric is metric
        assert np.isfinite(d.depth).all() and (d.depth > 0).all()


def test_build_with_a_depth_model_reports_it(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    weights = tiny_depth(tmp_path / "depth")
    out = tmp_path / "out"
    cli("build", paths["photo"], "-o", out, "--mask", f"{paths['cup']}:cup", "--depth", "depth-anything",
        env={**os.environ, "PHYSOMNI_DEPTH_WEIGHTS": str(weights)}, check=True)
    build = json.loads((out / "report.json").read_text())["stages"]["build"]
    assert build["backends"]["depth"]["name"] == "depth-anything"
    assert build["backends"]["depth"]["weights"] == str(weights)
    assert "depth_ground" in build  # a random model sees no floor (None) or some plane (its pitch and inliers)


def test_missing_weights_is_one_line(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    env = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_DEPTH_WEIGHTS"}
    proc = cli("build", paths["photo"], "-o", tmp_path / "out", "--mask", str(paths["cup"]), "--depth",
               "depth-anything", env=env)
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "PHYSOMNI_DEPTH_WEIGHTS" in errors[0]
    assert not (tmp_path / "out").exists()
