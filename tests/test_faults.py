"""The reliability matrix (issue: faults, hostile input and a shared farm): each case of
``physomni_usd.bench.faults`` on the session's finished shot, every trial clean. ``bench faults`` runs the
same cases and prints them as a table."""

from __future__ import annotations

import os

import pytest

from physomni_usd.bench import faults


@pytest.fixture(scope="module")
def base(shot):
    return {"dir": shot["dir"], "photo": shot["photo"], "labels": ("cup", "box"),
            "masks": [f"{shot['cup']}:cup", f"{shot['box']}:box"],
            "run": ["--push", "box=0.6,0,0", "--seconds", "1.5", "--fps", "20", "--camera-height", "1"]}


#: Rows not clean yet, each with why: the test holds them to failing, so that a fix is noticed.
KNOWN: dict[str, str] = {}


#: The cases of 25 s or more on a loaded 2-core machine (preview origin 60 s, full disk 38 s, terminated re-run
#: 33 s, secrets 26 s, terminated new folder 24 s): the quicker cases cover the same commands.
SLOW = {"preview origin", "full disk", "terminated re-run", "secrets", "terminated new folder"}


def _marks(name: str) -> list:
    return ([pytest.mark.xfail(reason=KNOWN[name], strict=True)] if name in KNOWN else []) \
        + ([pytest.mark.slow] if name in SLOW else [])


#: Run trial by trial in test_preview_keep_safety.py.
ELSEWHERE = {"preview keep"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=_marks(n)) for n in faults.CASES if n not in ELSEWHERE])
def test_fault_is_handled_cleanly(name, base, tmp_path):
    trials = faults.CASES[name](base, tmp_path)
    if not trials:
        pytest.skip(f"{name}: not possible here (a tmpfs mount and chattr need root)")
    assert all(ok for ok, _ in trials), "\n".join(f"{'ok' if ok else 'NOT'} {d}" for ok, d in trials)


def test_redact_hides_url_credentials():
    from physomni_usd.errors import PhysOmniError, redact

    assert redact("at http://me:pw@host:1/v1 and https://tok@x/") == "at http://***@host:1/v1 and https://***@x/"
    assert "pw" not in str(PhysOmniError("VLM server at http://me:pw@h/v1 refused"))


def test_preview_guard_rules():
    from physomni_usd.preview.security import Guard, clamp

    local = Guard("127.0.0.1")
    assert local.token is None
    assert local.refusal({"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"}, "/") is None
    assert local.refusal({"Host": "127.0.0.1:8080", "Origin": "http://evil.example"}, "/")
    assert local.refusal({"Host": "evil.example:8080", "Origin": "http://evil.example:8080"}, "/")
    wide = Guard("0.0.0.0")
    assert wide.token and wide.url(8080).endswith(f"?token={wide.token}")
    assert wide.refusal({"Host": "10.0.0.5:8080"}, "/")
    assert wide.refusal({"Host": "10.0.0.5:8080"}, f"/?token={wide.token}") is None
    assert wide.refusal({"Host": "10.0.0.5:8080", "Cookie": f"physomni_preview={wide.token}"}, "/") is None
    assert wide.refusal({"Host": "10.0.0.5:8080", "Cookie": "physomni_preview=guess"}, "/")
    assert clamp(-5, 0.001, 1e5) == 0.001 and clamp(1e30, 0, 1000) == 1000 and clamp(float("nan"), 0, 1) is None


def test_temporary_names_are_shown_as_their_target():
    from physomni_usd._files import shown_name

    assert shown_name("/s/.sim.physomni-ab12cd.usdc") == "/s/sim.usdc"
    assert shown_name("/s/report.json") == "/s/report.json"


def test_a_particle_spacing_that_would_fill_memory_is_refused_before_sampling():
    """--particle-spacing 0.0002 on a 10 cm cube would be 1.25e11 particles: one line naming the option."""
    import trimesh

    from physomni_usd.errors import InputError
    from physomni_usd.physics.mpm import choose_spacing
    from physomni_usd.settings import MAX_PARTICLES

    cube = trimesh.creation.box((0.1, 0.1, 0.1))
    with pytest.raises(InputError, match=r"--particle-spacing 0.0002: .* at most 2,000,000") as info:
        choose_spacing([cube], 0.0002)
    assert "\n" not in str(info.value)
    assert choose_spacing([cube], 0.01) == 0.01  # 1000 particles: as asked
    assert (0.1 ** 3) / choose_spacing([cube], (0.1 ** 3 / MAX_PARTICLES) ** (1 / 3) * 1.01) ** 3 <= MAX_PARTICLES


def test_a_build_of_several_boxes_says_each_mask_as_it_is_cut():
    """GrabCut takes seconds a box on a large photo: a build of many boxes is never silent until the last."""
    import numpy as np

    from physomni_usd.building import _box_progress
    from physomni_usd.perceive.masks import collect_masks

    photo = np.full((64, 96, 3), 200, np.uint8)
    photo[20:40, 10:30] = (200, 40, 40)
    photo[20:40, 60:80] = (40, 40, 200)
    said = []
    objects = collect_masks(photo, (), ["8,18,32,42:red", "58,18,82,42:blue"], _box_progress(said.append))
    assert [o.label for o in objects] == ["red", "blue"]
    assert said == ["perceive: mask 1/2 cut from its box", "perceive: mask 2/2 cut from its box"]


SWALLOWED = """
import os, pathlib, signal, sys, time
from physomni_usd.cli.shell import stop_on_signals
from physomni_usd._files import all_or_nothing, write_bytes
from physomni_usd.errors import Interrupted

target = pathlib.Path(sys.argv[1])
signal.signal(signal.SIGHUP, signal.SIG_DFL)  # as from a terminal: under nohup it is inherited ignored, and kept so
stop_on_signals()
try:
    with all_or_nothing():
        write_bytes(target, b"new")
        try:  # as a library's optional import under `except BaseException` (trimesh's) swallows it
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(5)
        except BaseException:
            pass
    print("finished")
except Interrupted as exc:
    print("interrupted", exc.name)
print(target.read_bytes().decode())
"""


def test_a_signal_whose_exception_a_library_swallows_still_undoes_the_command(tmp_path):
    """The window behind the once-flaky SIGHUP re-run: a signal landing while trimesh imported an optional
    module under ``except BaseException`` was lost, and the command finished and kept its files (exit 0)."""
    import subprocess
    import sys

    target = tmp_path / "sim.usdc"
    target.write_bytes(b"old")
    proc = subprocess.run([sys.executable, "-c", SWALLOWED, str(target)], capture_output=True, text=True, timeout=60)
    assert proc.stdout.split("\n")[:2] == ["interrupted SIGHUP", "old"], proc.stdout + proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim.usdc"]


@pytest.mark.skipif(not os.environ.get("PHYSOMNI_FAULTS_UNDER_LOAD"),
                    reason="opt-in (minutes, loads the machine): PHYSOMNI_FAULTS_UNDER_LOAD=20 runs the SIGHUP re-run "
                           "trial 20 times in a row beside 8 busy processes (PHYSOMNI_FAULTS_LOAD sets how many)")
def test_the_sighup_rerun_trial_holds_in_a_row_under_load(base, tmp_path):
    runs = int(os.environ["PHYSOMNI_FAULTS_UNDER_LOAD"])
    trials = faults.sighup_under_load(base, tmp_path, runs, int(os.environ.get("PHYSOMNI_FAULTS_LOAD", "8")))
    print("\n".join(f"{'ok' if ok else 'NOT'} {d}" for ok, d in trials))
    assert len(trials) == runs and all(ok for ok, _ in trials), \
        "\n".join(f"{'ok' if ok else 'NOT'} {d}" for ok, d in trials)


@pytest.mark.parametrize("journal", [
    {"pid": 1, "saved": {"/etc/victim.txt": None}, "temporary": []},
    {"pid": 1, "saved": {"../other.txt": "payload.txt"}},
    {"pid": 1, "saved": {"sub/edits.usda": None}},
    {"pid": 1, "saved": {"..": None}},
    {"pid": 1, "saved": {"shot.usda": "edits.usda"}},  # our kept copies are named .NAME.physomni-XXXX.keep
    {"pid": 1, "saved": {"sim.usdc": ".sim.usdc.physomni-ab.keep/../../x"}},
    {"pid": 1, "saved": {}, "temporary": ["../x"]},
    ["not", "a", "journal"],
])
def test_a_journal_naming_anything_but_our_files_in_the_folder_is_refused(journal):
    from physomni_usd._files import journal_refusal

    assert journal_refusal(journal)


def test_a_journal_of_ours_is_followed():
    from physomni_usd._files import journal_refusal

    assert journal_refusal({"pid": 1, "saved": {"sim.usdc": ".sim.usdc.physomni-k2j3.keep", "report.json": None},
                            "temporary": [".sim.physomni-x1y2.usdc"]}) is None
    assert journal_refusal({}) is None


def test_a_refused_journal_is_set_aside_and_restores_nothing(tmp_path, capfd):
    """In process: the lock taken over a planted journal deletes nothing outside or inside, keeps the journal's
    text as .physomni.lock.bad and says so in one line."""
    import json

    from physomni_usd._files import all_or_nothing, write_bytes

    shot, decoy = tmp_path / "shot", tmp_path / "decoy"
    shot.mkdir(), decoy.mkdir()
    (decoy / "victim.txt").write_text("victim")
    (shot / "edits.usda").write_text("#usda 1.0\n")
    planted = json.dumps({"pid": 1, "saved": {str(decoy / "victim.txt"): None, "edits.usda": None}})
    (shot / ".physomni.lock").write_text(planted)
    with all_or_nothing():
        write_bytes(shot / "report.json", b"{}")
    assert (decoy / "victim.txt").read_text() == "victim" and (shot / "edits.usda").is_file()
    assert (shot / ".physomni.lock.bad").read_text() == planted
    said = [ln for ln in capfd.readouterr().err.splitlines() if ln]
    assert len(said) == 1 and said[0].startswith("warning:") and "victim.txt" in said[0]


def test_no_write_goes_through_a_link(tmp_path):
    """A lock, a layer or a file below a linked subfolder: refused in one line naming it, the target as it was."""
    from physomni_usd._files import check_writable, write_bytes
    from physomni_usd.errors import InputError

    shot, decoy = tmp_path / "shot", tmp_path / "decoy"
    shot.mkdir(), decoy.mkdir()
    (decoy / "victim.txt").write_text("victim")
    (shot / ".physomni.lock").symlink_to(decoy / "victim.txt")
    with pytest.raises(InputError, match=r"\.physomni\.lock: it is a symbolic link"):
        write_bytes(shot / "report.json", b"{}")
    (shot / ".physomni.lock").unlink()
    (shot / "sim.usdc").symlink_to(decoy / "victim.txt")
    with pytest.raises(InputError, match=r"sim\.usdc: it is a symbolic link"):
        write_bytes(shot / "sim.usdc", b"layer")
    (shot / "textures").symlink_to(decoy)
    with pytest.raises(InputError, match=r"textures: it is a symbolic link"):
        check_writable([shot / "textures" / "cup_0.png"], inside=shot)
    check_writable([decoy / "video.mp4"], inside=shot)  # an output the user names outside the shot is theirs
    assert (decoy / "victim.txt").read_text() == "victim" and sorted(p.name for p in decoy.iterdir()) == ["victim.txt"]


CAUGHT = """
import os, pathlib, signal, sys, time
from physomni_usd.cli.shell import stop_on_signals
from physomni_usd._files import all_or_nothing, write_bytes

target = pathlib.Path(sys.argv[1])
signal.signal(signal.SIGHUP, signal.SIG_DFL)  # as from a terminal: under nohup it is inherited ignored, and kept so
stop_on_signals()
try:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5)
except KeyboardInterrupt:  # caught on purpose, as the preview stops on it and then writes its take
    pass
with all_or_nothing():
    write_bytes(target, b"take")
print(target.read_bytes().decode())
"""


def test_a_signal_caught_on_purpose_before_a_write_does_not_undo_it(tmp_path):
    """The preview stops on Ctrl-C or SIGTERM and then writes its take: that later write is kept."""
    import subprocess
    import sys

    target = tmp_path / "sim.usdc"
    target.write_bytes(b"old")
    proc = subprocess.run([sys.executable, "-c", CAUGHT, str(target)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.strip() == "take", proc.stdout + proc.stderr


def test_estimate_set_on_a_shot_reached_through_a_linked_folder_does_not_wait_on_itself(shot, tmp_path):
    """The shot folder may be a link the user made: `estimate --set` locks it by the link's name before it reads and
    wrote through the folder's own name, two locks on one file; it waited on itself and then failed."""
    import shutil
    import subprocess

    shutil.copytree(shot["dir"], tmp_path / "real")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    proc = subprocess.run(faults.command("estimate", tmp_path / "link" / "shot.usda", "--set", "cup.density=300"),
                          capture_output=True, text=True, timeout=300, env={**os.environ, "PHYSOMNI_LOCK_WAIT": "5"})
    assert proc.returncode == 0, proc.stderr[-400:]
    assert b"300" in (tmp_path / "real" / "edits.usda").read_bytes()
