"""``physomni_usd.run()``: the three stages of ``physomni-usd run`` in the public API, and the structured
failure ``batch`` gets from it (stage, exception type, message, exit code) instead of a log line."""

from __future__ import annotations

import json

import pytest

import physomni_usd
from physomni_usd.batch.child import attempt
from physomni_usd.cli.cmd_run import run_arguments
from physomni_usd.errors import InputError
from physomni_usd.settings import BuildSettings, SimulateSettings


def test_run_chains_the_stages_and_says_each(tmp_path, photo):
    seen, frames = [], {}
    out = physomni_usd.run(photo["photo"], tmp_path / "shot", masks=[f"{photo['box']}:box"],
                           settings=BuildSettings(fps=10), simulate_settings=SimulateSettings(seconds=0.2),
                           on_stage=lambda stage, result: seen.append((stage, result is not None)),
                           progress=lambda stage, done, total: frames.__setitem__(stage, (done, total)))
    assert [s for s, _ in seen] == ["check", "check", "build", "build", "simulate", "simulate", "render", "render"]
    assert [ended for _, ended in seen] == [False, True] * 4
    assert frames["simulate"][0] == frames["simulate"][1] and frames["render"][0] == frames["render"][1]
    folder = tmp_path / "shot"
    assert out["build"].shot == folder / "shot.usda" and out["render"]["video"] == str(folder / "video.mp4")
    report = json.loads((folder / "report.json").read_text())
    stages = report["stages"]
    assert stages["run"]["total_seconds"] == out["total_seconds"] > 0
    assert out["simulate"]["frames"] == stages["simulate"]["frames"] == 3  # 0.2 s at 10 fps, frame 0 too


def test_run_checks_every_option_before_any_work(tmp_path, photo):
    with pytest.raises(InputError, match="--camera-amount"):
        physomni_usd.run(photo["photo"], tmp_path / "out", masks=[str(photo["box"])], camera="orbit-left",
                         camera_amount=9.0)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, stage, kind, code, says", [
    (["--seconds", "9999"], "check", "ValidationError", 2, "--seconds 9999"),
    (["--mask", "nothere.png:cup"], "build", "InputError", 2, "nothere.png"),
])
def test_a_shot_that_fails_tells_its_stage_type_message_and_code(tmp_path, photo, args, stage, kind, code, says):
    lines = []
    base = [str(photo["photo"]), "-o", str(tmp_path / "out")]
    failure, exit_code = attempt(run_arguments, base + args, lines.append)
    assert failure["stage"] == stage and failure["type"] == kind and failure["exit_code"] == exit_code == code
    assert says in failure["message"] and f"error: {failure['message']}" in lines
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("failing", ["simulate", "render"])
def test_a_run_that_fails_after_build_keeps_the_shot_and_says_which_stage_and_why(tmp_path, photo, monkeypatch,
                                                                                    failing):
    from physomni_usd.errors import PhysOmniError

    def fail(*args, **kwargs):
        raise PhysOmniError("simulation diverged at frame 3: the energy grew", exit_code=1)

    monkeypatch.setattr(physomni_usd, failing, fail)
    folder = tmp_path / "shot"
    with pytest.raises(PhysOmniError) as caught:
        physomni_usd.run(photo["photo"], folder, masks=[f"{photo['box']}:box"], settings=BuildSettings(fps=10),
                         simulate_settings=SimulateSettings(seconds=0.2))
    said = str(caught.value)
    assert said.startswith(f"{failing} failed: simulation diverged at frame 3") and str(folder) in said
    assert "\n" not in said and caught.value.exit_code == 1
    for name in ("shot.usda", "scene.usda", "physics.usda", "edits.usda", "report.json"):
        assert (folder / name).is_file(), name
    report = json.loads((folder / "report.json").read_text())
    failed = report["stages"]["run"]["failed"]
    assert failed["stage"] == failing and failed["message"].startswith("simulation diverged at frame 3")
    assert failed["exit_code"] == 1 and "build" in report["stages"]
    assert not (folder / "video.mp4").exists()
