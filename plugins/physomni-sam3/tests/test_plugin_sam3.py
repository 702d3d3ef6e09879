"""The sam3 finder through `build --find` on a tiny random SAM 3 the test builds: refused without weights
(and without any finder), its masks used and labelled by phrase, an empty search refused in one line."""

from __future__ import annotations

import json
import os
import pathlib
import sys
from importlib import metadata

import cv2
import numpy as np
import pytest

torch = pytest.importorskip("torch")
transformers = pytest.importorskip("transformers")
if not hasattr(transformers, "Sam3Model"):
    pytest.skip("this transformers has no Sam3Model", allow_module_level=True)

from tests.conftest import cli, synthetic_photo  # noqa: E402

PLUGIN = pathlib.Path(__file__).resolve().parents[1]


def tiny_sam3(folder: pathlib.Path, score: float) -> pathlib.Path:
    """A random SAM 3 (56-pixel input, one query) with a byte-level tokenizer, saved with save_pretrained.
    Its query and presence scores are set to ``score``'s sign: +1 finds one instance a phrase, -1 none."""
    from transformers import CLIPTokenizer, Sam3Config, Sam3Model
    from transformers.convert_slow_tokenizer import bytes_to_unicode

    folder.mkdir(parents=True, exist_ok=True)
    symbols = list(bytes_to_unicode().values())
    vocab = {s: i for i, s in enumerate(symbols + [s + "</w>" for s in symbols]
                                       + ["<|startoftext|>", "<|endoftext|>"])}
    CLIPTokenizer(vocab=vocab, merges=[]).save_pretrained(folder)
    small = dict(num_attention_heads=2, intermediate_size=64)
    config = Sam3Config(
        vision_config=dict(backbone_config=dict(model_type="sam3_vit_model", hidden_size=32, num_hidden_layers=2,
                                                image_size=56, patch_size=14, window_size=2, global_attn_indexes=[1],
                                                pretrain_image_size=56, **small),
                           fpn_hidden_size=32, backbone_feature_sizes=[[16, 16], [8, 8], [4, 4]]),
        text_config=dict(model_type="clip_text_model", vocab_size=len(vocab), hidden_size=32, projection_dim=32,
                         num_hidden_layers=1, max_position_embeddings=32, bos_token_id=len(vocab) - 2,
                         eos_token_id=len(vocab) - 1, pad_token_id=len(vocab) - 1, **small),
        geometry_encoder_config=dict(hidden_size=32, num_layers=1, **small),
        detr_encoder_config=dict(hidden_size=32, num_layers=1, **small),
        detr_decoder_config=dict(hidden_size=32, num_layers=1, num_queries=1, **small),
        mask_decoder_config=dict(hidden_size=32, num_attention_heads=2))
    torch.manual_seed(0)
    model = Sam3Model(config).eval()
    with torch.no_grad():  # scores that do not depend on the random weights: all found, or none
        scoring, presence = model.dot_product_scoring, model.detr_decoder.presence_head.layer3
        for layer, bias in ((scoring.query_proj, 2.0), (scoring.text_proj, 2.0 * np.sign(score))):
            layer.weight.zero_()
            layer.bias.fill_(bias)
        presence.weight.zero_()
        presence.bias.fill_(8.0 * np.sign(score))
    model.save_pretrained(folder)
    (folder / "preprocessor_config.json").write_text(json.dumps(
        {"size": {"height": 56, "width": 56}, "image_mean": [0.5] * 3, "image_std": [0.5] * 3}))
    return folder


@pytest.fixture()
def env(tmp_path):
    """The environment of a CLI run that sees the plugin: installed, or else registered for the test by a
    dist-info folder of its own (the entry point, as pip would write it)."""
    out = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_SAM3_WEIGHTS"}
    try:
        metadata.distribution("physomni-sam3")
    except metadata.PackageNotFoundError:
        info = tmp_path / "site" / "physomni_sam3-0.1.0.dist-info"
        info.mkdir(parents=True)
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: physomni-sam3\nVersion: 0.1.0\n")
        (info / "entry_points.txt").write_text('[physomni_usd.backends]\nfinder.sam3 = physomni_sam3:Sam3Finder\n')
        out["PYTHONPATH"] = os.pathsep.join([str(info.parent), str(PLUGIN), *sys.path])
    return out


def _errors(proc):
    return [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]


def test_without_weights_one_line_names_the_variable(tmp_path, env):
    paths = synthetic_photo(tmp_path / "in")
    proc = cli("build", paths["photo"], "-o", tmp_path / "out", "--find", "cup, box", env=env)
    assert proc.returncode == 2
    errors = _errors(proc)
    assert len(errors) == 1 and "PHYSOMNI_SAM3_WEIGHTS" in errors[0], proc.stderr
    assert not (tmp_path / "out").exists()


def test_the_registry_lists_the_finder(env):
    proc = cli("plugins", env=env, check=True)
    assert "finder:\n  sam3: plugin, physomni-sam3 0.1.0, not ready: PHYSOMNI_SAM3_WEIGHTS" in proc.stdout


def test_found_objects_are_built_labelled_by_phrase_and_numbered(tmp_path, env):
    paths = synthetic_photo(tmp_path / "in")
    weights = tiny_sam3(tmp_path / "sam3", score=1)
    env["PHYSOMNI_SAM3_WEIGHTS"] = str(weights)
    out = tmp_path / "out"
    proc = cli("build", paths["photo"], "-o", out, "--mask", f"{paths['box']}:box", "--find", "cup, saucer",
               env=env, check=True)
    report = json.loads((out / "report.json").read_text())
    assert [(o["name"], o["label"]) for o in report["objects"]] == [("box_0", "box"), ("cup_1", "cup"),
                                                                    ("saucer_2", "saucer")], proc.stderr
    assert report["objects"][1]["source"] == "find:cup"
    # the masks are the model's: the finder run here gives the same pixels
    sys.path.insert(0, str(PLUGIN))
    os.environ["PHYSOMNI_SAM3_WEIGHTS"] = str(weights)
    try:
        from physomni_sam3 import Sam3Finder

        photo = cv2.cvtColor(cv2.imread(str(paths["photo"])), cv2.COLOR_BGR2RGB)
        expected = Sam3Finder().find(photo, ["cup"])[0][0]
    finally:
        del os.environ["PHYSOMNI_SAM3_WEIGHTS"]
    got = cv2.imread(str(out / "inputs" / "masks" / "cup_1.png"), cv2.IMREAD_GRAYSCALE) > 0
    assert (got == expected).all()


def test_an_empty_search_is_refused_in_one_line(tmp_path, env):
    paths = synthetic_photo(tmp_path / "in")
    env["PHYSOMNI_SAM3_WEIGHTS"] = str(tiny_sam3(tmp_path / "sam3", score=-1))
    proc = cli("build", paths["photo"], "-o", tmp_path / "out", "--find", "cup, spoon", env=env)
    errors = _errors(proc)
    assert proc.returncode == 2 and len(errors) == 1 and "found none of 'cup', 'spoon'" in errors[0], proc.stderr
    assert not (tmp_path / "out").exists()
