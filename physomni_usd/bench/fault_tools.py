"""What the fault cases of ``bench faults`` share: the real CLI in a fresh interpreter, a snapshot of a folder,
the one-``error:``-line check, a copy of the finished shot and the ``run`` line it was made by."""

from __future__ import annotations

import hashlib
import pathlib
import shutil
import subprocess
import sys

CLI = "import sys\nfrom physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n"


def command(*args) -> list[str]:
    return [sys.executable, "-c", CLI, *map(str, args)]


def cli(*args, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(command(*args), capture_output=True, text=True, timeout=timeout)


def snapshot(folder: pathlib.Path) -> dict[str, str]:
    """Every file under ``folder`` (hidden ones too) → its content's SHA-256."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_error_line(stderr: str, *needles: str) -> bool:
    """Whether ``stderr`` ends in exactly one ``error:`` line holding every needle, and has no traceback."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("error:")]
    return (len(errors) == 1 and bool(lines) and lines[-1] == errors[0] and "Traceback" not in stderr
            and all(n in errors[0] for n in needles))


def copy_shot(base: dict, dest: pathlib.Path) -> pathlib.Path:
    shutil.copytree(base["dir"], dest)
    return dest


def run_args(base: dict, out: pathlib.Path) -> list:
    args = ["run", base["photo"], "-o", out]
    for m in base["masks"]:
        args += ["--mask", m]
    return args + list(base.get("run", ()))
