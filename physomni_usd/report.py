"""``report.json``: what each stage did and how long it took, one section per stage.

Each command replaces only its own stage's section, so the report of a shot
built, re-simulated and rendered holds the latest run of each.
"""

from __future__ import annotations

import json
import pathlib
import time
from contextlib import contextmanager

from ._files import write_bytes

REPORT = "report.json"


def update_report(folder: pathlib.Path, **sections) -> pathlib.Path:
    """Merge ``sections`` (stage name → dict) into ``folder/report.json``, atomically."""
    path = pathlib.Path(folder) / REPORT
    data = {}
    if path.is_file():
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
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
    """Wall-clock seconds of named steps, in the order they ran."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    @contextmanager
    def step(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = round(self.seconds.get(name, 0.0) + time.perf_counter() - t0, 4)

    @property
    def total(self) -> float:
        return round(sum(self.seconds.values()), 4)
