"""What a failed command says to a person: one line and an exit code, for the CLI and for ``batch`` alike.

Exit codes: 1 a stage failed, 2 bad input, 3 an internal error (a bug),
130 interrupted. A pydantic refusal names the option that set the field, as
the user typed it (``--fov 500: ...``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from pydantic import ValidationError

from .errors import PhysOmniError

#: Settings fields → the options that set them, so that a refused value is named as the user typed it.
OPTIONS = {"fov_deg": "--fov", "pitch_deg": "--pitch", "height_m": "--camera-height", "shape": "--shape",
           "fps": "--fps", "seconds": "--seconds", "substeps": "--substeps", "iterations": "--iterations",
           "particle_spacing": "--particle-spacing", "mpm_steps": "--mpm-steps", "max_size": "--max-size"}

INTERRUPTED = "interrupted; the shot's files are as they were before this command"


@dataclass(frozen=True)
class Failure:
    """Why a command ended: ``message`` one line, ``exit_code`` as above, ``type`` the exception's class name,
    ``stage`` the stage of ``run`` it happened in (None outside ``run``); ``internal``: a bug, not the input."""

    message: str
    exit_code: int
    type: str
    stage: str | None = None
    internal: bool = False

    def as_json(self) -> dict:
        return asdict(self)


def failure_of(exc: BaseException, stage: str | None = None) -> Failure:
    """The failure ``exc`` stands for."""
    kind = type(exc).__name__
    if isinstance(exc, PhysOmniError):
        return Failure(str(exc), exc.exit_code, kind, stage)
    if isinstance(exc, ValidationError):
        first = exc.errors()[0]
        loc = [str(x) for x in first.get("loc", ())]
        where = OPTIONS.get(loc[-1], ".".join(loc)) if loc else "value"
        msg = str(first.get("msg", "is not valid"))
        msg = msg[len("Input "):] if msg.startswith("Input ") else msg
        value = first.get("input")
        shown = f" {value:g}" if isinstance(value, float) else (f" {value}" if isinstance(value, (int, str)) else "")
        return Failure(f"{where}{shown}: {msg}", 2, kind, stage)
    if isinstance(exc, PermissionError):  # the checks before each command should have caught it
        return Failure(f"cannot write {exc.filename}: permission denied", 2, kind, stage)
    if isinstance(exc, KeyboardInterrupt):
        return Failure(INTERRUPTED, 130, kind, stage)
    return Failure(f"internal error: {kind}: {exc} (set PHYSOMNI_DEBUG=1 for the traceback)", 3, kind, stage,
                   internal=True)
