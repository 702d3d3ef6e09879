"""The sam segmenter through the CLI on a tiny random SAM: refused without weights, its mask used, empty refused."""

from __future__ import annotations

import json
import os

import cv2
import pytest

torch = pytest.importorskip("torch")
transformers = pytest.importorskip("transformers")
pytest.importorskip("physomni_sam")

from tests.conftest import cli, synthetic_photo  # noqa: E402

BOX = "125,70,205,145"


def tiny_sam(folder, empty: bool = False):
    """A random SAM with a 64-pixel input (8-pixel patches) and its processor, saved with save_pretrained."""
    from transformers import SamConfig, SamImageProcessor, SamModel, SamProcessor
    from transformers.models.sam.configuration_sam import (SamMaskDecoderConfig, SamPromptEncoderConfig,
                                                           SamVisionConfig)

    vision = SamVisionConfig(hidden_size=32, output_channels=16, num_hidden_layers=2, num_attention_heads=2,
                             image_size=64, patch_size=8, mlp_dim=32, global_attn_indexes=[1], window_size=4,
                             num_pos_feats=8)
    prompt = SamPromptEncoderConfig(hidden_size=16, image_size=64, patch_size=8, mask_input_channels=4)
    decoder = SamMaskDecoderConfig(hidden_size=16, num_hidden_layers=2, num_attention_heads=2, mlp_dim=32,
                                   iou_head_hidden_dim=16)
    torch.manual_seed(0)
    model = SamModel(SamConfig(vision_config=vision.to_dict(), prompt_encoder_config=prompt.to_dict(),
                               mask_decoder_config=decoder.to_dict())).eval()
    if empty:  # every mask logit exactly 0: nothing passes the > 0 threshold
        with torch.no_grad():
            for p in model.mask_decoder.output_hypernetworks_mlps.parameters():
                p.zero_()
    model.save_pretrained(folder)
    SamProcessor(SamImageProcessor(size={"longest_edge": 64}, pad_size={"height": 64, "width": 64})
                 ).save_pretrained(folder)
    return folder


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_SAM_WEIGHTS"}
    env.update(extra)
    return env


def _errors(proc):
    return [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]


def test_missing_weights_is_one_line_and_writes_nothing(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    out = tmp_path / "out"
    proc = cli("build", paths["photo"], "-o", out, "--box", f"{BOX}:box", "--segmenter", "sam", env=_env())
    assert proc.returncode == 2
    errors = _errors(proc)
    assert len(errors) == 1 and "PHYSOMNI_SAM_WEIGHTS" in errors[0] and "from_pretrained" in errors[0]
    assert not out.exists()


def test_box_is_cut_by_the_model_and_reported(tmp_path, monkeypatch):
    from physomni_sam import SamSegmenter

    from physomni_usd.swappable.protocols import Prompt

    paths = synthetic_photo(tmp_path / "in")
    weights = tiny_sam(tmp_path / "sam")
    monkeypatch.setenv("PHYSOMNI_SAM_WEIGHTS", str(weights))
    photo = cv2.cvtColor(cv2.imread(str(paths["photo"])), cv2.COLOR_BGR2RGB)
    expected = SamSegmenter().segment(photo, [Prompt(box=tuple(int(c) for c in BOX.split(",")))])[0]
    assert 16 <= expected.sum() < expected.size  # the random model's mask is a usable one
    out = tmp_path / "out"
    cli("build", paths["photo"], "-o", out, "--mask", f"{paths['cup']}:cup", "--box", f"{BOX}:box",
        "--segmenter", "sam", env=_env(PHYSOMNI_SAM_WEIGHTS=str(weights)), check=True)
    got = cv2.imread(str(out / "inputs" / "masks" / "box_1.png"), cv2.IMREAD_GRAYSCALE) > 0
    assert (got == expected).all()
    report = json.loads((out / "report.json").read_text())
    used = report["stages"]["build"]["backends"]["segmenter"]
    assert used["name"] == "sam" and used["package"] == "physomni-sam" and used["weights"] == str(weights)
    assert [o["source"] for o in report["objects"]] == ["file:" + str(paths["cup"]), "box:" + BOX]


def test_empty_mask_from_the_model_is_the_usual_error(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    weights = tiny_sam(tmp_path / "sam", empty=True)
    out = tmp_path / "out"
    proc = cli("build", paths["photo"], "-o", out, "--box", f"{BOX}:box", "--segmenter", "sam",
               env=_env(PHYSOMNI_SAM_WEIGHTS=str(weights)))
    assert proc.returncode == 2, proc.stderr
    errors = _errors(proc)
    assert len(errors) == 1 and "is empty: no pixel belongs to the object" in errors[0]
    assert "Traceback" not in proc.stderr
    assert not (out / "scene.usda").exists()


def test_clicks_after_the_box_are_the_models_point_prompts(tmp_path, monkeypatch):
    from physomni_sam import SamSegmenter

    from physomni_usd.swappable.protocols import Prompt

    paths = synthetic_photo(tmp_path / "in")
    weights = tiny_sam(tmp_path / "sam")
    monkeypatch.setenv("PHYSOMNI_SAM_WEIGHTS", str(weights))
    photo = cv2.cvtColor(cv2.imread(str(paths["photo"])), cv2.COLOR_BGR2RGB)
    box = tuple(int(c) for c in BOX.split(","))
    clicks = [(165.0, 110.0, True), (128.0, 72.0, False)]
    sam = SamSegmenter()
    expected = sam.segment(photo, [Prompt(box=box, points=clicks)])[0]
    assert (expected != sam.segment(photo, [Prompt(box=box)])[0]).any()  # the clicks change the mask
    out = tmp_path / "out"
    cli("build", paths["photo"], "-o", out, "--box", f"{BOX}:box:+165,110:-128,72", "--segmenter", "sam",
        env=_env(PHYSOMNI_SAM_WEIGHTS=str(weights)), check=True)
    got = cv2.imread(str(out / "inputs" / "masks" / "box_0.png"), cv2.IMREAD_GRAYSCALE) > 0
    assert (got == expected).all()
    assert json.loads((out / "report.json").read_text())["objects"][0]["label"] == "box"
