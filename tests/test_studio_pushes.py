"""The studio does what the artist drew and makes the video the page promised: in a real browser (Debian's
chromium through Playwright), a ball whose box lies inside a crate's box gets the push drawn from it; the push
is removed alone and drawn again; the preview opens paused; Render makes the length the page shows; and the
commands the page wrote, run again, make the same objects, push, frames and final positions."""

from __future__ import annotations

import json
import shlex

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
from pxr import Usd, UsdGeom

from .conftest import cli
from .test_studio import running_studio, studio_page

W, H = 240, 180
#: The crate's box holds the ball's box: an arrow started on the ball is the ball's.
CRATE_BOX = (52, 38, 196, 158)
BALL_BOX = (82, 108, 122, 150)
BALL_CENTRE = (102, 128)
LENGTH_S = 1.0  # typed into the page's length field: a short video keeps the test quick


def crate_and_ball(folder) -> object:
    """A wall-and-floor photo: a brown crate and, in front of it, a small red ball."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    img = np.zeros((H, W, 3), np.float32)
    img[:70] = np.linspace(150, 190, 70)[:, None, None] * np.array([0.9, 0.95, 1.0])
    img[70:] = np.linspace(120, 80, H - 70)[:, None, None] * np.array([1.0, 0.85, 0.7])
    img += rng.normal(0, 4, (H, W, 1))
    crate = np.zeros((H, W), np.uint8)
    cv2.rectangle(crate, (60, 45), (188, 150), 1, -1)
    img[crate > 0] = np.array([120, 80, 40]) + rng.normal(0, 5, (int(crate.sum()), 1))
    ball = np.zeros((H, W), np.uint8)
    cv2.circle(ball, BALL_CENTRE, 17, 1, -1)
    img[ball > 0] = np.array([220, 40, 40])
    path = folder / "photo.png"
    cv2.imwrite(str(path), cv2.cvtColor(np.clip(img, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    return path


def final_positions(folder) -> dict:
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    cache = UsdGeom.XformCache(stage.GetEndTimeCode())
    return {p.GetName(): np.array(cache.GetLocalToWorldTransform(p).ExtractTranslation())
            for p in stage.GetPrimAtPath("/World/Objects").GetChildren()}


def draw_ball_and_crate(page, drag) -> None:
    """Box the ball first, then the crate around it (so the last box holding a ball pixel is the crate's),
    label each and wait for its mask."""
    for i, (box, label) in enumerate(((BALL_BOX, "ball"), (CRATE_BOX, "crate"))):
        drag(box[:2], box[2:])
        page.get_by_label(f"Label of object {i}").fill(label)
        page.wait_for_function(f"() => studio.masks[{i}] && studio.masks[{i}].bits", timeout=60000)


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    photo = crate_and_ball(tmp_path_factory.mktemp("photo"))
    out = tmp_path_factory.mktemp("studio") / "shot"
    with running_studio(photo, out) as (port, proc, lines):
        result = {"out": out, "lines": lines}
        with studio_page(port, W, (1400, 760)) as (browser, page, at, drag):
            draw_ball_and_crate(page, drag)
            page.get_by_label("Push arrow").check()
            arrow = (BALL_CENTRE, (BALL_CENTRE[0] + W // 8, BALL_CENTRE[1]))  # 0.5 m/s to the right
            drag(*arrow)
            pushes = "() => studio.S.pushes.map(p => [p.object, ...p.velocity])"
            result["pushed"] = page.evaluate(pushes)
            result["in_list"] = page.get_by_label("Push 0 x").input_value()
            page.get_by_role("button", name="Remove push 0").click()
            result["after_remove"] = (page.evaluate(pushes), page.evaluate("() => studio.S.objects.length"))
            drag(*arrow)  # drawn again, then edited in the list: the edited value is what is built
            page.get_by_label("Push 0 y").fill("0.1")
            page.get_by_label("Push 0 y").dispatch_event("change")
            result["pushes"] = page.evaluate(pushes)
            result["default_seconds"] = page.get_by_label("Video length in seconds").input_value()
            page.screenshot(path=str(out.parent / "page_drawn.png"))
            # every status the page shows while it works, as it shows it
            page.evaluate("""() => { window.seen = []; new MutationObserver(() =>
                window.seen.push(document.getElementById('status').textContent)).observe(
                document.getElementById('status'), {childList: true, characterData: true, subtree: true}); }""")
            page.get_by_role("button", name="Build").click()
            page.get_by_text("built 2 objects").wait_for(timeout=300000)
            result["log_after_build"] = page.locator("#log").inner_text()
            frame = page.frame_locator("#preview")
            # the embedded preview opens as `preview` does: paused on frame 0, its button offers Play
            frame.get_by_role("button", name="Play").wait_for(timeout=120000)
            page.wait_for_timeout(2000)
            result["still_paused"] = frame.get_by_role("button", name="Play").count() == 1
            page.get_by_label("Video length in seconds").fill(str(LENGTH_S))
            page.get_by_label("Video length in seconds").dispatch_event("input")
            result["length_text"] = page.locator("#length").inner_text()
            page.get_by_role("button", name="Render").click()
            page.get_by_text("rendered").wait_for(timeout=300000)
            result["log_after_render"] = page.locator("#log").inner_text()
            result["seen"] = page.evaluate("() => window.seen")
            result["status"] = page.locator("#status").inner_text()
            page.screenshot(path=str(out.parent / "page_rendered.png"))
            browser.close()
    result["returncode"] = proc.returncode
    return result


@pytest.fixture(scope="module")
def replayed(drawn, tmp_path_factory):
    """studio.sh run again, line by line, into another folder."""
    out = drawn["out"]
    again = tmp_path_factory.mktemp("again") / "shot"
    for line in (out / "studio.sh").read_text().splitlines():
        if line.startswith("physomni-usd "):
            args = [again.as_posix() + a[len(out.as_posix()):] if a.startswith(out.as_posix()) else a
                    for a in shlex.split(line)[1:]]
            cli(*args, "-q", check=True)
    return again


def test_an_arrow_started_on_the_ball_inside_the_crate_s_box_pushes_the_ball(drawn):
    assert drawn["pushed"] == [[0, 0.5, 0, 0]]
    assert float(drawn["in_list"]) == 0.5  # shown on the ball's own entry in the list
    assert drawn["after_remove"] == ([], 2)  # the push went, both objects stayed
    assert drawn["pushes"] == [[0, 0.5, 0.1, 0]]


def test_studio_sh_builds_the_same_objects_with_the_same_push(drawn, replayed):
    first, second = (json.loads((d / "report.json").read_text()) for d in (drawn["out"], replayed))
    names = [(o["name"], o["label"]) for o in first["objects"]]
    assert names == [("ball_0", "ball"), ("crate_1", "crate")]
    assert names == [(o["name"], o["label"]) for o in second["objects"]]
    pushes = [o.get("push") for o in first["objects"]]
    assert pushes[1] is None and pushes[0]["velocity_m_s"] == pytest.approx([0.5, 0.1, 0], abs=1e-6)
    assert pushes == [o.get("push") for o in second["objects"]]


def test_the_preview_opens_paused_and_render_makes_the_length_the_page_shows(drawn):
    assert drawn["still_paused"]
    assert drawn["default_seconds"] == "3"  # never simulated: the length simulate would take
    fps = json.loads((drawn["out"] / "report.json").read_text())["stages"]["simulate"]["fps"]
    frames = int(round(LENGTH_S * fps)) + 1
    assert drawn["length_text"] == f"= {frames} frames at {fps:g} fps"
    reader = imageio.get_reader(str(drawn["out"] / "video.mp4"))
    assert reader.count_frames() == frames
    reader.close()
    assert f"rendered {frames} frames" in drawn["status"]


def test_the_page_shows_each_stage_and_frame_as_it_happens(drawn):
    build, render = drawn["log_after_build"], drawn["log_after_render"]
    assert "perceive:" in build and "build: wrote" in build
    assert "simulate: frame" in render and "render: frame" in render
    frames = [int(x) for x in __import__("re").findall(r"render: frame (\d+)/", render)]
    assert len(frames) >= 3 and frames == sorted(frames)
    # and while it works, the status line says the stage or frame of the moment
    seen = drawn["seen"]
    assert any(s.startswith("Build: perceive:") for s in seen), seen
    assert any(__import__("re").match(r"Render: (simulate|render): frame \d+/\d+$", s) for s in seen), seen


def test_the_video_is_the_one_studio_sh_makes(drawn, replayed):
    page, again = (json.loads((d / "report.json").read_text())["stages"] for d in (drawn["out"], replayed))
    assert page["render"]["frames"] == again["render"]["frames"] == page["simulate"]["frames"]
    ours, theirs = final_positions(drawn["out"]), final_positions(replayed)
    assert set(ours) == set(theirs) == {"ball_0", "crate_1"}
    moved = np.linalg.norm(ours["ball_0"] - final_positions_at_start(drawn["out"])["ball_0"])
    assert moved > 0.01  # the push acted
    for name in ours:
        assert np.allclose(ours[name], theirs[name], atol=1e-4), (name, ours[name], theirs[name])
    assert drawn["returncode"] == 0


def final_positions_at_start(folder) -> dict:
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    cache = UsdGeom.XformCache(stage.GetStartTimeCode())
    return {p.GetName(): np.array(cache.GetLocalToWorldTransform(p).ExtractTranslation())
            for p in stage.GetPrimAtPath("/World/Objects").GetChildren()}
