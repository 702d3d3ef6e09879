"""The fault cases of ``bench faults`` on a shot folder from someone else (a planted journal, a symlinked lock,
edits.usda or layer, layers that do not compose, a huge label) and the preview's Keep settings and Save take
on such a folder: nothing outside the folder may change, and edits.usda never but by its own commands."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import pathlib
import shutil
import sys

from .fault_tools import cli, copy_shot, one_error_line, snapshot


def decoy_beside(base, work) -> pathlib.Path:
    """Someone's files beside the shot (``work/decoy``), which no command on the shot may touch; one of them a
    valid layer, so that a link to it composes."""
    decoy = work / "decoy"
    (decoy / "sub").mkdir(parents=True)
    for name in ("victim.txt", "other.txt", "sub/deep.txt"):
        (decoy / name).write_text(f"{name}: someone else's\n")
    shutil.copy(base["dir"] / "sim.usdc", decoy / "layer.usdc")
    return decoy


def outside(work: pathlib.Path, folder: pathlib.Path) -> dict[str, str]:
    """Every entry under ``work`` except ``folder`` → its content's SHA-256 ("link → …" for a link, never
    followed; "folder" for one): what a command on the shot in ``folder`` must leave as it is."""
    out = {}
    for root, dirs, files in os.walk(work):
        root = pathlib.Path(root)
        dirs[:] = [d for d in dirs if root / d != folder]
        for name in dirs + files:
            p = root / name
            rel = str(p.relative_to(work))
            if p.is_symlink():
                out[rel] = f"link → {os.readlink(p)}"
            elif p.is_dir():
                out[rel] = "folder"
            else:
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def shot_commands(base, folder: pathlib.Path) -> dict[str, list]:
    """The commands that write into an existing shot, each as short as it can be."""
    masks = [a for m in base["masks"] for a in ("--mask", m)]
    return {"simulate": ["simulate", folder / "shot.usda", "--seconds", "0.3"],
            "render": ["render", folder / "shot.usda"],
            "estimate --set": ["estimate", folder / "shot.usda", "--set", f"{base['labels'][0]}.density=300"],
            "build -o": ["build", base["photo"], "-o", folder, *masks]}


def hostile_trials(base, work, name: str, plant, expect: dict[str, tuple[int, str]], commands=None):
    """For each command: a fresh copy of the shot beside :func:`decoy_beside`, ``plant(folder, decoy)`` done
    to it, the command run; clean when it exits as ``expect[command]`` says (code, and a needle its one
    ``error:`` line, or for exit 0 its warning, holds), nothing outside the folder changed and ``edits.usda``
    is byte for byte what it was (`estimate --set` adds its value to it when it succeeds)."""
    trials = []
    for cmd in commands or expect:
        # numbered, not named: a folder named after the trial ("sublayer_cycle") would put the very words that
        # the old code's message filter looked for into every path, and hide what the trial is to find
        where = work / f"trial{sum(1 for _ in work.iterdir()):02d}"
        where.mkdir()
        decoy = decoy_beside(base, where)
        folder = copy_shot(base, where / "shot")
        plant(folder, decoy)
        edits, before = (folder / "edits.usda").read_bytes(), outside(where, folder)
        proc = cli(*shot_commands(base, folder)[cmd])
        code, needle = expect[cmd]
        said = one_error_line(proc.stderr, needle) if code else needle in proc.stderr
        kept = outside(where, folder) == before
        now = (folder / "edits.usda").read_bytes() if (folder / "edits.usda").is_file() else None
        same_edits = now == edits or (cmd == "estimate --set" and proc.returncode == 0 and now is not None
                                      and b"300" in now)
        last = (proc.stderr.strip().splitlines() or [""])[-1][:160]
        trials.append((proc.returncode == code and said and kept and same_edits,
                       f"{name}, {cmd}: exit {proc.returncode}, outside {'unchanged' if kept else 'CHANGED'}, "
                       f"edits.usda {'as it was' if same_edits else 'CHANGED'}: {last}"))
    return trials


def _plant_journal(folder, decoy):
    (folder / "payload.txt").write_text("payload\n")
    (folder / ".physomni.lock").write_text(json.dumps(
        {"pid": 1, "saved": {str(decoy / "victim.txt"): None, "../decoy/other.txt": "payload.txt"},
         "temporary": ["../decoy/sub/deep.txt"]}))


def case_planted_journal(base, work):
    """A lock journal planted in the shot (a tarball's) naming an absolute path and a ../ path: it is set
    aside with one line, nothing is deleted or restored, the command runs."""
    said = (0, "is no journal of ours")
    trials = hostile_trials(base, work, "planted journal", _plant_journal,
                            dict.fromkeys(shot_commands(base, work), said))
    # an in-folder journal that would move one of the shot's files over another is no journal of ours either
    def swap(folder, decoy):
        (folder / ".physomni.lock").write_text(json.dumps({"pid": 1, "saved": {"shot.usda": "edits.usda"}}))

    return trials + hostile_trials(base, work, "journal moving edits.usda", swap, {"simulate": said})


def _link_lock(folder, decoy):
    (folder / ".physomni.lock").symlink_to(decoy / "victim.txt")


def case_symlinked_lock(base, work):
    """The lock file a link to a file outside: refused in one line naming it, exit 2; the target untouched."""
    return hostile_trials(base, work, "symlinked lock", _link_lock,
                          dict.fromkeys(shot_commands(base, work), (2, ".physomni.lock")))


def case_symlinked_layer(base, work):
    """sim.usdc a link to a valid layer outside: read through (render, estimate) but never written through
    (simulate, build: exit 2 naming it); textures/ a link to a folder outside: build refuses it."""
    def plant(folder, decoy):
        (folder / "sim.usdc").unlink()
        (folder / "sim.usdc").symlink_to(decoy / "layer.usdc")

    trials = hostile_trials(base, work, "symlinked sim.usdc", plant,
                            {"simulate": (2, "sim.usdc"), "render": (0, ""), "estimate --set": (0, ""),
                             "build -o": (2, "sim.usdc")})

    def textures(folder, decoy):
        shutil.copytree(folder / "textures", decoy / "textures")
        shutil.rmtree(folder / "textures")
        (folder / "textures").symlink_to(decoy / "textures")

    return trials + hostile_trials(base, work, "symlinked textures/", textures, {"build -o": (2, "textures")})


def _sublayer(folder, path: str) -> None:
    """Give the shot's edits.usda a sublayer (as a hand edit would)."""
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(str(folder / "edits.usda"))
    layer.subLayerPaths.append(path)
    layer.Save()


def case_uncomposable(base, work):
    """edits.usda sublayering itself (a cycle) or a missing file: exit 2 in every command, one line naming
    the layer; nothing replaced."""
    trials = hostile_trials(base, work, "sublayer cycle", lambda folder, decoy: _sublayer(folder, "./edits.usda"),
                            dict.fromkeys(shot_commands(base, work), (2, "edits.usda")))
    return trials + hostile_trials(base, work, "missing sublayer",
                                   lambda folder, decoy: _sublayer(folder, "./gone.usda"),
                                   dict.fromkeys(shot_commands(base, work), (2, "gone.usda")))


def _mask_box(base) -> str:
    """``X0,Y0,X1,Y1`` around the base shot's first mask: a box with an object in it, which GrabCut cuts."""
    import cv2
    import numpy as np

    mask = cv2.imread(base["masks"][0].rpartition(":")[0], cv2.IMREAD_GRAYSCALE)
    ys, xs = np.nonzero(mask)
    return f"{xs.min()},{ys.min()},{xs.max() + 1},{ys.max() + 1}"


def case_huge_label(base, work):
    """A 10,000-character label (build) or name (estimate --set): exit 2 naming the option, nothing written."""
    huge = "a" * 10000
    trials = []
    for option, args in (("--mask", lambda folder: ["build", base["photo"], "-o", folder, "--mask",
                                                    f"{base['masks'][0].rpartition(':')[0]}:{huge}"]),
                         ("--box", lambda folder: ["build", base["photo"], "-o", folder, "--box",
                                                   f"{_mask_box(base)}:{huge}"]),
                         ("--set", lambda folder: ["estimate", folder / "shot.usda", "--set", f"{huge}.density=300"])):
        where = work / f"label{option.strip('-')}"
        where.mkdir()
        decoy_beside(base, where)
        folder = copy_shot(base, where / "shot")
        before, everything = outside(where, folder), snapshot(folder)
        proc = cli(*args(folder))
        same = snapshot(folder) == everything and outside(where, folder) == before
        trials.append((proc.returncode == 2 and one_error_line(proc.stderr, option, "10,000") and same,
                       f"10,000-character {option}: exit {proc.returncode}, files {'unchanged' if same else 'CHANGED'}"))
    return trials


# --- the preview's Keep settings and Save take on such a folder, pressed in process -----------------------------

def _edits_link(folder, decoy):
    shutil.copy(folder / "edits.usda", decoy / "edits.usda")
    (folder / "edits.usda").unlink()
    (folder / "edits.usda").symlink_to(decoy / "edits.usda")


def _sim_link(folder, decoy):
    (folder / "sim.usdc").unlink()
    (folder / "sim.usdc").symlink_to(decoy / "layer.usdc")


def _cycle_on_disk(folder, decoy):
    """edits.usda sublayering itself, written by another program (an editor) while the preview runs."""
    text = (folder / "edits.usda").read_text()
    (folder / "edits.usda").write_text(text.replace("(", "(\n    subLayers = [@./edits.usda@]", 1))


def _noted(name: str):
    """An edit of the layer ``name`` by another program while the preview runs: a note in its metadata."""
    def edit(folder, decoy):
        text = (folder / name).read_text()
        note = '(\n    customLayerData = {\n        string handEdit = "kept"\n    }'
        (folder / name).write_text(text.replace("(", note, 1))

    return edit


def _damaged_edits(folder, decoy):
    with open(folder / "edits.usda", "a") as f:
        f.write("\nover this is no USD\n")


#: name → (what is done to the shot, whether while the preview runs rather than before it opens the shot, the
#: button: "keep" (Keep settings) or "save" (Save take), whether it writes, a needle of the line it says, and
#: what the written file must still hold: the edit made meanwhile).
KEEP_TRIALS = {
    "planted journal, Keep settings": (_plant_journal, False, "keep", True, "kept 1 setting", None),
    "planted journal, Save take": (_plant_journal, False, "save", True, "take 1 saved", None),
    "symlinked lock, Keep settings": (_link_lock, False, "keep", False, ".physomni.lock: it is a symbolic", None),
    "symlinked lock, Save take": (_link_lock, False, "save", False, ".physomni.lock: it is a symbolic", None),
    "symlinked edits.usda, Keep settings": (_edits_link, False, "keep", False, "edits.usda: it is a symbolic", None),
    "symlinked sim.usdc, Save take": (_sim_link, False, "save", False, "sim.usdc: it is a symbolic", None),
    "sublayer cycle written meanwhile, Keep settings": (_cycle_on_disk, True, "keep", False, "(a cycle)", None),
    "edits.usda damaged meanwhile, Keep settings": (_damaged_edits, True, "keep", False, "not a valid USD", None),
    "edits.usda edited meanwhile, Keep settings": (_noted("edits.usda"), True, "keep", True, "kept 1", "handEdit"),
    "shot.usda edited meanwhile, Save take": (_noted("shot.usda"), True, "save", True, "take 1 saved", "handEdit"),
}


@contextlib.contextmanager
def _stderr_lines(into: list):
    """What is written to file descriptor 2 inside the block (USD's own diagnostics included), as lines."""
    import tempfile

    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            f.seek(0)
            into.extend(ln for ln in f.read().decode(errors="replace").splitlines() if ln.strip())


def keep_trial(base, work, name: str) -> tuple[bool, str]:
    """One of :data:`KEEP_TRIALS`: a fresh copy of the shot beside :func:`decoy_beside`, opened as the preview opens
    it, gravity changed and three frames stepped, the button's function called as the page's press runs it. Clean
    when it answers (never raises) with one line holding the needle, writes or not as the trial says, nothing
    outside the folder changed, and ``edits.usda`` is byte for byte what it was unless Keep settings wrote it
    (then it holds the kept value and whatever the trial put there meanwhile)."""
    from ..preview.app import keep_settings, save_take
    from ..preview.engine import Engine

    plant, meanwhile, button, writes, needle, still = KEEP_TRIALS[name]
    where = work / f"keep{sum(1 for _ in work.iterdir()):02d}"
    where.mkdir()
    decoy = decoy_beside(base, where)
    folder = copy_shot(base, where / "shot")
    if not meanwhile:
        plant(folder, decoy)
    engine = Engine(folder / "shot.usda", capture=False)
    engine.set_gravity(5.0)
    for _ in range(3):
        engine.step()
    if meanwhile:
        plant(folder, decoy)
    edits, before = (folder / "edits.usda").read_bytes(), outside(where, folder)
    written = folder / ("edits.usda" if button == "keep" else "sim.usdc")
    old = written.read_bytes()
    printed: list[str] = []
    try:
        with _stderr_lines(printed):
            if button == "keep":
                wrote, line = keep_settings(engine)
            else:
                summary, line = save_take(engine, 1)
                wrote = summary is not None
    except Exception as exc:  # the press ended the preview
        wrote, line = None, f"RAISED {type(exc).__name__}: {exc}"
    # besides the line on the page, at most the planted journal's one warning: none of USD's own diagnostics
    quiet = len(printed) <= 1 and all(ln.startswith("warning: ") for ln in printed)
    kept = outside(where, folder) == before
    now = written.read_bytes()
    if button == "keep" and wrote:  # refused where the trial says so: a write from the copy read before is wrong
        right = writes and b"gravityMagnitude = 5" in now and (still is None or still.encode() in now)
    else:
        right = (folder / "edits.usda").read_bytes() == edits and (wrote or now == old)
        if still is not None:
            right = right and still.encode() in (folder / "shot.usda").read_bytes()
    ok = wrote is writes and needle in line and "\n" not in line and quiet and kept and right
    return ok, (f"{name}: {'wrote' if wrote else 'refused' if wrote is False else 'ENDED THE PREVIEW'}, "
                f"{'' if quiet else f'{len(printed)} MORE LINES ON STDERR, '}outside "
                f"{'unchanged' if kept else 'CHANGED'}, {'shot.usda' if still and button == 'save' else 'edits.usda'} "
                f"{'as it should be' if right else 'WRONG'}: "
                f"{line[:160]}")


def case_preview_keep(base, work):
    """The preview's Keep settings and Save take on a shot folder from someone else, or one changed while the
    preview runs: refused in one line where they would write through a link, the session going on; nothing
    outside the folder changed; edits.usda as it was, or with the kept value added to what is on disk now."""
    return [keep_trial(base, work, name) for name in KEEP_TRIALS]
