"""rerender --model wan-vace on the tiny Wan VACE of diffusers' own tests: a video of the shot's frames and size."""

from __future__ import annotations

import json
import os

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("diffusers")
physomni_wan = pytest.importorskip("physomni_wan")

from tests.conftest import cli, synthetic_photo  # noqa: E402

PROMPT = "a cup and a box"


def tiny_wan(folder):
    """The tiny Wan VACE pipeline (no tokenizer or text encoder: the test caches the prompt's embeddings)."""
    from diffusers import (AutoencoderKLWan, FlowMatchEulerDiscreteScheduler, WanVACEPipeline,
                           WanVACETransformer3DModel)

    torch.manual_seed(0)
    vae = AutoencoderKLWan(base_dim=3, z_dim=16, dim_mult=[1, 1, 1, 1], num_res_blocks=1,
                           temperal_downsample=[False, True, True])
    transformer = WanVACETransformer3DModel(
        patch_size=(1, 2, 2), num_attention_heads=2, attention_head_dim=12, in_channels=16, out_channels=16,
        text_dim=32, freq_dim=256, ffn_dim=32, num_layers=3, cross_attn_norm=True,
        qk_norm="rms_norm_across_heads", rope_max_seq_len=32, vace_layers=[0, 2], vace_in_channels=96)
    WanVACEPipeline(tokenizer=None, text_encoder=None, vae=vae, scheduler=FlowMatchEulerDiscreteScheduler(shift=7.0),
                    transformer=transformer).save_pretrained(folder)
    return folder


@pytest.fixture(scope="module")
def wan_shot(tmp_path_factory):
    """A built, simulated and rendered shot of 5 frames (0.2 s at 20 fps)."""
    tmp = tmp_path_factory.mktemp("wan")
    paths = synthetic_photo(tmp / "in")
    out = tmp / "shot"
    cli("run", paths["photo"], "-o", out, "--mask", f"{paths['cup']}:cup", "--mask", f"{paths['box']}:box",
        "--push", "box=0.5,0,0", "--seconds", "0.2", "--fps", "20", check=True)
    return out


def test_missing_weights_is_one_line(wan_shot):
    env = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_WAN_WEIGHTS"}
    proc = cli("rerender", wan_shot / "shot.usda", "--model", "wan-vace", env=env)
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "PHYSOMNI_WAN_WEIGHTS" in errors[0]
    assert not (wan_shot / "rerender.mp4").exists()


def test_rerender_writes_a_video_of_the_shots_frames_and_size(wan_shot, tmp_path):
    import imageio.v3 as iio

    weights = tiny_wan(tmp_path / "wan")
    env = {**os.environ, "PHYSOMNI_WAN_WEIGHTS": str(weights), "PHYSOMNI_WAN_CACHE": str(tmp_path / "cache")}
    os.environ["PHYSOMNI_WAN_CACHE"] = env["PHYSOMNI_WAN_CACHE"]
    try:
        cached = physomni_wan.embeddings_file(str(weights), PROMPT)
    finally:
        del os.environ["PHYSOMNI_WAN_CACHE"]
    cached.parent.mkdir(parents=True)
    torch.save({"prompt": torch.randn(1, 16, 32), "negative": torch.randn(1, 16, 32)}, cached)
    video = tmp_path / "wan.mp4"
    cli("rerender", wan_shot / "shot.usda", "--model", "wan-vace", "--strength", "0.5", "--steps", "2",
        "--max-size", "64", "--prompt", PROMPT, "-o", video, env=env, check=True)
    render = json.loads((wan_shot / "report.json").read_text())["stages"]["render"]
    frames = iio.imread(video)
    assert render["frames"] == 5
    assert frames.shape == (5, round(64 * render["height"] / render["width"]), 64, 3)
    section = json.loads((wan_shot / "report.json").read_text())["stages"]["rerender"]
    assert section["backend"]["name"] == "wan-vace" and section["backend"]["weights"] == str(weights)
    assert section["frames"] == 5 and section["strength"] == 0.5 and section["steps"] == 2
    assert section["model"] == "wan-vace" and section["passes"] == ["depth", "objectId", "motion"]


def test_depth_control_paints_the_objects_depth_and_keeps_the_frames_elsewhere():
    import numpy as np

    frames = np.full((2, 40, 60, 3), 90, np.uint8)
    depth = np.full((2, 40, 60), 10.0, np.float32)
    ids = np.zeros((2, 40, 60), np.int32)
    ids[:, 10:20, 10:20], depth[:, 10:20, 10:20] = 1, 2.0  # near
    ids[:, 10:20, 40:50], depth[:, 10:20, 40:50] = 2, 4.0  # farther
    masks, control = physomni_wan.depth_control(frames, depth, ids, grow=2)
    assert masks[:, 8:22, 8:22].all() and not masks[:, 30:].any()
    assert (control[:, 30:] == 90).all()  # the rendered world is kept
    near, far = control[0, 15, 15, 0], control[0, 15, 45, 0]
    assert near > far and (control[0, 15, 15] == near).all()
