"""``physomni-usd batch``: a shot list on Ray, failures kept to their shot, resumable, local or on a cluster.

One local batch (two good shots, one with a missing photo, and one good shot's
Ray worker killed mid-shot) is shared by the first tests; a second pass over it
must skip; the same list then runs on a Ray head the test starts.
"""

from __future__ import annotations

import json
import os
import pathlib
import secrets
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time

import pytest

from .conftest import cli, synthetic_photo

SHOT_ARGS = "--seconds 0.3 --fps 10"
LIST = f"""# two good shots and one whose photo is missing
photos/photo.png -o out/cup --mask photos/cup.png:cup --mask photos/box.png:box --push box=0.6,0,0 {SHOT_ARGS}
'photos/photo.png' -o 'out/box' --mask photos/box.png:box {SHOT_ARGS}

photos/nothere.png -o out/missing --mask photos/box.png:box {SHOT_ARGS}
"""


def _write_list(folder: pathlib.Path) -> pathlib.Path:
    synthetic_photo(folder / "photos")
    path = folder / "shots.txt"
    path.write_text(LIST)
    return path


def _batch_argv(*args) -> list[str]:
    code = "import sys\nfrom physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n"
    return [sys.executable, "-c", code, "batch", *map(str, args)]


def _procs() -> dict[int, list[str]]:
    out = {}
    for entry in pathlib.Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                out[int(entry.name)] = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
            except OSError:
                pass
    return out


def _parent(pid: int) -> int:
    stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    return int(stat.rsplit(")", 1)[1].split()[1])


def _gone(pid: int) -> bool:
    try:
        return pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


def _kill_worker_mid_shot(output: str, log: pathlib.Path, batch: subprocess.Popen, timeout=300) -> dict:
    """SIGKILL the Ray worker running the shot whose ``-o`` is ``output``, once its build has finished."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout and batch.poll() is None:
        built = log.is_file() and "build: wrote" in log.read_text(errors="replace")
        shots = [pid for pid, argv in _procs().items()
                 if "run" in argv and "-o" in argv and argv[argv.index("-o") + 1] == output]
        if built and shots:
            worker = _parent(shots[0])
            os.kill(worker, signal.SIGKILL)
            t1 = time.monotonic()
            while not _gone(shots[0]) and time.monotonic() - t1 < 5:  # SIGKILL follows at once
                time.sleep(0.1)
            return {"worker": worker, "shot": shots[0], "shot_gone": _gone(shots[0])}
        time.sleep(0.2)
    return {}


@pytest.fixture(scope="module")
def first_pass(tmp_path_factory):
    folder = tmp_path_factory.mktemp("batch")
    shots = _write_list(folder)
    summary = folder / "summary.json"
    batch = subprocess.Popen(_batch_argv(shots, "--summary", summary), stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        killed = _kill_worker_mid_shot("out/box", folder / "out/box/batch.log", batch)
        stdout, stderr = batch.communicate(timeout=900)
    finally:
        if batch.poll() is None:
            batch.kill()
    return {"folder": folder, "shots": shots, "summary": summary, "code": batch.returncode, "stderr": stderr,
            "killed": killed}


def _entries(summary_path) -> dict[str, dict]:
    data = json.loads(pathlib.Path(summary_path).read_text())
    return {pathlib.Path(e["output"]).name: e for e in data["shots"]}


@pytest.mark.slow  # the first pass's batch with a killed worker: 180 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_failed_shot_fails_alone(first_pass):
    assert first_pass["code"] == 1, first_pass["stderr"]
    entries = _entries(first_pass["summary"])
    assert {k: e["status"] for k, e in entries.items()} == {"cup": "ok", "box": "ok", "missing": "failed"}
    assert "nothere.png" in entries["missing"]["reason"]
    assert entries["missing"]["failure"]["stage"] == "check" and entries["missing"]["failure"]["exit_code"] == 2
    assert "photos/nothere.png" in first_pass["stderr"]
    for name in ("cup", "box"):
        out = first_pass["folder"] / "out" / name
        assert (out / "video.mp4").stat().st_size > 0 and (out / "sim.usdc").stat().st_size > 0
        assert entries[name]["node"] and entries[name]["node_id"] and entries[name]["seconds"] > 0
    assert not (first_pass["folder"] / "out" / "missing").exists()  # nothing written for bad input


def test_a_failed_shot_tells_its_stage_type_and_exit_code(tmp_path):
    """The shot's process hands its failure to the task as data (not as a line in its log)."""
    synthetic_photo(tmp_path / "photos")
    shots = tmp_path / "shots.txt"
    shots.write_text("photos/photo.png -o out/absurd --mask photos/box.png:box --seconds 9999\n")
    summary = tmp_path / "summary.json"
    proc = subprocess.run(_batch_argv(shots, "--summary", summary, "--retries", "1"), capture_output=True,
                          text=True)
    assert proc.returncode == 1, proc.stderr
    entry = _entries(summary)["absurd"]
    assert entry["status"] == "failed" and entry["attempts"] == 1  # bad input: not retried
    assert entry["failure"] == {"message": entry["reason"], "exit_code": 2, "type": "ValidationError",
                                "stage": "check", "internal": False}
    assert entry["reason"].startswith("--seconds 9999")
    assert f"error: {entry['reason']}" in (tmp_path / "out/absurd/batch.log").read_text()


@pytest.mark.slow  # the first pass's batch: 180 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_killed_worker_is_retried_and_others_undisturbed(first_pass):
    killed = first_pass["killed"]
    assert killed, f"the shot's process was never found:\n{first_pass['stderr']}"
    assert killed["shot_gone"], "the shot's process outlived its killed Ray worker"
    entries = _entries(first_pass["summary"])
    assert entries["box"]["status"] == "ok" and entries["box"]["attempts"] == 2
    assert entries["cup"]["status"] == "ok" and entries["cup"]["attempts"] == 1
    log = (first_pass["folder"] / "out/box/batch.log").read_text()
    assert log.count("== attempt ") == 2 and "== attempt 2 " in log


@pytest.mark.slow  # the first pass's batch: 180 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_second_pass_skips_finished_shots(first_pass):
    folder = first_pass["folder"]
    watched = [folder / "out" / n / f for n in ("cup", "box") for f in ("sim.usdc", "video.mp4", "batch.log")]
    before = {p: p.stat().st_mtime_ns for p in watched}
    summary = folder / "summary2.json"
    proc = subprocess.run(_batch_argv(first_pass["shots"], "--summary", summary), capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr
    entries = _entries(summary)
    assert {k: e["status"] for k, e in entries.items()} == {"cup": "skipped", "box": "skipped", "missing": "failed"}
    assert all(e["attempts"] == 0 for e in entries.values())
    assert json.loads(summary.read_text())["ray"] is None  # nothing to run: Ray was not even started
    assert {p: p.stat().st_mtime_ns for p in watched} == before  # no simulation, render or attempt ran


@pytest.mark.slow  # the first pass's batch: 180 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_interrupted_or_changed_shot_is_not_finished(first_pass, tmp_path):
    from physomni_usd.batch.shots import inputs_hash, is_finished, mark_started, read_shot_list
    from physomni_usd.cli.cmd_run import parse_run
    from physomni_usd.report import update_report

    shots = read_shot_list(first_pass["shots"], parse_run)
    cup = shots[0]
    digest = inputs_hash(cup)
    assert is_finished(cup.output, digest)
    other = read_shot_list(_list_with(tmp_path, first_pass["shots"], "--push box=0.6,0,0", "--push box=0.7,0,0"),
                           parse_run)[0]
    assert inputs_hash(other) != digest  # an option changed
    copy = tmp_path / "copy"
    shutil.copytree(cup.output, copy)
    update_report(copy, simulate={"frames": 1})  # a later command re-simulated it
    assert not is_finished(copy, digest)
    shutil.rmtree(copy)
    shutil.copytree(cup.output, copy)
    mark_started(copy)  # a shot that started again and was interrupted
    assert not is_finished(copy, digest)


def _list_with(folder: pathlib.Path, shots: pathlib.Path, old: str, new: str) -> pathlib.Path:
    path = folder / "shots.txt"
    shutil.copytree(shots.parent / "photos", folder / "photos")
    path.write_text(shots.read_text().replace(old, new))
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow  # 65 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_same_list_on_a_ray_head(tmp_path):
    shots = _write_list(tmp_path)
    port = _free_port()
    # a throwaway head with its own token, so nothing of the user's ~/.ray is used or made
    env = dict(os.environ, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32))
    ray_cli = str(pathlib.Path(sys.executable).parent / "ray")
    head = subprocess.Popen([ray_cli if os.path.exists(ray_cli) else "ray", "start", "--head", "--port", str(port),
                             "--num-cpus", "2", "--node-ip-address", "127.0.0.1", "--include-dashboard=false",
                             "--disable-usage-stats", "--block"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        summary = tmp_path / "summary.json"
        proc = subprocess.run(_batch_argv(shots, "--address", f"127.0.0.1:{port}", "--summary", summary), env=env,
                              capture_output=True, text=True, timeout=900)
        head_node_ids = {argv_value(argv, "--node_id=") for pid, argv in _procs().items()
                         if _in_group(pid, head.pid) and any("raylet" in a for a in argv[:1])}
    finally:
        try:
            os.killpg(head.pid, signal.SIGTERM)
            head.wait(timeout=10)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
        try:
            os.killpg(head.pid, signal.SIGKILL)  # the head drains for 30 s on SIGTERM; a test need not wait
        except ProcessLookupError:
            pass
        head.wait()
    assert proc.returncode == 1, proc.stderr
    entries = _entries(summary)
    assert {k: e["status"] for k, e in entries.items()} == {"cup": "ok", "box": "ok", "missing": "failed"}
    assert json.loads(summary.read_text())["ray"] == f"127.0.0.1:{port}"
    for name in ("cup", "box"):
        assert (tmp_path / "out" / name / "video.mp4").is_file()
        assert entries[name]["node_id"] in head_node_ids and entries[name]["node"]


def argv_value(argv: list[str], prefix: str) -> str | None:
    return next((a[len(prefix):] for a in argv if a.startswith(prefix)), None)


def _in_group(pid: int, group: int) -> bool:
    try:
        return os.getpgid(pid) == group
    except OSError:
        return False


@pytest.mark.slow  # 91 s on a loaded 2-core machine; a quicker test runs batch through Ray
def test_upload_ships_inputs_and_outputs_through_ray(tmp_path):
    synthetic_photo(tmp_path / "photos")
    shots = tmp_path / "shots.txt"
    shots.write_text(f"photos/photo.png -o out/box --mask photos/box.png {SHOT_ARGS}\n")
    out = tmp_path / "out/box"
    out.mkdir(parents=True)
    mine = '#usda 1.0\n(\n    doc = "the artist\'s"\n)\n'
    (out / "edits.usda").write_text(mine)
    summary = tmp_path / "summary.json"
    proc = subprocess.run(_batch_argv(shots, "--upload", "--summary", summary), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert _entries(summary)["box"]["status"] == "ok"
    assert (out / "video.mp4").stat().st_size > 0 and (out / "sim.usdc").is_file()
    assert (out / "edits.usda").read_text() == mine
    log = (out / "batch.log").read_text()
    assert " --output out " in log and "in/mask0/box.png" in log  # it ran in the task's own folder
    report = json.loads((out / "report.json").read_text())
    assert report["objects"][0]["label"] == "box"  # the mask's file name still labels the object

    from physomni_usd.batch.shots import inputs_hash, is_finished, read_shot_list
    from physomni_usd.cli.cmd_run import parse_run

    assert is_finished(out, inputs_hash(read_shot_list(shots, parse_run)[0]))


def test_bad_shot_list_names_the_line(tmp_path):
    shots = _write_list(tmp_path)
    bad = tmp_path / "bad.txt"
    bad.write_text(LIST.replace("--mask photos/box.png:box --seconds", "--mask photos/box.png:box --bogus 1 --seconds"))
    proc = cli("batch", bad)
    assert proc.returncode == 2 and f"{bad}:3: No such option" in proc.stderr
    dup = tmp_path / "dup.txt"
    dup.write_text(shots.read_text() + "photos/photo.png -o out/./cup\n")
    proc = cli("batch", dup)
    assert proc.returncode == 2 and f"{dup}:6: output" in proc.stderr and "dup.txt:2" in proc.stderr
    assert not (tmp_path / "out").exists()  # nothing ran


def test_yaml_and_json_lists_read_like_text(tmp_path):
    from physomni_usd.batch.shots import read_shot_list
    from physomni_usd.cli.cmd_run import parse_run

    text = read_shot_list(_write_list(tmp_path), parse_run)
    (tmp_path / "shots.yaml").write_text(
        "# the same shots\n"
        "- photo: photos/photo.png\n  output: out/cup\n  mask: [photos/cup.png:cup, photos/box.png:box]\n"
        f"  push: box=0.6,0,0\n  seconds: 0.3\n  fps: 10\n"
        f"- photos/photo.png -o out/box --mask photos/box.png:box {SHOT_ARGS}\n"
        "- {photo: photos/nothere.png, o: out/missing, mask: photos/box.png:box, seconds: 0.3, fps: 10}\n")
    (tmp_path / "shots.json").write_text(json.dumps([shlex.join(s.args) for s in text]))
    from physomni_usd.batch.shots import inputs_hash

    for other in ("shots.yaml", "shots.json"):
        shots = read_shot_list(tmp_path / other, parse_run)
        assert [s.output for s in shots] == [s.output for s in text]
        assert [inputs_hash(s) for s in shots] == [inputs_hash(s) for s in text]
    assert read_shot_list(tmp_path / "shots.yaml", parse_run)[2].where.endswith("shots.yaml:9")
    (tmp_path / "bad.yaml").write_text("- photos/photo.png -o out/a\n- {photo: photos/photo.png}\n")
    proc = cli("batch", tmp_path / "bad.yaml")
    assert proc.returncode == 2 and "bad.yaml:2" in proc.stderr and "--output" in proc.stderr


def test_without_ray_names_the_extra(tmp_path):
    code = ("import sys\nsys.modules['ray'] = None  # as if Ray were not installed\n"
            "from physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n")
    proc = subprocess.run([sys.executable, "-c", code, "batch", _write_list(tmp_path)], capture_output=True,
                          text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == ["error: batch needs Ray: pip install 'physomni-usd[batch]'"]
