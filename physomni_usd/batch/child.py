"""One attempt of one shot, in its own process: :func:`physomni_usd.run` on the shot's arguments.

Run as ``python -m physomni_usd.batch.child PARENT_PID RESULT_FD run ARGS...``
by :func:`physomni_usd.batch.runner.run_shot` (the arguments after the two
numbers are for people reading the process list and the log); the function that
turns ARGS into ``run()``'s keyword arguments comes pickled on stdin. Messages,
progress and the error line go to stdout (the shot's log); the structured
failure (:class:`physomni_usd.failure.Failure`: stage, exception type, message,
exit code) goes as one JSON line to RESULT_FD, and the process exits with its
exit code.

The process ends with its parent (the Ray worker): PR_SET_PDEATHSIG on Linux,
so that a killed worker leaves no orphan writing into a folder that a retry is
about to write too.
"""

from __future__ import annotations

import json
import os
import pickle
import signal
import sys

#: Where stdout is a log, frame progress is a line at every tenth of a stage's frames.
_TENTHS = 10


def _die_with_parent(parent: int) -> None:
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # the parent died before the line above
            sys.exit(137)


def attempt(call, args: list[str], say=print) -> "tuple[dict | None, int]":
    """Run the shot; returns (the failure as JSON, or None, and the exit code)."""
    import physomni_usd
    from physomni_usd.failure import failure_of

    state = {"stage": "check", "logged": {}}

    def on_stage(stage, result):
        state["stage"] = stage
        if result is not None and stage != "check":
            say(f"run: {stage} done")

    def progress(stage, done, total):
        step = max(1, -(-total // _TENTHS))
        if done >= total or done // step > state["logged"].get(stage, 0) // step:
            say(f"{stage}: frame {done}/{total}")
            state["logged"][stage] = done

    try:
        physomni_usd.run(**call(args), echo=say, progress=progress, on_stage=on_stage)
    except (Exception, KeyboardInterrupt) as exc:
        found = failure_of(exc, state["stage"])
        say(f"error: {found.message}")
        return found.as_json(), found.exit_code
    return None, 0


def main(argv: list[str]) -> int:
    parent, result_fd = int(argv[0]), int(argv[1])
    _die_with_parent(parent)
    call = pickle.load(sys.stdin.buffer)
    args = argv[3:] if argv[2:3] == ["run"] else argv[2:]
    failure, code = attempt(call, args, lambda m: print(m, flush=True))
    with os.fdopen(result_fd, "w") as out:
        if failure is not None:
            out.write(json.dumps(failure) + "\n")
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
