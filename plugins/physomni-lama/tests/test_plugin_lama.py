"""The lama inpainter through the CLI: refused without weights, and its fill (not the built-in's) in the plate."""

from __future__ import annotations

import json
import os

import cv2
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("physomni_lama")

from physomni_usd.backends.steps import hole  # noqa: E402
from physomni_usd.settings import BuildSettings  # noqa: E402
from tests.conftest import cli, synthetic_photo  # noqa: E402


class MidGrey(torch.nn.Module):
    """LaMa's signature, model(image (1,3,H,W) in [0, 1], mask (1,1,H,W), 1 = hole): the hole becomes 0.5."""

    def forward(self, image: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        return image * (1.0 - mask) + 0.5 * mask


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_LAMA_WEIGHTS"}
    env.update(extra)
    return env


def test_missing_weights_is_one_line_and_writes_nothing(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    out = tmp_path / "out"
    proc = cli("build", paths["photo"], "-o", out, "--mask", f"{paths['cup']}:cup", "--inpainter", "lama", env=_env())
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "PHYSOMNI_LAMA_WEIGHTS" in errors[0] and "big-lama.pt" in errors[0]
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_plate_under_the_mask_is_the_models_grey(tmp_path):
    paths = synthetic_photo(tmp_path / "in")
    weights = tmp_path / "big-lama.pt"
    torch.jit.script(MidGrey()).save(str(weights))
    out = tmp_path / "out"
    cli("build", paths["photo"], "-o", out, "--mask", f"{paths['cup']}:cup", "--mask", f"{paths['box']}:box",
        "--inpainter", "lama", env=_env(PHYSOMNI_LAMA_WEIGHTS=str(weights)), check=True)
    photo = cv2.cvtColor(cv2.imread(str(paths["photo"])), cv2.COLOR_BGR2RGB)
    plate = cv2.cvtColor(cv2.imread(str(out / "textures" / "plate.png")), cv2.COLOR_BGR2RGB)
    masks = [cv2.imread(str(paths[k]), cv2.IMREAD_GRAYSCALE) > 0 for k in ("cup", "box")]
    where = hole(masks, photo.shape[:2], BuildSettings().plate_dilation)
    assert (plate[where] == 128).all()  # 0.5 → 128: the plugin's fill, which the built-in never gives everywhere
    assert (plate[~where] == photo[~where]).all()
    used = json.loads((out / "report.json").read_text())["stages"]["build"]["backends"]["inpainter"]
    assert used["name"] == "lama" and used["package"] == "physomni-lama" and used["weights"] == str(weights)


def test_missing_torch_names_the_extra(monkeypatch):
    import importlib.util

    import physomni_lama

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "torch" else real(name, *a))
    assert "pip install 'physomni-lama[models]'" in physomni_lama.LamaInpainter.missing()
