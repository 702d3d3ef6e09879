"""rerender hands the rendered frames and their control passes to the re-renderer; --model's default."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Usd

from physomni_usd.swappable import registry
from physomni_usd.rerender import rerender_shot
from physomni_usd.cli import main
from physomni_usd.errors import InputError

SEEN = {}


class PassesRerenderer:
    """Records what it was given and returns the frames darkened (a re-renderer that takes the passes)."""

    kind, name = "rerenderer", "fake-passes"

    @classmethod
    def missing(cls):
        return None

    @classmethod
    def weights(cls):
        return None

    def rerender(self, frames, masks, reference, *, prompt, strength, steps, seed, passes=None):
        SEEN.update(frames=frames, masks=masks, passes=passes, reference=reference)
        return frames // 2


class OldRerenderer(PassesRerenderer):
    """A re-renderer written before the passes: no ``passes`` keyword."""

    name = "fake-old"

    def rerender(self, frames, masks, reference, *, prompt, strength, steps, seed):
        SEEN.update(frames=frames, masks=masks, passes="never given")
        return frames


def installed(monkeypatch, *classes):
    """Make the registry list the built-ins and these re-renderers (and no other)."""
    builtins = [e for e in registry.entries() if e.builtin]
    fakes = [registry.Entry("rerenderer", c.name, f"{__name__}:{c.__name__}", "fake", "0") for c in classes]
    monkeypatch.setattr(registry, "entries", lambda: builtins + fakes)


@pytest.fixture()
def short_shot(shot, tmp_path):
    """A copy of the shared shot cut to its first 4 frames."""
    d = tmp_path / "shot"
    shutil.copytree(shot["dir"], d)
    stage = Usd.Stage.Open(str(d / "shot.usda"))
    stage.SetEndTimeCode(stage.GetStartTimeCode() + 3)
    stage.GetRootLayer().Save()
    return d


def test_the_passes_reach_the_rerenderer_and_the_report_records_the_run(monkeypatch, short_shot):
    installed(monkeypatch, PassesRerenderer)
    SEEN.clear()
    section = rerender_shot(short_shot / "shot.usda", None, strength=0.4, steps=3, max_size=96)
    frames, masks, passes = SEEN["frames"], SEEN["masks"], SEEN["passes"]
    t, h, w = frames.shape[:3]
    assert t == 4 and passes.depth.shape == (t, h, w) and passes.motion.shape == (t, h, w, 2)
    assert np.isfinite(passes.depth).all() and set(np.unique(passes.object_id)) == {0, 1, 2}
    assert np.array_equal(masks, passes.object_id > 0)
    box = passes.object_id[0] == 2
    assert np.abs(passes.motion[0][box]).max() > 0.1  # the pushed box moves
    report = json.loads((short_shot / "report.json").read_text())["stages"]["rerender"]
    assert report["model"] == "fake-passes" and report["strength"] == 0.4 and report["steps"] == 3
    assert report["passes"] == ["depth", "objectId", "motion"] and report["seconds"]["model"] >= 0
    assert section["video"].endswith("rerender.mp4") and (short_shot / "rerender.mp4").stat().st_size > 0


def test_a_rerenderer_without_the_passes_keyword_still_runs(monkeypatch, short_shot):
    installed(monkeypatch, OldRerenderer)
    SEEN.clear()
    rerender_shot(short_shot / "shot.usda", "fake-old", max_size=64)
    assert SEEN["passes"] == "never given" and SEEN["masks"].any()
    assert json.loads((short_shot / "report.json").read_text())["stages"]["rerender"]["passes"] == []


def test_several_rerenderers_need_model(monkeypatch, short_shot):
    installed(monkeypatch, PassesRerenderer, OldRerenderer)
    with pytest.raises(InputError, match="--model: several re-renderers are installed"):
        rerender_shot(short_shot / "shot.usda", None, max_size=64)


def test_no_rerenderer_installed_is_one_line_naming_the_plugin(monkeypatch, short_shot):
    installed(monkeypatch)
    result = CliRunner().invoke(main, ["rerender", str(short_shot / "shot.usda")])
    assert result.exit_code == 2
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "physomni-wan" in lines[0], result.output
    assert not (short_shot / "rerender.mp4").exists()
