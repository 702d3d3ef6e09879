"""The studio renders the take the artist kept: in a real browser (Debian's chromium through Playwright), a
take saved in the embedded preview is what Render makes (its frames, its sim.usdc, nothing simulated again),
the page says so before and after, studio.sh says that the take cannot be replayed by commands and runs no
simulate over it, and a change of pushes or a Build drops the take, the page saying so."""

from __future__ import annotations

import re
import types

import imageio.v2 as imageio
import pytest
from pxr import Sdf

from physomni_usd.studio import Options, Studio, session

from .test_preview import free_port
from .test_studio import running_studio, studio_page
from .test_studio_pushes import BALL_CENTRE, W, crate_and_ball, draw_ball_and_crate

PLAY_S = 1.0  # wall seconds the preview plays before the take is saved: far fewer frames than the 3 s field's


def test_studio_sh_with_a_kept_take_renders_it_and_runs_nothing_that_would_write_over_it(tmp_path):
    state = session.empty_state(tmp_path / "p.png", tmp_path / "shot")
    state["objects"] = [{"label": "ball", "box": [1, 2, 30, 40], "clicks": []}]
    state["pushes"] = [{"object": 0, "velocity": [0.5, 0, 0]}]
    text = session.command_text(state, {"frames": 12, "seconds": 11 / 30})
    run = [line for line in text.splitlines() if not line.startswith("#")]
    assert run == [f"physomni-usd render {tmp_path}/shot/shot.usda --camera static"]  # build would empty sim.usdc
    assert "cannot be replayed by commands" in text and "12 frames" in text
    assert f"# physomni-usd build {tmp_path}/p.png -o {tmp_path}/shot --box 1,2,30,40:ball --push ball=0.5,0,0" in text
    assert "simulate" not in session.commands(state, {"frames": 12, "seconds": 0.4})
    assert f"physomni-usd simulate {tmp_path}/shot/shot.usda --seconds 3" in session.command_text(state)  # no take


@pytest.fixture(scope="module")
def kept(tmp_path_factory):
    photo = crate_and_ball(tmp_path_factory.mktemp("photo"))
    out = tmp_path_factory.mktemp("studio") / "shot"
    with running_studio(photo, out) as (port, proc, lines):
        result = {"out": out, "lines": lines}
        with studio_page(port, W, (1400, 760)) as (browser, page, at, drag):
            draw_ball_and_crate(page, drag)
            page.get_by_label("Push arrow").check()
            drag(BALL_CENTRE, (BALL_CENTRE[0] + W // 8, BALL_CENTRE[1]))
            page.get_by_role("button", name="Build").click()
            page.get_by_text("built 2 objects").wait_for(timeout=300000)
            result["plan_built"] = page.locator("#plan").inner_text()
            frame = page.frame_locator("#preview")
            frame.get_by_role("button", name="Play").click(timeout=120000)
            page.wait_for_timeout(PLAY_S * 1000)
            frame.get_by_role("button", name="Pause").click(timeout=10000)
            frame.get_by_role("button", name="Save take").click(timeout=10000)
            page.get_by_text("Render: the kept take").wait_for(timeout=30000)
            result["plan_kept"] = page.locator("#plan").inner_text()
            page.get_by_role("button", name="Render").click()
            page.get_by_text("rendered").wait_for(timeout=300000)
            result["status_rendered"] = page.locator("#status").inner_text()
            result["log_rendered"] = page.locator("#log").inner_text()
            result["studio_sh"] = (out / "studio.sh").read_text()
            sim = Sdf.Layer.OpenAsAnonymous(str(out / "sim.usdc"))
            result["sim"] = (dict(sim.customLayerData), sim.endTimeCode)
            reader = imageio.get_reader(str(out / "video.mp4"))
            result["video_frames"] = reader.count_frames()
            reader.close()
            # the push edited after the take: the take no longer matches, the page says it goes
            page.get_by_label("Push 0 y").fill("0.2")
            page.get_by_label("Push 0 y").dispatch_event("change")
            result["plan_pushed"] = page.locator("#plan").inner_text()
            page.get_by_label("Push 0 y").fill("0")  # back as it was: the take is Render's again
            page.get_by_label("Push 0 y").dispatch_event("change")
            result["plan_back"] = page.locator("#plan").inner_text()
            page.get_by_role("button", name="Build").click()  # a Build after the Render drops the take
            page.get_by_text("built 2 objects").wait_for(timeout=300000)
            result["status_rebuilt"] = page.locator("#status").inner_text()
            result["plan_rebuilt"] = page.locator("#plan").inner_text()
            browser.close()
    result["returncode"] = proc.returncode
    return result


def test_render_makes_the_kept_take_and_the_page_says_so(kept):
    assert kept["plan_built"].startswith("Render: simulates 3 s")
    frames = int(re.fullmatch(r"Render: the kept take, (\d+) frames \([\d.]+ s\)", kept["plan_kept"]).group(1))
    assert 2 <= frames < 91  # a second of play, not the 3 s field's 91 frames
    assert kept["video_frames"] == frames
    assert f"rendered {frames} frames" in kept["status_rendered"] and "take kept in the preview" in kept["status_rendered"]
    meta, end = kept["sim"]
    assert meta.get("physomni:source") == "preview" and end == frames - 1  # the take's sim.usdc, not simulate's
    assert "simulate: frame" not in kept["log_rendered"] and "render: frame" in kept["log_rendered"]
    assert kept["returncode"] == 0


def test_studio_sh_says_the_take_cannot_be_replayed_and_simulates_nothing_over_it(kept):
    text = kept["studio_sh"]
    run = [line for line in text.splitlines() if not line.startswith("#")]
    assert len(run) == 1 and run[0].startswith("physomni-usd render ")
    assert "cannot be replayed by commands" in text and f"({kept['video_frames']} frames" in text


def test_a_change_of_pushes_or_a_build_drops_the_take_and_the_page_says_so(kept):
    assert "dropped" in kept["plan_pushed"] and kept["plan_pushed"].startswith("Render: simulates")
    assert kept["plan_back"].startswith("Render: the kept take")
    assert f"the kept take ({kept['video_frames']} frames) was dropped" in kept["status_rebuilt"]
    assert kept["plan_rebuilt"].startswith("Render: simulates")


def test_the_server_renders_a_kept_take_until_changed_pushes_or_a_build_drop_it(photo, tmp_path, monkeypatch):
    """The studio's own decisions, with build and render stood in for: a take saved in the preview is what
    Render gets, changed pushes make Render simulate, a Build drops the take; each drop is said."""
    out = tmp_path / "shot"
    out.mkdir()
    rendered = []

    def fake_build(state, *args, **kwargs):
        session.write_state(state)
        return types.SimpleNamespace(shot=out / "shot.usda", objects=[])

    def fake_render(state, *args, take=None, **kwargs):
        rendered.append(take)
        session.write_state(state, take)
        return {"frames": take["frames"] if take else 91}

    monkeypatch.setattr(session, "build", fake_build)
    monkeypatch.setattr(session, "render", fake_render)
    monkeypatch.setattr(session, "take_on_disk", lambda state, take: None)  # sim.usdc as the preview wrote it
    monkeypatch.setattr(Studio, "_start_preview", lambda self, shot, *first_use: None)
    said: list[str] = []
    s = Studio(photo["photo"], out, Options(port=free_port(), preview_port=free_port(), open_browser=False,
                                            echo=said.append))
    body = {"objects": [{"label": "ball", "box": [38, 60, 104, 138], "clicks": []}],
            "pushes": [{"object": 0, "velocity": [0.5, 0, 0]}]}
    s.build(body)
    s.preview = types.SimpleNamespace(kept={"frames": 7, "seconds": 0.2})  # Save take pressed in the preview
    assert s.take_info()["take"]["frames"] == 7
    s.preview = None  # as Render stops it
    r = s.render(body)
    assert rendered[-1]["frames"] == 7 and r["take"]["frames"] == 7 and r["length"]["frames"] == 7
    assert r["dropped"] is None
    assert not [x for x in r["command"].splitlines() if x.startswith("physomni-usd simulate")]
    pushed = dict(body, pushes=[{"object": 0, "velocity": [0.5, 0.2, 0]}])
    r = s.render(pushed)
    assert rendered[-1] is None and r["take"] is None and "pushes changed" in r["dropped"]
    assert any("physomni-usd simulate" in x for x in r["command"].splitlines())
    s.take = {"frames": 7, "seconds": 0.2, "pushes": session.push_key(body["pushes"])}
    r = s.build(body)
    assert "was dropped" in r["dropped"] and s.take_info()["take"] is None
    assert any("the kept take (7 frames) was dropped" in line for line in said)


def test_a_port_whose_server_closed_its_connections_is_free_again_and_a_listened_one_is_not():
    """A Build after a Render starts the preview again on its port, which the stopped preview's closed
    connections hold in TIME_WAIT for a minute: that is free; a port a program listens on is not."""
    import socket

    from physomni_usd.errors import InputError
    from physomni_usd.preview.app import check_port

    server = socket.socket()
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as viser's own server does
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    client = socket.create_connection(("127.0.0.1", port))
    accepted, _ = server.accept()
    with pytest.raises(InputError, match="another program holds it"):
        check_port("127.0.0.1", port)
    accepted.close()  # the server's side closes first, as a stopped preview's does: TIME_WAIT
    server.close()
    client.close()
    check_port("127.0.0.1", port)
