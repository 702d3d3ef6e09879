"""What a new user meets in the first hour: clicks that correct a box's mask, "did you mean" for a label
typo, and `render` refusing a shot that was never simulated."""

from __future__ import annotations

import numpy as np
import pytest

from physomni_usd.errors import InputError
from physomni_usd.perceive.masks import box_clicks, box_spec, mask_from_box, parse_box, read_photo

from .conftest import cli

BOX = (40, 60, 110, 140)  # around the synthetic photo's cup, reaching into the floor


def test_box_spec_round_trips_label_and_clicks():
    spec = box_spec(BOX, "tea cup", [(70, 100, True), (45, 135, False)])
    assert spec == "40,60,110,140:tea cup:+70,100:-45,135"
    assert parse_box(spec) == (BOX, "tea cup")
    assert box_clicks(spec) == [(70, 100, True), (45, 135, False)]
    assert parse_box("40,60,110,140") == (BOX, None) and box_clicks("40,60,110,140:cup") == []


def test_a_click_off_the_object_takes_its_pixels_out_and_one_on_it_keeps_them(photo):
    img = read_photo(photo["photo"])
    plain = mask_from_box(img, box_spec(BOX, "cup"), 0).mask
    inside = np.argwhere(plain)
    y, x = inside[len(inside) // 2]
    off = mask_from_box(img, box_spec(BOX, "cup", [(int(x), int(y), False)]), 0)
    assert not off.mask[y, x] and off.source.endswith(f":-{x},{y}")
    on = mask_from_box(img, box_spec(BOX, "cup", [(int(x), int(y), True)]), 0).mask
    assert on[y, x]
    with pytest.raises(InputError, match="not inside"):
        mask_from_box(img, box_spec(BOX, "cup", [(500, 10, True)]), 0)


def test_a_label_typo_is_answered_with_the_closest_label(tmp_path, photo):
    proc = cli("build", photo["photo"], "-o", tmp_path / "out", "--mask", f"{photo['cup']}:cup",
               "--push", "cpu=1,0,0")
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2 and len(errors) == 1
    assert "did you mean 'cup'?" in errors[0] and "--push" in errors[0]
    assert not (tmp_path / "out").exists()


def test_render_refuses_a_shot_never_simulated_unless_still_and_set_offers_the_label(tmp_path, photo):
    out = tmp_path / "shot"
    cli("build", photo["photo"], "-o", out, "--mask", f"{photo['cup']}:cup", "-q", check=True)
    proc = cli("render", out / "shot.usda", "--max-size", "64")
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2 and len(errors) == 1 and "never simulated" in errors[0] and "--still" in errors[0]
    assert not (out / "video.mp4").exists()
    cli("render", out / "shot.usda", "--max-size", "64", "--still", "-q", check=True)
    assert (out / "video.mp4").is_file()
    edits = (out / "edits.usda").read_bytes()
    proc = cli("estimate", out / "shot.usda", "--set", "cpu.density=800")  # the same shot: a typo in --set
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2 and len(errors) == 1 and "did you mean 'cup'?" in errors[0]
    assert (out / "edits.usda").read_bytes() == edits


def test_find_without_a_finder_plugin_names_it_before_any_work(monkeypatch):
    from physomni_usd.backends import finders, registry

    installed = registry.entries()
    monkeypatch.setattr(registry, "entries", lambda: [e for e in installed if e.kind != "finder"])
    with pytest.raises(InputError, match=r"--find 'cup, saucer' needs a text-promptable finder.*physomni-sam3"):
        finders.load_finder("cup, saucer", None)
    assert finders.parse_phrases(" cup,  tea   cup ,, cup") == ["cup", "tea cup"]
    assert finders.load_finder(None, None) is None


ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def test_readme_is_a_short_guide_whose_test_commands_ci_runs_verbatim():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) < 300
    ci = (ROOT / ".ci" / "run").read_text()
    commands = [ln for ln in readme.splitlines() if ln.startswith("pip install -e") and "pytest" in ln]
    assert len(commands) == 2 and all(c in ci for c in commands)
    assert "--index-url https://download.pytorch.org/whl/cpu" in readme
    for step in ("git clone", "python3 -m venv", "pip install -e . && bash examples/motorcycle/run.sh"):
        assert step in readme, step
    for doc in ("docs/reference.md", "docs/benchmarks.md"):
        assert (ROOT / doc).is_file() and doc in readme


def test_help_and_plugins_say_what_they_mean():
    assert "render.usda" in cli("--help", check=True).stdout
    out = cli("plugins", check=True).stdout
    vlm = next(ln for ln in out.splitlines() if ln.strip().startswith("vlm:"))
    assert "needs setting up: PHYSOMNI_VLM_URL" in vlm and "ready" not in vlm
    assert "finder:" in out
