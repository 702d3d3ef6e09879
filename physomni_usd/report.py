"""``report.json``: what each stage did and how long it took, one section per stage.

Each command replaces only its own stage's section, so the report of a shot
built, re-simulated and rendered holds the latest run of each. A ``report.json``
that is not a JSON object (damaged, or edited by hand) is never overwritten: it
is moved aside to ``report.json.bad`` (``.bad.1``, … if that exists) and a new
report is started, with one warning line.
"""

from __future__ import annotations

import json
import pathlib
import time
from contextlib import contextmanager

from ._files import check_writable, remove_file, write_bytes

REPORT = "report.json"


def prepare_writes(folder: pathlib.Path, names, echo=lambda m: None) -> None:
    """Before a stage computes anything: refuse (one line, exit 2) if any of ``names`` in ``folder`` or
    ``report.json`` cannot be written, and move a damaged report aside."""
    folder = pathlib.Path(folder)
    check_writable([folder / n for n in names] + [folder / REPORT], inside=folder)
    set_aside_damaged(folder, echo)


def read_report(folder: pathlib.Path) -> dict | None:
    """The report as a dict; ``{}`` when there is none, None when the file is not a JSON object."""
    path = pathlib.Path(folder) / REPORT
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("stages", {}), dict) else None


def set_aside_damaged(folder: pathlib.Path, echo=lambda m: None) -> pathlib.Path | None:
    """Move a damaged ``report.json`` to ``report.json.bad`` (never over another file); returns where."""
    path = pathlib.Path(folder) / REPORT
    if read_report(folder) is not None:
        return None
    target, n = path.with_name(REPORT + ".bad"), 0
    while target.exists():
        n += 1
        target = path.with_name(f"{REPORT}.bad.{n}")
    write_bytes(target, path.read_bytes())  # as every write: undone if the command fails
    remove_file(path)
    echo(f"warning: {path} was not a readable report; moved it to {target.name} and started a new one")
    return target


def update_report(folder: pathlib.Path, **sections) -> pathlib.Path:
    """Merge ``sections`` (stage name → dict) into ``folder/report.json``, atomically."""
    path = pathlib.Path(folder) / REPORT
    data = read_report(folder)
    if data is None:
        set_aside_damaged(folder)
        data = {}
    data.setdefault("stages", {})
    for key, value in sections.items():
        if key in ("objects", "shot"):
            data[key] = value
        else:
            data["stages"][key] = value
    return write_bytes(path, (json.dumps(data, indent=2, default=_plain) + "\n").encode())


def _plain(value):
    try:
        import numpy as np

        if isinstance(value, np.generic):
            return value.item()
        if isinstance(value, np.ndarray):
            return value.tolist()
    except ImportError:  # pragma: no cover
        pass
    return str(value)


class Timer:
    """Wall-clock seconds of named steps, in the order they ran, and the process's CPU seconds in each (what a
    shared machine's load does not inflate)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.cpu_seconds: dict[str, float] = {}

    @contextmanager
    def step(self, name: str):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.seconds[name] = round(self.seconds.get(name, 0.0) + time.perf_counter() - t0, 4)
            self.cpu_seconds[name] = round(self.cpu_seconds.get(name, 0.0) + time.process_time() - c0, 4)

    @property
    def total(self) -> float:
        return round(sum(self.seconds.values()), 4)
