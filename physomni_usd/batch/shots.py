"""The shot list of ``batch`` and when a shot counts as finished.

A shot list is a text file with the arguments of one ``physomni-usd run`` per
line (shell-quoted; blank lines and ``#`` comments skipped), or a YAML or JSON
list whose entries are such a line or a mapping of the same options. Paths are
relative to the list's folder. Every entry is parsed by ``run``'s own option
parser before anything runs, so a bad list fails at once, naming the line.

A shot is finished when its ``report.json`` carries a ``batch`` section with
the content hash of its inputs (photo, mask and mesh bytes, options, package
version) and a hash of the rest of the report as it was when the shot ended:
``batch`` clears that section before a shot starts and writes it last, so an
interrupted shot, or one a later command changed, never looks finished.
"""

from __future__ import annotations

import hashlib
import json
import pathlib
import shlex
from dataclasses import dataclass, field
from typing import Callable

from .. import __version__
from ..errors import InputError
from ..report import REPORT, update_report

#: Files a finished ``run`` leaves in its folder.
OUTPUTS = ("shot.usda", "sim.usdc", "video.mp4")
#: The log of every attempt of a shot, in its output folder.
LOG = "batch.log"
_SECTION = "batch"
_YAML = (".yaml", ".yml")


@dataclass(frozen=True)
class Shot:
    """One line of a shot list."""

    where: str  # 'shots.txt:3' (or 'shots.json: entry 2'), for messages
    args: tuple[str, ...]  # arguments of `physomni-usd run`, as written
    cwd: pathlib.Path  # the list's folder: relative paths in args are relative to it
    output: pathlib.Path  # the output folder, absolute
    params: dict = field(compare=False, hash=False)  # what `run`'s parser made of args


def read_shot_list(path, parse: Callable[[list[str]], dict]) -> list[Shot]:
    """The shots of the list at ``path``; ``parse(args)`` is ``run``'s option parser (params dict).

    Raises InputError (exit 2) naming the file and line of the first bad entry.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise InputError(f"shot list not found: {path}")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read shot list {path}: {exc}") from None
    cwd = path.resolve().parent
    if path.suffix.lower() in _YAML + (".json",):
        entries = _structured_entries(path, text)
    else:
        entries = []
        for number, line in enumerate(text.splitlines(), 1):
            where = f"{path}:{number}"
            try:
                args = shlex.split(line, comments=True)
            except ValueError as exc:
                raise InputError(f"{where}: {exc}") from None
            if args:
                entries.append((where, args))
    shots, outputs = [], {}
    for where, args in entries:
        shot = _shot(where, args, cwd, parse)
        if shot.output in outputs:
            raise InputError(f"{where}: output {shot.output} is also the output of {outputs[shot.output]}")
        outputs[shot.output] = where
        shots.append(shot)
    if not shots:
        raise InputError(f"{path}: no shots in it (one `physomni-usd run` argument list per line)")
    return shots


def _structured_entries(path: pathlib.Path, text: str) -> list[tuple[str, list[str]]]:
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise InputError(f"{path}: not valid JSON ({exc})") from None
        lines = [None] * len(data) if isinstance(data, list) else []
    else:
        import yaml

        try:
            node = yaml.compose(text)
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise InputError(f"{path}: not valid YAML ({' '.join(str(exc).split())})") from None
        lines = [item.start_mark.line + 1 for item in node.value] if isinstance(data, list) else []
    if not isinstance(data, list):
        raise InputError(f"{path}: expected a list of shots (each a `run` argument line or a mapping of its options)")
    out = []
    for index, (entry, line) in enumerate(zip(data, lines), 1):
        where = f"{path}:{line}" if line else f"{path}: entry {index}"
        if isinstance(entry, str):
            try:
                out.append((where, shlex.split(entry, comments=True)))
            except ValueError as exc:
                raise InputError(f"{where}: {exc}") from None
        elif isinstance(entry, dict):
            out.append((where, _mapping_args(where, entry)))
        else:
            raise InputError(f"{where}: expected a `run` argument line or a mapping of its options, "
                             f"got {type(entry).__name__}")
    return out


def _mapping_args(where: str, entry: dict) -> list[str]:
    """``{photo: p.png, output: out, mask: [a.png:cup], seconds: 1}`` → ``['p.png', '--output', 'out', ...]``."""
    entry = dict(entry)
    if "photo" not in entry:
        raise InputError(f"{where}: no 'photo' in this shot")
    args = [str(entry.pop("photo"))]
    for key, value in entry.items():
        option = ("-" if len(str(key)) == 1 else "--") + str(key).replace("_", "-")
        for item in value if isinstance(value, list) else [value]:
            if item is True:
                args.append(option)
            elif item is False or item is None:
                continue
            elif isinstance(item, (dict, list)):
                raise InputError(f"{where}: {key}: expected a value or a list of values")
            else:
                args += [option, str(item)]
    return args


def _shot(where: str, args: list[str], cwd: pathlib.Path, parse) -> Shot:
    if args[:2] == ["physomni-usd", "run"]:
        args = args[2:]
    if {"-h", "--help", "--version"} & set(args):
        raise InputError(f"{where}: --help has no place in a shot list")
    try:
        params = parse(list(args))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    output = pathlib.Path(params["out_dir"])
    return Shot(where=where, args=tuple(args), cwd=cwd, output=(cwd / output).resolve(), params=params)


def missing_input(shot: Shot) -> str | None:
    """``run``'s message for the first input file the shot names that does not exist, else None.

    Checked where the batch starts (shared storage: the nodes see the same
    files), so that such a shot fails at once, without a process or a folder.
    """
    from ..perceive.masks import split_spec

    if not (shot.cwd / shot.params["photo"]).is_file():
        return f"photo not found: {shot.params['photo']}"
    for spec in shot.params.get("masks", ()):
        name, _ = split_spec(spec)
        if not (shot.cwd / name).is_file():
            return f"mask not found: {name}"
    meshes = shot.params.get("meshes_dir")
    if meshes is not None and not (shot.cwd / meshes / "poses.json").is_file():
        return f"--meshes {meshes}: no poses.json in it"
    return None


def _file_digest(path: pathlib.Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return f"unreadable:{path}"


def inputs_hash(shot: Shot) -> str:
    """SHA-256 of what decides the shot's result: input bytes, options and the package version."""
    from ..perceive.masks import split_spec

    params = {k: v for k, v in shot.params.items() if k not in ("out_dir", "quiet")}
    params["photo"] = _file_digest(shot.cwd / params["photo"])
    masks = []
    for spec in params.pop("masks", ()):
        name, label = split_spec(spec)
        masks.append([_file_digest(shot.cwd / name), label])
    params["masks"] = masks
    meshes = params.pop("meshes_dir", None)
    if meshes is not None:
        folder = shot.cwd / meshes
        files = sorted(p for p in folder.rglob("*") if p.is_file()) if folder.is_dir() else []
        params["meshes_dir"] = [[str(p.relative_to(folder)), _file_digest(p)] for p in files]
    blob = json.dumps({"version": __version__, "params": params}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def _read_report(folder: pathlib.Path) -> dict | None:
    try:
        data = json.loads((folder / REPORT).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _rest_hash(report: dict) -> str:
    """Hash of the report without the batch section: any later stage command changes it."""
    rest = dict(report)
    rest["stages"] = {k: v for k, v in report.get("stages", {}).items() if k != _SECTION}
    return hashlib.sha256(json.dumps(rest, sort_keys=True).encode()).hexdigest()


def is_finished(folder, digest: str) -> bool:
    """Whether ``folder`` holds a finished batch run of inputs hashing to ``digest``."""
    folder = pathlib.Path(folder)
    report = _read_report(folder)
    if report is None or not all((folder / name).is_file() for name in OUTPUTS):
        return False
    section = report.get("stages", {}).get(_SECTION) or {}
    return section.get("inputs_sha256") == digest and section.get("report_sha256") == _rest_hash(report)


def mark_started(folder) -> None:
    """Forget an earlier finish before the shot's files start to change."""
    folder = pathlib.Path(folder)
    if (folder / REPORT).is_file():
        update_report(folder, **{_SECTION: {"status": "running"}})


def mark_finished(folder, digest: str, **extra) -> None:
    """Record the finish, last and atomically (``report.json`` is replaced by a rename)."""
    folder = pathlib.Path(folder)
    report = _read_report(folder) or {}
    update_report(folder, **{_SECTION: {"status": "ok", "inputs_sha256": digest,
                                        "report_sha256": _rest_hash(report), **extra}})
