"""``physomni-usd studio``: a real browser (Debian's chromium through Playwright) picks two objects on the
synthetic photo, labels them, corrects one with a click off it, pushes one, builds, drags an object in the
live preview and renders; the command line the page wrote, run again, builds the same scene."""

from __future__ import annotations

import base64
import json
import shlex
import signal
import subprocess
import sys
import threading
from contextlib import contextmanager

import cv2
import numpy as np
import pytest
from pxr import Usd

from physomni_usd.fields import parse_force_spec
from physomni_usd.studio import session

from .conftest import W, cli
from .test_preview import CHROMIUM, free_port

#: Photo pixels of the two boxes the test drags (around the cup and the box of the synthetic photo).
CUP_BOX = (40, 62, 102, 136)
BOX_BOX = (124, 68, 206, 146)
#: A click off the box object, inside its mask near a corner.
OFF_CLICK = (196, 136)


def test_every_force_preset_is_a_valid_force_option():
    for kind, spec in session.FORCE_PRESETS.items():
        assert parse_force_spec(spec).kind == kind


def test_commands_replay_boxes_clicks_and_pushes_and_name_a_shared_label_by_prim():
    state = session.empty_state("p.png", "shot")
    state["objects"] = [{"label": "cup", "box": [1, 2, 30, 40], "clicks": [[5, 6, False]]},
                        {"label": "cup", "box": [50, 2, 90, 40], "clicks": []}]
    state["pushes"] = [{"object": 1, "velocity": [0.5, 0, 0]}]
    state["camera"] = "orbit-left"
    build = session.commands(state)["build"]
    assert build[build.index("--box") + 1] == "1,2,30,40:cup:-5,6"
    assert build[build.index("--push") + 1] == "cup_1=0.5,0,0"  # the label is shared: the prim is named
    assert "--camera orbit-left" in session.command_text(state)


def test_the_video_length_is_the_page_s_field_else_the_shot_s_and_is_written_to_studio_sh(tmp_path):
    from physomni_usd.errors import InputError

    state = session.empty_state("p.png", tmp_path / "shot")
    assert session.render_seconds(state) == session.RENDER_SECONDS == 3.0  # no shot: what simulate takes
    state["seconds"] = session.check_seconds("1.5")
    assert "simulate" in session.command_text(state) and "--seconds 1.5" in session.command_text(state)
    assert session.check_seconds("") is None and session.check_seconds(None) is None
    for bad in ("nan", "0", "601", "-1", "soon"):
        with pytest.raises(InputError, match="video length"):
            session.check_seconds(bad)


def studio_port() -> int:
    """A free port whose next one exists too (the studio runs its preview there)."""
    port = free_port()
    while port + 1 > 65535:
        port = free_port()
    return port


@contextmanager
def studio_page(port: int, photo_width: int, viewport=(1400, 760)):
    """The studio's page at ``port`` in chromium, once it has drawn the photo: yields ``(browser, page, at,
    drag)``, ``at(x, y)`` the page's point over photo pixel (x, y) (``photo_width`` pixels wide) and
    ``drag(a, b)`` the mouse pressed from photo pixel ``a`` to ``b`` in five steps, as a hand draws."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"])
        page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
        page.goto(f"http://127.0.0.1:{port}/")
        page.wait_for_selector("body[data-ready='1']", timeout=30000)
        page.wait_for_function("() => document.getElementById('photo').width > 0")
        c = page.locator("#photo").bounding_box()
        scale = c["width"] / photo_width

        def at(x, y):
            return c["x"] + (x + 0.5) * scale, c["y"] + (y + 0.5) * scale

        def drag(a, b):
            page.mouse.move(*at(*a))
            page.mouse.down()
            for k in range(1, 6):
                page.mouse.move(*at(a[0] + (b[0] - a[0]) * k / 5, a[1] + (b[1] - a[1]) * k / 5))
            page.mouse.up()

        yield browser, page, at, drag


def _start(photo, out, port):
    proc = subprocess.Popen([sys.executable, "-m", "physomni_usd.cli", "studio", str(photo), "-o", str(out),
                             "--port", str(port), "--no-open", "--duration", "900"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    ready = threading.Event()

    def read():
        for line in proc.stderr:
            lines.append(line.rstrip("\n"))
            if line.startswith("studio: http://"):
                ready.set()
        ready.set()

    threading.Thread(target=read, daemon=True).start()
    if not ready.wait(120) or proc.poll() is not None:
        proc.kill()
        raise AssertionError("studio did not start:\n" + "\n".join(lines))
    return proc, lines


@contextmanager
def running_studio(photo, out):
    """The studio on ``photo`` writing ``out``, on a free port: yields ``(port, proc, lines)`` (``lines`` its
    stderr so far); ends it with Ctrl-C, killed if it has not ended, and a failure inside shows its stderr."""
    port = studio_port()
    proc, lines = _start(photo, out, port)
    try:
        yield port, proc, lines
        proc.send_signal(signal.SIGINT)
        proc.wait(120)
    except Exception as exc:
        raise AssertionError(f"{exc}\nstudio's stderr (exit {proc.poll()}):\n" + "\n".join(lines)) from exc
    finally:
        if proc.poll() is None:
            proc.kill()


def _decode(data_url: str) -> np.ndarray:
    png = base64.b64decode(data_url.split(",", 1)[1])
    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)[..., 3] > 0


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum()) / max(1, int((a | b).sum()))


@pytest.fixture(scope="module")
def studio_run(photo, tmp_path_factory):
    out = tmp_path_factory.mktemp("studio") / "shot"
    with running_studio(photo["photo"], out) as (port, proc, lines):
        result = {"out": out, "lines": lines}
        with studio_page(port, W, (1600, 720)) as (browser, page, at, drag):
            def mask_ready(i, clicks):
                page.wait_for_function(
                    f"() => studio.masks[{i}] && studio.masks[{i}].complete && studio.S.objects[{i}].spec"
                    f" && (studio.S.objects[{i}].spec.match(/:[+-]/g) || []).length === {clicks}", timeout=60000)

            for i, (box, label) in enumerate(((CUP_BOX, "cup"), (BOX_BOX, "box"))):
                drag(box[:2], box[2:])
                page.get_by_label(f"Label of object {i}").fill(label)
                mask_ready(i, 0)
            # a mask coming back rebuilds the list: whoever is typing a label keeps the field and the caret
            page.get_by_label("Label of object 0").focus()
            page.keyboard.press("End")
            page.evaluate("() => studio.list()")
            page.keyboard.insert_text(" mug")
            result["typed_through_rebuild"] = page.evaluate("() => studio.S.objects[0].label")
            page.get_by_label("Label of object 0").fill("cup")
            # a third object, moved up and deleted again: the list's order is the objects' numbers
            drag((36, 58), (106, 140))  # around the cup again
            page.get_by_label("Label of object 2").fill("spare")
            mask_ready(2, 0)
            labels = "() => studio.S.objects.map(o => o.label).join(',')"
            page.get_by_role("button", name="Up 2").click()
            result["reordered"] = page.evaluate(labels)
            page.get_by_role("button", name="Delete 1").click()
            result["deleted"] = page.evaluate(labels)
            result["before_click"] = _decode(page.evaluate("() => studio.masks[1].src"))
            page.get_by_label("Click off object (−)").check()
            page.mouse.click(*at(*OFF_CLICK))
            mask_ready(1, 1)
            page.get_by_label("Push arrow").check()
            drag((71, 100), (71 + W // 8, 100))  # 0.5 m/s to the right
            page.get_by_label("Camera move").select_option("orbit-left")
            result["page_masks"] = [_decode(page.evaluate(f"() => studio.masks[{i}].src")) for i in range(2)]
            page.get_by_role("button", name="Build").click()
            page.get_by_text("built 2 objects").wait_for(timeout=240000)
            result["shot_after_build"] = (out / "shot.usda").is_file()
            # a drag on the box in the live preview (inside the page), which opens paused: the drag plays it
            frame = page.frame_locator("#preview")
            frame.get_by_role("button", name="Play").wait_for(timeout=120000)
            page.wait_for_timeout(1500)
            canvas = frame.locator("canvas").first.bounding_box()
            from physomni_usd.preview.scene import photo_view
            from physomni_usd.usd import layers

            view, _ = photo_view(layers.open_shot(out))
            s = canvas["height"] / view.height
            left = canvas["x"] + canvas["width"] / 2 - view.width * s / 2
            x, y = left + 165 * s, canvas["y"] + 110 * s
            page.mouse.move(x, y)
            page.mouse.down()
            for k in range(1, 16):
                page.mouse.move(x + 8 * k, y)
                page.wait_for_timeout(60)
            page.mouse.up()
            page.wait_for_timeout(500)
            page.get_by_role("button", name="Render").click()
            page.get_by_text("rendered").wait_for(timeout=300000)
            result["video_src"] = page.evaluate("() => document.getElementById('video').src")
            browser.close()
    result["returncode"] = proc.returncode
    return result


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_build_from_the_page_has_the_objects_as_labelled(studio_run):
    out = studio_run["out"]
    assert studio_run["shot_after_build"]
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    objects = [p for p in stage.GetPrimAtPath("/World/Objects").GetChildren()]
    labels = {p.GetName(): p.GetAttribute("physomni:label").Get() for p in objects}
    assert labels == {"cup_0": "cup", "box_1": "box"}


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_typing_a_label_goes_on_while_the_list_is_rebuilt(studio_run):
    assert studio_run["typed_through_rebuild"] == "cup mug"


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_objects_reorder_and_delete_in_the_list(studio_run):
    assert studio_run["reordered"] == "cup,spare,box" and studio_run["deleted"] == "cup,box"


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_the_click_off_the_object_changed_its_mask(studio_run):
    before, after = studio_run["before_click"], studio_run["page_masks"][1]
    x, y = OFF_CLICK
    assert before[y, x] and not after[y, x]


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_masks_of_the_written_command_match_the_page_and_it_builds_the_same_scene(studio_run, tmp_path):
    out = studio_run["out"]
    state = json.loads((out / "studio.json").read_text())
    build = state["commands"]["build"]
    assert (out / "studio.sh").read_text().count("physomni-usd build") == 1
    assert shlex.split((out / "studio.sh").read_text().splitlines()[1])[1:] == build
    again = tmp_path / "again"
    build[build.index("-o") + 1] = str(again)
    cli(*build, "-q", check=True)
    for i, name in enumerate(("cup_0", "box_1")):
        cli_mask = cv2.imread(str(again / "inputs" / "masks" / f"{name}.png"), cv2.IMREAD_GRAYSCALE) > 0
        assert _iou(cli_mask, studio_run["page_masks"][i]) >= 0.95, name
        built = cv2.imread(str(out / "inputs" / "masks" / f"{name}.png"), cv2.IMREAD_GRAYSCALE) > 0
        assert (built == cli_mask).all(), name
    first, second = (json.loads((d / "report.json").read_text()) for d in (out, again))
    for a, b in zip(first["objects"], second["objects"]):
        assert (a["name"], a["label"], a.get("push")) == (b["name"], b["label"], b.get("push"))
        assert np.allclose(a["size_m"], b["size_m"]) and np.allclose(a["position_m"], b["position_m"])
    assert first["objects"][0]["push"]["velocity_m_s"][0] == pytest.approx(0.5, abs=0.05)


@pytest.mark.slow  # the page's whole flow: 60-100 s under load; test_studio_pushes drives the same page
def test_render_from_the_page_writes_the_video_with_the_chosen_move(studio_run):
    out = studio_run["out"]
    assert (out / "video.mp4").is_file() and studio_run["video_src"].endswith(".mp4?t=" +
                                                                            studio_run["video_src"].split("=")[-1])
    report = json.loads((out / "report.json").read_text())["stages"]["render"]
    assert report["frames"] >= 2 and "orbit-left" in json.dumps(report.get("camera"))
    assert (out / "render.usda").is_file()
    # the video is the stated length (the shot's default), not what the drag in the preview stepped
    assert any(ln == "studio: rendering 3 s (91 frames at 30 fps)" for ln in studio_run["lines"]), studio_run["lines"]
    assert report["frames"] == 91
    assert studio_run["returncode"] == 0, "\n".join(studio_run["lines"])


def test_bad_input_to_the_page_is_one_line_before_anything_starts(tmp_path, photo):
    proc = cli("studio", tmp_path / "nope.png", "-o", tmp_path / "shot", "--no-open", "--duration", "1")
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2 and len(errors) == 1 and "photo not found" in errors[0]
    proc = cli("preview", photo["photo"], "--no-open", "--duration", "1")
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2 and len(errors) == 1 and "-o" in errors[0] and "studio" in errors[0]
    assert not (tmp_path / "shot").exists()


def test_preview_of_a_photo_serves_the_set_up_page(tmp_path, photo):
    import urllib.request

    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "physomni_usd.cli", "preview", str(photo["photo"]), "-o",
                             str(tmp_path / "shot"), "--port", str(port), "--no-open", "--duration", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stderr.readline()
        while line and not line.startswith("studio: http://"):
            line = proc.stderr.readline()
        assert line.startswith(f"studio: http://127.0.0.1:{port}"), line
        info = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=30).read())
        assert (info["width"], info["height"]) == (W, 180) and info["segmenter"] == "grabcut"
        req = urllib.request.Request(f"http://127.0.0.1:{port}/api/mask", method="POST",
                                     data=json.dumps({"object": {"label": "cup", "box": [500, 0, 600, 50],
                                                                 "clicks": []}}).encode(),
                                     headers={"Content-Type": "application/json"})  # the page's POSTs are JSON
        try:
            urllib.request.urlopen(req, timeout=30)
            raise AssertionError("a box outside the photo was accepted")
        except urllib.error.HTTPError as exc:
            assert exc.code == 400 and "not inside" in json.loads(exc.read())["error"]
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert not (tmp_path / "shot").exists()  # nothing built, nothing written


@pytest.mark.slow
def test_a_first_build_says_it_compiles_the_kernels_while_it_does(tmp_path, photo):
    """In an empty kernel cache, the page's progress says the kernels are compiling before the build's answer
    comes, then how long they took; the page's preview then starts at once."""
    import os
    import time
    import urllib.request

    port = free_port()
    env = dict(os.environ, WARP_CACHE_PATH=str(tmp_path / "kernels"))
    proc = subprocess.Popen([sys.executable, "-m", "physomni_usd.cli", "studio", str(photo["photo"]), "-o",
                             str(tmp_path / "shot"), "--port", str(port), "--no-open", "--duration", "600"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    base = f"http://127.0.0.1:{port}"
    try:
        line = proc.stderr.readline()
        while line and not line.startswith("studio: http://"):
            line = proc.stderr.readline()
        answer = {}

        def build():
            body = {"objects": [{"label": "cup", "box": list(CUP_BOX), "clicks": []}], "pushes": []}
            req = urllib.request.Request(base + "/api/build", data=json.dumps(body).encode(), method="POST",
                                         headers={"Content-Type": "application/json"})
            answer["build"] = json.loads(urllib.request.urlopen(req, timeout=600).read())

        worker = threading.Thread(target=build)
        worker.start()
        heard_while_building = []
        while worker.is_alive():
            time.sleep(1)
            lines = json.loads(urllib.request.urlopen(base + "/api/progress?since=0", timeout=30).read())["lines"]
            if worker.is_alive():
                heard_while_building = lines
        worker.join()
        said = json.loads(urllib.request.urlopen(base + "/api/progress?since=0", timeout=30).read())["lines"]
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert "build" in answer, said
    assert "studio: compiling physics kernels, once per machine (a minute or two) ..." in heard_while_building
    assert any(ln.startswith("perceive:") for ln in heard_while_building)
    compiled = [ln for ln in said if ln.startswith("studio: physics kernels compiled in ")]
    assert len(compiled) == 1 and int(compiled[0].split(" in ")[1].split(" s")[0]) >= 1, said
