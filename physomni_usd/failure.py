"""What a failed command says to a person: one line and an exit code, for the CLI and for ``batch`` alike.

Exit codes: 1 a stage failed (or the disk did), 2 bad input, 3 an internal error (a bug),
128 + the signal's number when interrupted (130 for Ctrl-C, 143 for SIGTERM). A pydantic refusal names the option that set the field, as
the user typed it (``--fov 500: ...``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from pydantic import ValidationError

from ._files import io_failure, shown_name
from .errors import PhysOmniError
from .settings import option_of

INTERRUPTED = "interrupted by {name}: the shot's files are put back as they were before this command"
#: The signal came in the commit's last moment (well under a millisecond), which is not cut in half.
INTERRUPTED_LATE = "interrupted by {name} as this command finished: its files are all in place"


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
        # named by the option that sets the field (the settings model's own Option), as the user typed it
        where = (option_of(exc.title, loc[-1]) or ".".join(loc)) if loc else "value"
        msg = str(first.get("msg", "is not valid"))
        msg = msg[len("Input "):] if msg.startswith("Input ") else msg
        value = first.get("input")
        shown = f" {value:g}" if isinstance(value, float) else (f" {value}" if isinstance(value, (int, str)) else "")
        return Failure(f"{where}{shown}: {msg}", 2, kind, stage)
    if isinstance(exc, PermissionError):  # the checks before each command should have caught it
        return Failure(f"cannot write {shown_name(exc.filename)}: permission denied", 2, kind, stage)
    if isinstance(exc, OSError):
        disk = io_failure(exc)  # full, read-only or failing: the disk's fault, not a bug
        if disk is not None:
            return Failure(disk[0], disk[1], kind, stage)
    if isinstance(exc, KeyboardInterrupt):  # Ctrl-C, or a terminating signal raised as one (errors.Interrupted)
        name, signum = getattr(exc, "name", "SIGINT"), getattr(exc, "signum", 2)
        said = INTERRUPTED_LATE if getattr(exc, "after_commit", False) else INTERRUPTED
        return Failure(said.format(name=name), 128 + signum, kind, stage)
    return Failure(f"internal error: {kind}: {exc} (set PHYSOMNI_DEBUG=1 for the traceback)", 3, kind, stage,
                   internal=True)
