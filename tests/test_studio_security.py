"""Who may drive ``physomni-usd studio``: raw HTTP requests a hostile page, a rebound DNS name or a broken
client would send, each answered with one line and none of them building, rendering or returning the photo;
then a real browser (Debian's chromium through Playwright) on a page served from another local port, which
cannot make the studio build or render or read its photo, while the studio's own page still works.

The raw requests go to a studio in this process whose build and render are stand-ins that write
``studio.json`` as the real ones do: a request that got through shows as a call and as a changed file, in
milliseconds instead of a build's minutes. The studio's own request (the same body as JSON from its own
origin) is sent last in each test, so that a stand-in that never runs cannot pass a test.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import http.server
import json
import pathlib
import shutil
import signal
import socket
import threading
import time
import types

import pytest

from physomni_usd.preview.security import Guard
from physomni_usd.studio import Options, Studio, session

from .test_preview import CHROMIUM, free_port

#: The body the page sends to Build or Render: one object (the synthetic photo's cup), a camera move.
STATE = {"objects": [{"label": "cup", "box": [40, 62, 102, 136], "clicks": []}], "pushes": [], "force": None,
         "camera": "orbit-left"}
#: Longest wait for an answer: a server that reads a body it was told not to bound hangs here instead.
ANSWER_S = 15


def snapshot(folder: pathlib.Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def seed(photo, out: pathlib.Path) -> None:
    """What an artist left in the shot folder: the page's set-up (studio.json, studio.sh) and a video."""
    out.mkdir(parents=True, exist_ok=True)
    state = session.empty_state(photo, out)
    state["objects"] = [{"label": "mug", "box": [38, 60, 104, 138], "clicks": [[70, 100, True]]}]
    session.write_state(state)
    (out / "video.mp4").write_bytes(b"the artist's video")


@pytest.fixture
def studio(photo, tmp_path, monkeypatch):
    """``start(wide=False)`` → a running studio on a seeded folder; ``wide``: as if bound beyond loopback."""
    out = tmp_path / "shot"
    seed(photo["photo"], out)
    calls: list[str] = []

    def fake_build(state, *args, **kwargs):
        calls.append("build")
        session.write_state(state)  # as the real build does once it has built
        return types.SimpleNamespace(shot=out / "shot.usda", objects=[])

    def fake_render(state, *args, **kwargs):
        calls.append("render")
        session.write_state(state)
        return {"frames": 2}

    monkeypatch.setattr(session, "build", fake_build)
    monkeypatch.setattr(session, "render", fake_render)
    monkeypatch.setattr(Studio, "_start_preview", lambda self, shot, *first_use: None)
    started = []

    def start(wide: bool = False):
        said: list[str] = []
        s = Studio(photo["photo"], out, Options(port=free_port(), preview_port=free_port(), open_browser=False,
                                                echo=said.append))
        s.said = said
        if wide:  # the checks of a studio started with --host 10.0.0.5, on a loopback socket
            s.guard = Guard("10.0.0.5", "studio")
        s.start()
        started.append(s)
        s.calls, s.out, s.before = calls, out, snapshot(out)
        return s

    yield start
    for s in started:
        s.httpd.shutdown()
        s.httpd.server_close()
    errors = [line for s in started for line in s.said if "internal error" in line]
    assert not errors, errors  # a request that broke the handler, whatever the client was answered


def exchange(port: int, data: bytes) -> tuple[int, dict, bytes]:
    """Send ``data`` as it is and read the answer until the server closes; (status, headers, body)."""
    with socket.create_connection(("127.0.0.1", port), timeout=ANSWER_S) as s:
        s.sendall(data)
        answer, deadline = b"", time.monotonic() + ANSWER_S
        while time.monotonic() < deadline and len(answer) < 1 << 26:
            try:
                chunk = s.recv(1 << 16)
            except socket.timeout:
                raise AssertionError(f"no answer within {ANSWER_S} s to {data[:200]!r}") from None
            if not chunk:
                break
            answer += chunk
    head, _, body = answer.partition(b"\r\n\r\n")
    if not head:
        raise AssertionError(f"the server closed without an answer to {data[:200]!r}")
    lines = head.decode("latin-1").split("\r\n")
    headers = {k.strip().lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:])}
    return int(lines[0].split()[1]), headers, body


def request(port: int, method: str, path: str, body: bytes | None = None, host: str | None = None,
            length: str | None = "auto", **headers) -> tuple[int, dict, bytes]:
    """One request; ``host`` defaults to the studio's own, ``length`` to the body's (None: no header)."""
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host if host is not None else f'127.0.0.1:{port}'}"]
    if length == "auto":
        length = None if body is None else str(len(body))
    if length is not None:
        lines.append(f"Content-Length: {length}")
    lines += [f"{k.replace('_', '-')}: {v}" for k, v in headers.items()]
    return exchange(port, ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + (body or b""))


def own_post(s, path: str, body=STATE) -> tuple[int, dict, bytes]:
    port = s.httpd.server_address[1]
    return request(port, "POST", path, json.dumps(body).encode(), Content_Type="application/json",
                   Origin=f"http://127.0.0.1:{port}")


def one_line_error(status: int, body: bytes) -> str | None:
    """Why ``body`` is not a one-line JSON error, or None."""
    try:
        error = json.loads(body)["error"]
    except (ValueError, KeyError, TypeError):
        return f"{status}: not a JSON error: {body[:200]!r}"
    if body.count(b"\n") > 1 or "\n" in error or "Traceback" in error or not error:
        return f"{status}: not one line: {body[:300]!r}"
    return None


def check(rows) -> None:
    """``rows``: (what was sent, status, expected status, body); one assertion listing every wrong row."""
    wrong = []
    for what, status, expected, body in rows:
        why = one_line_error(status, body) if expected >= 400 else None
        if status != expected or why:
            wrong.append(f"{what}: {status} (expected {expected}) {why or body[:200]!r}")
    assert not wrong, "\n".join(wrong)


def test_a_post_from_another_origin_is_refused_and_changes_nothing(studio):
    s = studio()
    port = s.httpd.server_address[1]
    body = json.dumps(STATE).encode()
    rows = []
    for path, kind, origin in (("/api/build", "text/plain;charset=UTF-8", "http://evil.example"),
                               ("/api/render", "application/x-www-form-urlencoded", f"http://127.0.0.1:{port + 7}"),
                               ("/api/build", "application/json", "http://evil.example"),
                               ("/api/render", "application/json", "null"),
                               ("/api/mask", "application/json", f"http://localhost:{port}")):
        status, _, answer = request(port, "POST", path, body, Content_Type=kind, Origin=origin)
        rows.append((f"POST {path} {kind} from {origin}", status, 403, answer))
    check(rows)
    assert s.calls == [] and snapshot(s.out) == s.before
    status, _, answer = own_post(s, "/api/build")
    assert status == 200 and s.calls == ["build"], answer


def test_only_json_changes_anything_even_from_its_own_origin(studio):
    s = studio()
    port = s.httpd.server_address[1]
    body = json.dumps(STATE).encode()
    rows = []
    for kind in ("text/plain", "multipart/form-data; boundary=x", "application/jsonp", "text/plain; application/json",
                 None):
        headers = {"Content_Type": kind} if kind else {}
        for origin in (f"http://127.0.0.1:{port}", None):  # a page of its own origin, a local client
            extra = dict(headers, **({"Origin": origin} if origin else {}))
            status, _, answer = request(port, "POST", "/api/build", body, **extra)
            rows.append((f"POST /api/build as {kind} from {origin}", status, 400, answer))
    check(rows)
    assert s.calls == [] and snapshot(s.out) == s.before
    status, _, answer = request(port, "POST", "/api/render", body, Content_Type="Application/JSON; charset=utf-8")
    assert status == 200 and s.calls == ["render"], answer


def test_a_foreign_host_or_another_sites_page_reads_nothing(studio):
    """DNS rebinding: a name of the attacker's, rebound to 127.0.0.1, makes the studio the page's own origin."""
    s = studio()
    port = s.httpd.server_address[1]
    rows = []
    for path in ("/", "/api/info", "/photo.png", "/video.mp4"):
        for host in (f"evil.example:{port}", f"127.0.0.1.evil.example:{port}", ""):
            status, _, answer = request(port, "GET", path, host=host)
            rows.append((f"GET {path} Host {host!r}", status, 403, answer))
        # another site's page embedding the photo (<img src>): the browser says so in Sec-Fetch-Site
        status, _, answer = request(port, "GET", path, Sec_Fetch_Site="same-site", Sec_Fetch_Mode="no-cors")
        rows.append((f"GET {path} from another site's page", status, 403, answer))
    check(rows)
    assert not any(b"PNG" in body or str(s.out).encode() in body for *_, body in rows)
    for path in ("/", "/api/info", "/photo.png", "/video.mp4"):
        for host in (f"127.0.0.1:{port}", f"localhost:{port}"):
            status, _, answer = request(port, "GET", path, host=host, Sec_Fetch_Site="same-origin")
            assert status == 200, (path, host, answer[:200])
    assert snapshot(s.out) == s.before


def test_a_body_length_that_cannot_be_read_is_one_line_and_nothing_is_read_beyond_it(studio, capfd):
    s = studio()
    port = s.httpd.server_address[1]
    body = json.dumps(STATE).encode()
    origin = {"Content_Type": "application/json", "Origin": f"http://127.0.0.1:{port}"}
    rows = []
    # each left open after the body: a server that reads to the end of the stream never answers
    for length, expected in (("-1", 400), ("abc", 400), ("1e3", 400), (f"+{len(body)}", 400), (None, 400),
                             (str(10 ** 12), 413)):
        status, _, answer = request(port, "POST", "/api/build", body, length=length, **origin)
        rows.append((f"Content-Length {length}", status, expected, answer))
    status, _, answer = request(port, "POST", "/api/build", f"{len(body):x}\r\n".encode() + body + b"\r\n0\r\n\r\n",
                                length=None, Transfer_Encoding="chunked", **origin)
    rows.append(("Transfer-Encoding chunked", status, 400, answer))
    check(rows)
    assert s.calls == [] and snapshot(s.out) == s.before
    assert "Traceback" not in capfd.readouterr().err
    assert own_post(s, "/api/build")[0] == 200 and s.calls == ["build"]


BAD_BODIES = [b'{"force": 123}', b'{"camera": 5}', b'{"objects": "cup"}', b'{"objects": [5]}',
              b'{"objects": [{"label": "cup", "box": "1,2,3,4"}]}',
              b'{"objects": [{"label": 7, "box": [40, 62, 102, 136]}]}',
              b'{"objects": [{"label": "cup", "box": [40, 62, 102, 136], "clicks": [7]}]}',
              b'{"objects": [{"label": "cup", "box": [40, 62, 102, 136]}], "pushes": [{"object": "x", '
              b'"velocity": [1, 0, 0]}]}',
              b'{"objects": [{"label": "cup", "box": [40, 62, 102, 136]}], "pushes": [{"object": 0, '
              b'"velocity": [NaN, 0, 0]}]}',
              b'{"objects": [{"label": "cup", "box": [40, 62, 102, Infinity]}]}',
              b'{"objects": [{"label": "cup", "box": [40, 62, 102, 136]}], "pushes": [{"object": 0, '
              b'"velocity": [1e999, 0, 0]}]}',
              b'[]', b'"build"', b'null', b'{"force": "wind:strength=5"', b'[' * 100000 + b']' * 100000,
              b'{"camera": "\xff"}']


def test_a_value_of_the_wrong_kind_is_one_line_400(studio, capfd):
    s = studio()
    rows = []
    for path in ("/api/build", "/api/render"):
        for body in BAD_BODIES:
            port = s.httpd.server_address[1]
            status, _, answer = request(port, "POST", path, body, Content_Type="application/json",
                                        Origin=f"http://127.0.0.1:{port}")
            rows.append((f"POST {path} {body[:70]!r}", status, 400, answer))
    for obj in (5, "cup", {"box": [1, 2]}, {"label": "cup", "box": [40, 62, 102, 136], "clicks": [[1, 2]]}):
        status, _, answer = own_post(s, "/api/mask", {"object": obj})
        rows.append((f"POST /api/mask object {obj}", status, 400, answer))
    status, _, answer = own_post(s, "/api/mask", {"object": STATE["objects"][0], "index": "first"})
    rows.append(("POST /api/mask index 'first'", status, 400, answer))
    check(rows)
    assert s.calls == [] and snapshot(s.out) == s.before
    assert "Traceback" not in capfd.readouterr().err


def test_beyond_loopback_every_request_needs_the_studios_token(studio, capfd):
    s = studio(wide=True)
    port, token = s.httpd.server_address[1], s.guard.token
    host = f"10.0.0.5:{port}"
    rows = []
    for path, headers in (("/api/info", {}), ("/photo.png", {}), (f"/?token={token[:-1]}", {}), ("/?token=%C3%A9", {}),
                          ("/api/info", {"Cookie": f"physomni_studio={token}x"}),
                          ("/api/info", {"Cookie": "physomni_studio=\u00e9"}),
                          ("/api/info", {"Cookie": f"physomni_preview={token}"})):  # the preview's cookie is not it
        status, _, answer = request(port, "GET", path, host=host, **headers)
        rows.append((f"GET {path} {headers}", status, 403, answer))
    status, _, answer = request(port, "POST", "/api/build", json.dumps(STATE).encode(), host=host,
                                Content_Type="application/json", Origin=f"http://{host}")
    rows.append(("POST /api/build without the token", status, 403, answer))
    check(rows)
    assert s.calls == [] and "Traceback" not in capfd.readouterr().err
    status, headers, _ = request(port, "GET", f"/?token={token}", host=host)
    assert status == 200 and headers.get("set-cookie", "").startswith(f"physomni_studio={token};")
    assert "SameSite=Strict" in headers["set-cookie"] and "HttpOnly" in headers["set-cookie"]
    cookie = {"Cookie": f"physomni_preview=other; physomni_studio={token}"}
    # a preview running (as after Build): the page is sent to it by the name it used, with the preview's token
    s.preview, s.preview_query = object(), "token=theirs"
    status, _, answer = request(port, "GET", "/api/info", host=host, **cookie)
    assert status == 200 and json.loads(answer)["preview"] == f"http://10.0.0.5:{s.preview_port}/?token=theirs"
    s.preview = None
    status, _, answer = request(port, "POST", "/api/build", json.dumps(STATE).encode(), host=host,
                                Content_Type="application/json", Origin=f"http://{host}", **cookie)
    assert status == 200 and s.calls == ["build"], answer


def test_other_methods_and_preflights_are_one_line_and_the_page_is_not_framed(studio):
    s = studio()
    port = s.httpd.server_address[1]
    rows = []
    for method in ("PUT", "DELETE", "PATCH", "HEAD"):
        status, _, answer = request(port, method, "/api/build", b"{}", Content_Type="application/json")
        rows.append((method, status, 405, answer if method != "HEAD" else b'{"error": "x"}'))
    status, _, answer = request(port, "OPTIONS", "/api/build", Origin="http://evil.example",
                                Access_Control_Request_Method="POST", Access_Control_Request_Headers="content-type")
    rows.append(("OPTIONS preflight from evil.example", status, 403, answer))
    status, _, answer = exchange(port, b"GET / HTTP/1.1\r\n" + b"X-A: b\r\n" * 101 + b"\r\n")
    rows.append(("101 headers", status, 431, answer))
    check(rows)
    status, headers, _ = request(port, "GET", "/")
    assert status == 200 and headers.get("x-frame-options") == "DENY"
    assert "frame-ancestors 'none'" in headers.get("content-security-policy", "")
    assert s.calls == [] and snapshot(s.out) == s.before


def test_the_guard_refuses_what_a_client_makes_up_instead_of_raising():
    local, wide = Guard("127.0.0.1", "studio"), Guard("10.0.0.5", "studio")
    assert "loopback" in local.refusal({"Host": "[::1"}, "/")  # urlsplit raises on an unclosed [
    assert "another origin than the studio's" in local.refusal({"Host": "127.0.0.1:1", "Origin": "http://[x"}, "/")
    assert wide.refusal({"Host": "10.0.0.5:1"}, "/?token=%C3%A9")  # compare_digest raises on non-ASCII str
    assert wide.refusal({"Host": "10.0.0.5:1", "Cookie": "physomni_studio=\u00e9"}, "/")
    assert wide.refusal({"Host": "10.0.0.5:1", "Cookie": f"physomni_preview={wide.token}"}, "/")
    assert wide.refusal({"Host": "10.0.0.5:1", "Cookie": f"physomni_studio={wide.token}"}, "/") is None


# --- a real browser -----------------------------------------------------------------------------------------------
HOSTILE_PAGE = """<!doctype html><title>a page on another port</title>
<iframe name="sink"></iframe>
<script>
const S = "http://127.0.0.1:%(port)d", body = JSON.stringify(%(state)s);
const results = window.results = {};
async function attempt(name, f) {
  try { const r = await f(); results[name] = r.type === "opaque" ? "sent (answer hidden)" : "answered " + r.status; }
  catch (e) { results[name] = "failed: " + e.name; }
}
function formPost(path, enctype) {  // a plain HTML form, the oldest way to post across sites
  return new Promise((done) => {
    const f = document.createElement("form");
    f.method = "POST"; f.action = S + path; f.enctype = enctype; f.target = "sink";
    const i = document.createElement("input");  // text/plain sends name=value: a JSON-looking body
    i.name = body.slice(0, -1) + ', "x": "'; i.value = '"}'; f.appendChild(i); document.body.appendChild(f);
    document.querySelector("iframe").onload = () => done();
    f.submit();
    setTimeout(done, 5000);
  });
}
(async () => {
  await attempt("fetch text/plain build", () => fetch(S + "/api/build",
    { method: "POST", mode: "no-cors", headers: { "Content-Type": "text/plain" }, body }));
  await attempt("fetch text/plain render", () => fetch(S + "/api/render",
    { method: "POST", mode: "no-cors", headers: { "Content-Type": "text/plain" }, body }));
  await attempt("fetch JSON build", () => fetch(S + "/api/build",
    { method: "POST", headers: { "Content-Type": "application/json" }, body }));
  await attempt("read photo", async () => { const r = await fetch(S + "/photo.png"); await r.blob(); return r; });
  await attempt("read info", async () => { const r = await fetch(S + "/api/info"); await r.json(); return r; });
  results["photo image"] = await new Promise((done) => {
    const img = new Image(); img.onload = () => done("loaded"); img.onerror = () => done("not loaded");
    img.src = S + "/photo.png";
  });
  await formPost("/api/build", "text/plain");
  await formPost("/api/render", "application/x-www-form-urlencoded");
  results.done = true;
})();
</script>"""


@contextlib.contextmanager
def page_server(folder: pathlib.Path):
    """A tiny static site on another loopback port: the hostile page's origin."""
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(folder)))
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        yield httpd.server_address[1]
    finally:
        httpd.shutdown()
        httpd.server_close()


def test_a_page_on_another_port_cannot_drive_the_studio_and_its_own_page_still_works(shot, tmp_path):
    from playwright.sync_api import sync_playwright

    from .test_studio import _start

    out = tmp_path / "shot"  # a finished shot (built, simulated, rendered) with the artist's set-up beside it
    shutil.copytree(shot["dir"], out)
    seed(shot["photo"], out)
    (out / "video.mp4").write_bytes((shot["dir"] / "video.mp4").read_bytes())
    before = snapshot(out)
    port = free_port()
    proc, lines = _start(shot["photo"], out, port)
    site = tmp_path / "site"
    site.mkdir()
    (site / "index.html").write_text(HOSTILE_PAGE % {"port": port, "state": json.dumps(STATE)})
    try:
        with page_server(site) as other, sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=[
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox",
                "--host-resolver-rules=MAP rebound.test 127.0.0.1"])  # a DNS name rebound to this machine
            page = browser.new_page()
            page.goto(f"http://127.0.0.1:{other}/index.html")
            page.wait_for_function("() => window.results && window.results.done", timeout=60000)
            hostile = page.evaluate("() => window.results")
            # DNS rebinding: the attacker's name now points here, so the studio is the page's own origin
            rebound = page.goto(f"http://rebound.test:{port}/").status
            rebound_reads = page.evaluate("""async () => Promise.all(["/photo.png", "/api/info", "/video.mp4"].map(
                async (u) => (await fetch(u)).status))""")
            time.sleep(3)  # a build or render a request started would have written by now (a build writes at once)
            after = snapshot(out)
            # the studio's own page: loads, shows the photo, cuts a mask through its JSON API
            own = browser.new_page()
            own.goto(f"http://127.0.0.1:{port}/")
            own.wait_for_selector("body[data-ready='1']", timeout=30000)
            own.wait_for_function("() => document.getElementById('photo').width > 0", timeout=30000)
            mask = own.evaluate("""async (box) => { const r = await fetch("/api/mask", { method: "POST",
                headers: { "Content-Type": "application/json" },
                body: JSON.stringify({ object: { label: "cup", box, clicks: [] } }) });
                return [r.status, (await r.json()).pixels]; }""", STATE["objects"][0]["box"])
            browser.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(120)
    said = "\n".join(lines)
    assert after == before, ("the hostile page changed the shot folder", hostile, said)
    assert "studio: physomni-usd build" not in said and "studio: rendering" not in said, said
    assert hostile["read photo"].startswith("failed") and hostile["read info"].startswith("failed"), hostile
    assert hostile["photo image"] == "not loaded", hostile
    assert rebound == 403 and rebound_reads == [403, 403, 403], (rebound, rebound_reads)
    assert mask[0] == 200 and mask[1] > 500, mask
    assert snapshot(out) == before and proc.returncode == 0, said
