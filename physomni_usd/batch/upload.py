"""``batch --upload``: shots for a cluster whose nodes do not share storage with the driver.

The driver reads each shot's input files (photo, masks, the ``--meshes``
folder, and the artist's ``edits.usda`` if the output folder has one) and sends
them with the task through Ray's object store. The task writes them to a
temporary folder on its node, runs ``run`` there, and returns the output
folder as a tar archive; the driver unpacks it into the shot's output folder,
each file atomically, ``report.json`` last, and never over an existing
``edits.usda``.
"""

from __future__ import annotations

import io
import pathlib
import tarfile

import click

from .._files import write_bytes
from ..report import REPORT
from .shots import LOG, Shot

EDITS = "edits.usda"


def args_from_params(command: click.Command, params: dict) -> list[str]:
    """The argument list that ``command``'s parser turns back into ``params``."""
    positional, options = [], []
    for p in command.params:
        value = params.get(p.name)
        if isinstance(p, click.Argument):
            positional.append(str(value))
        elif p.is_flag:
            if value:
                options.append(p.opts[-1])
        elif p.multiple:
            for v in value or ():
                options += [p.opts[-1], str(v)]
        elif value is not None:
            options += [p.opts[-1], str(value)]
    return positional + options


def stage(shot: Shot, command: click.Command) -> tuple[list[str], dict[str, bytes]]:
    """``run`` arguments relative to a staging folder, and the files (relative path → bytes) it must hold.

    Each input keeps its file name (a mask's default label is its file's name).
    """
    from ..perceive.masks import split_spec

    params, files = dict(shot.params), {}

    def add(path: pathlib.Path, folder: str) -> str:
        name = f"in/{folder}/{path.name}"
        files[name] = path.read_bytes()
        return name

    params["photo"] = add(shot.cwd / params["photo"], "photo")
    masks = []
    for i, spec in enumerate(params.get("masks", ())):
        path, label = split_spec(spec)
        name = add(shot.cwd / path, f"mask{i}")
        masks.append(f"{name}:{label}" if label else name)
    params["masks"] = tuple(masks)
    if params.get("meshes_dir") is not None:
        folder = shot.cwd / params["meshes_dir"]
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                files[f"in/meshes/{p.relative_to(folder).as_posix()}"] = p.read_bytes()
        params["meshes_dir"] = "in/meshes"
    if (shot.output / EDITS).is_file():
        files[f"out/{EDITS}"] = (shot.output / EDITS).read_bytes()
    params["out_dir"] = "out"
    return args_from_params(command, params), files


def write_staged(root: pathlib.Path, files: dict[str, bytes]) -> None:
    for name, data in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


def pack(folder: pathlib.Path) -> bytes:
    """The folder's files as an uncompressed tar archive (videos and usdc are compressed already)."""
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w") as tar:
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                tar.add(p, arcname=p.relative_to(folder).as_posix())
    return buffer.getvalue()


def unpack(archive: bytes, folder: pathlib.Path) -> None:
    """Write the archive's files into ``folder`` atomically, ``report.json`` last; keep an existing edits.usda."""
    folder.mkdir(parents=True, exist_ok=True)
    report = None
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r") as tar:
        for member in tar.getmembers():
            target = (folder / member.name).resolve()
            if not member.isfile() or folder.resolve() not in target.parents:
                continue  # only plain files inside the folder
            if member.name == EDITS and target.is_file():
                continue
            data = tar.extractfile(member).read()
            if member.name == LOG:  # the attempts' history stays with the shot
                with open(target, "ab") as log:
                    log.write(data)
                continue
            if member.name == REPORT:
                report = data
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            write_bytes(target, data)
    if report is not None:
        write_bytes(folder / REPORT, report)
