"""`estimate`: rules on the bundled examples, --set into edits.usda, and a VLM over real HTTP on localhost."""

from __future__ import annotations

import base64
import json
import shutil
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest
from pxr import Sdf, Usd

from physomni_usd.validate import validate_stage

from .conftest import cli, copy_of


def _report(folder):
    return json.loads((folder / "report.json").read_text())


@pytest.mark.parametrize("example", ["motorcycle", "rocket"])
def test_rules_give_the_bundled_examples_plausible_materials(tmp_path, example, built_case):
    """The example built from its masks (a copy of the session's build, tests/conftest.py), then estimated."""
    result = copy_of(built_case(f"example:{example}")[0], tmp_path / "shot")
    cli("estimate", result.shot, "-q", check=True)
    materials = _report(result.folder)["stages"]["estimate"]["objects"]
    assert len(materials) == 3
    for name, m in materials.items():
        assert m["material"] == "rigid", name  # vehicles, furniture, bins, towers: solid things
        assert 50 <= m["params"]["density"]["value"] <= 3000
        assert 0.2 <= m["params"]["static_friction"]["value"] <= 1.0
        assert all(v["source"] == "rules" for v in m["params"].values())


USER_EDITS = """#usda 1.0
(
    doc = "my notes"
)

over "World"
{
    over "Objects"
    {
        over "cup_0"
        {
            float physics:density = 900
            custom string studio:note = "hero prop"
        }
    }
}
"""


def _shot_copy(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    return folder


def test_set_adds_to_edits_without_losing_what_the_user_wrote(tmp_path, shot):
    folder = _shot_copy(tmp_path, shot)
    (folder / "edits.usda").write_text(USER_EDITS)
    cli("estimate", folder / "shot.usda", "-q", "--set", "box.friction=0.3", "--set", "cup.restitution=0.5",
        check=True)
    layer = Sdf.Layer.OpenAsAnonymous(str(folder / "edits.usda"))
    assert layer.documentation == "my notes"
    assert layer.GetAttributeAtPath("/World/Objects/cup_0.physics:density").default == 900
    assert layer.GetAttributeAtPath("/World/Objects/cup_0.studio:note").default == "hero prop"
    fr = layer.GetAttributeAtPath("/World/Materials/Physics/box_1.physics:staticFriction")
    assert fr.default == pytest.approx(0.3) and fr.customData["physomni"]["source"] == "user"
    report = _report(folder)["stages"]["estimate"]["objects"]
    assert report["box_1"]["params"]["dynamic_friction"] == {"value": pytest.approx(0.3), "source": "user"}
    assert report["box_1"]["params"]["density"]["source"] == "rules"
    # a second --set keeps the first
    cli("estimate", folder / "shot.usda", "-q", "--set", "box.density=300", check=True)
    layer = Sdf.Layer.OpenAsAnonymous(str(folder / "edits.usda"))
    assert layer.GetAttributeAtPath("/World/Materials/Physics/box_1.physics:staticFriction").default == \
        pytest.approx(0.3)
    assert layer.GetAttributeAtPath("/World/Objects/cup_0.studio:note").default == "hero prop"


@pytest.mark.parametrize("spec, needle", [
    ("ghost.density=3", "no object named"),
    ("cup.poissons_ratio=0.5", "poissons_ratio must be in [0, 0.5)"),
    ("cup.density=-1", "density must be in"),
    ("cup.material=plasma", "unknown material"),
    ("cup.colour=3", "unknown parameter"),
    ("cup=3", "expected NAME.KEY=VALUE"),
])
def test_bad_set_is_refused_and_edits_untouched(tmp_path, shot, spec, needle):
    folder = _shot_copy(tmp_path, shot)
    (folder / "edits.usda").write_text(USER_EDITS)
    proc = cli("estimate", folder / "shot.usda", "--set", spec)
    assert proc.returncode == 2 and needle in proc.stderr, proc.stderr
    assert (folder / "edits.usda").read_text() == USER_EDITS


def test_estimate_keeps_pushes_and_user_fields(tmp_path, shot):
    folder = tmp_path / "shot"
    cli("build", shot["photo"], "-o", folder, "--mask", f"{shot['box']}:box", "--push", "box=1,0,0",
        "--force", "wind:strength=2", "-q", check=True)
    cli("estimate", folder / "shot.usda", "-q", "--force", "drag:linear_drag=0.5", check=True)
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    assert tuple(stage.GetPrimAtPath("/World/Objects/box_0").GetAttribute("physics:velocity").Get()) == (1, 0, 0)
    kinds = sorted(p.GetAttribute("physomni:kind").Get() for p in stage.GetPrimAtPath("/World/ForceFields").GetChildren())
    assert kinds == ["drag", "wind"]


# --- a VLM over HTTP --------------------------------------------------------------------------------

VALID_REPLY = json.dumps({"objects": [
    {"index": 0, "name": "ceramic cup", "material": "rigid", "material_params": {"rho": 800, "mu": 0.4},
     "fixed": False, "surface_color": [0.8, 0.2, 0.2]},
    {"index": 1, "name": "blue box", "material": "rigid", "material_params": {"rho": 150}, "fixed": "true"}],
    "forces": [{"type": "wind", "direction": [1, 0, 0], "strength": 2.0, "start_frame": -1}]})
REPLIES = {
    "valid": VALID_REPLY,
    "fenced": "Here is the configuration:\n```json\n" + VALID_REPLY + "\n```\nLet me know.",
    "legacy": json.dumps([{"index": 0, "material": "rigid"}, {"index": 1, "material": "rigid"}]),
    "wrong_types": json.dumps({"objects": [
        {"index": "0", "material": "rigid", "material_params": {"rho": "1.2e3", "friction": "0.5"}, "fixed": "false"},
        {"index": 1, "material": "rigid", "material_params": {"rho": [1, 2], "nu": "lots"}, "fixed": "maybe"}],
        "forces": [{"type": "wind", "strength": "3", "direction": "1,0,0"}, {"type": "gravity-ish"}]}),
    "garbage": "As an AI model I cannot see images.",
}


class _Server:
    def __init__(self):
        self.requests = []
        self.mode = "valid"
        self.delay = 0.0
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_POST(self):  # noqa: N802
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                outer.requests.append({"path": self.path, "auth": self.headers.get("Authorization"), "body": body})
                time.sleep(outer.delay)
                reply = {"id": "x", "object": "chat.completion", "choices": [
                    {"index": 0, "message": {"role": "assistant", "content": REPLIES[outer.mode]},
                     "finish_reason": "stop"}]}
                data = json.dumps(reply).encode()
                try:
                    self.send_response(200)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture(scope="module")
def vlm_server():
    server = _Server()
    yield server
    server.close()


def _vlm(folder, server, *extra):
    return cli("estimate", folder / "shot.usda", "--estimator", "vlm", "--vlm-url", server.url,
               "--vlm-model", "test-vl", "--vlm-api-key", "sekret", *extra)


@pytest.mark.parametrize("mode", sorted(REPLIES))
def test_vlm_replies_give_a_valid_stage(tmp_path, shot, vlm_server, mode):
    folder = _shot_copy(tmp_path, shot)
    vlm_server.mode, vlm_server.delay = mode, 0.0
    vlm_server.requests.clear()
    proc = _vlm(folder, vlm_server)
    assert proc.returncode == 0, proc.stderr
    assert [f for f in validate_stage(folder / "shot.usda") if f.severity == "error"] == []
    request = vlm_server.requests[-1]
    assert request["path"] == "/v1/chat/completions" and request["auth"] == "Bearer sekret"
    parts = request["body"]["messages"][1]["content"]
    images = [p["image_url"]["url"] for p in parts if p["type"] == "image_url"]
    assert len(images) == 3 and all(u.startswith("data:image/png;base64,") for u in images)
    base64.b64decode(images[1].split(",", 1)[1])
    materials = _report(folder)["stages"]["estimate"]["objects"]
    if mode in ("valid", "fenced"):
        assert materials["cup_0"]["params"]["density"] == {"value": 800, "source": "vlm"}
        assert materials["box_1"]["fixed"] is True
    if mode == "wrong_types":
        assert materials["cup_0"]["params"]["density"]["value"] == 1200
        assert materials["box_1"]["fixed"] is False
    if mode == "garbage":
        assert {m["material"] for m in materials.values()} == {"mpm_elastic"}


def test_slow_vlm_times_out_with_one_line(tmp_path, shot, vlm_server):
    folder = _shot_copy(tmp_path, shot)
    before = (folder / "physics.usda").read_bytes()
    vlm_server.mode, vlm_server.delay = "valid", 3.0
    try:
        proc = _vlm(folder, vlm_server, "--vlm-timeout", "1")
    finally:
        vlm_server.delay = 0.0
    assert proc.returncode == 1 and "no answer within 1 s" in proc.stderr and "Traceback" not in proc.stderr
    assert (folder / "physics.usda").read_bytes() == before


def test_unreachable_vlm_says_so(tmp_path, shot):
    folder = _shot_copy(tmp_path, shot)
    proc = cli("estimate", folder / "shot.usda", "--estimator", "vlm", "--vlm-url", "http://127.0.0.1:9/v1",
               "--vlm-model", "m")
    assert proc.returncode == 1 and "cannot reach it" in proc.stderr


def test_vlm_needs_a_url(tmp_path, shot):
    folder = _shot_copy(tmp_path, shot)
    env = {k: v for k, v in __import__("os").environ.items() if not k.startswith("PHYSOMNI_VLM")}
    proc = cli("estimate", folder / "shot.usda", "--estimator", "vlm", env=env)
    assert proc.returncode == 2 and "--vlm-url" in proc.stderr


def test_slow_vlm_within_the_timeout_is_waited_for(tmp_path, shot, vlm_server):
    folder = _shot_copy(tmp_path, shot)
    vlm_server.mode, vlm_server.delay = "valid", 1.5
    try:
        proc = _vlm(folder, vlm_server, "--vlm-timeout", "10")
    finally:
        vlm_server.delay = 0.0
    assert proc.returncode == 0, proc.stderr
    assert [f for f in validate_stage(folder / "shot.usda") if f.severity == "error"] == []
    assert _report(folder)["stages"]["estimate"]["objects"]["cup_0"]["params"]["density"]["source"] == "vlm"


def test_set_on_a_shot_with_no_photo_writes_edits_and_keeps_physics(tmp_path):
    """A shot assembled by a script (no inputs/photo.png) has nothing to estimate from; --set alone needs no
    estimate, so it is applied and physics.usda is kept byte for byte. Without --set, or with --force (which
    an estimate writes), the command says which file is missing and what still works."""
    from physomni_usd.bench.scenes import boxes_at_rest, write_bench_shot

    shot = write_bench_shot(tmp_path, boxes_at_rest(2))
    physics = (tmp_path / "physics.usda").read_bytes()
    edits = (tmp_path / "edits.usda").read_bytes()
    for extra in ([], ["--set", "box_0.density=800", "--force", "wind:strength=2"]):
        proc = cli("estimate", shot, "-q", *extra)
        line = proc.stderr.strip().splitlines()[0]
        assert proc.returncode == 2, proc.stderr
        assert "inputs/photo.png is missing" in line and "--set" in line, line
        assert (tmp_path / "edits.usda").read_bytes() == edits
    proc = cli("estimate", shot, "--set", "box_0.density=800")
    assert proc.returncode == 0, proc.stderr
    assert "only --set applied" in proc.stderr
    assert (tmp_path / "physics.usda").read_bytes() == physics
    report = _report(tmp_path)["stages"]["estimate"]
    assert report["estimated"] is False and report["set"] == ["box_0.density = 800.0"]
    assert report["objects"]["box_0"]["params"]["density"]["value"] == 800
    assert report["objects"]["box_1"]["params"]["density"]["value"] != 800


def test_an_unreadable_photo_in_the_shot_is_one_line_and_writes_nothing(tmp_path):
    from physomni_usd.bench.scenes import boxes_at_rest, write_bench_shot

    shot = write_bench_shot(tmp_path, boxes_at_rest(2))
    (tmp_path / "inputs").mkdir()
    (tmp_path / "inputs" / "photo.png").write_bytes(b"not a png")
    physics, edits = (tmp_path / "physics.usda").read_bytes(), (tmp_path / "edits.usda").read_bytes()
    proc = cli("estimate", shot, "-q", "--set", "box_0.density=800")
    assert proc.returncode == 2, proc.stderr
    lines = [l for l in proc.stderr.splitlines() if l.startswith("error:")]
    assert len(lines) == 1 and "inputs/photo.png cannot be read as an image" in lines[0], proc.stderr
    assert (tmp_path / "physics.usda").read_bytes() == physics and (tmp_path / "edits.usda").read_bytes() == edits
