"""What every command shares: an exception as one ``error:`` line and an exit code
(:func:`physomni_usd.failure.failure_of`), the progress display, the shot folder's lock, the line a stage
ends with, a usage error as one line, and the signals that unwind a command as Ctrl-C does."""

from __future__ import annotations

import os
import sys
import time
from contextlib import contextmanager
from functools import lru_cache

import click

from ..failure import failure_of


def fail(message: str, code: int) -> None:
    """Print ``error: MESSAGE`` (secrets redacted) on stderr and exit with ``code``."""
    from ..errors import redact

    click.echo(f"error: {redact(message)}", err=True)
    sys.exit(code)


@contextmanager
def errors():
    """Turn our exceptions and pydantic's into one line and an exit code (:func:`failure.failure_of`)."""
    from ..errors import Interrupted, received_signal

    try:
        yield
    except (Exception, KeyboardInterrupt) as exc:
        if received_signal() is not None and not isinstance(exc, Interrupted):
            # whatever broke after a signal whose exception was swallowed (a module left half-imported) is
            # the signal's doing: say that, not an internal error
            exc = Interrupted(received_signal())
        found = failure_of(exc)
        if found.internal and os.environ.get("PHYSOMNI_DEBUG"):
            raise
        fail(found.message, found.exit_code)


#: Where stderr is no terminal (a log, CI), progress is a plain line at every tenth of the work, and at
#: least every this many seconds.
LOG_EVERY_S = 5.0


@contextmanager
def progress(label: str, enabled: bool = True):
    """A click progress bar on stderr, or plain ``label: frame K/N`` lines where stderr is not a terminal;
    yields a callback ``(done, total)``."""
    state = {"bar": None, "done": 0, "logged": 0, "at": time.monotonic()}
    tty = sys.stderr.isatty()

    def log(done, total):
        now = time.monotonic()
        tenth = max(1, -(-total // 10))
        if done >= total or done // tenth > state["logged"] // tenth or now - state["at"] >= LOG_EVERY_S:
            click.echo(f"{label.strip()}: frame {done}/{total}", err=True)
            state["logged"], state["at"] = done, now

    def update(done, total):
        if not enabled:
            return
        if not tty:
            log(done, total)
            return
        if state["bar"] is None:
            state["bar"] = click.progressbar(length=total, label=label, file=sys.stderr, show_pos=True)
            state["bar"].__enter__()
        state["bar"].update(done - state["done"])
        state["done"] = done

    try:
        yield update
    finally:
        if state["bar"] is not None:
            state["bar"].__exit__(None, None, None)


@contextmanager
def shot_lock(shot):
    """Hold the shot folder's lock from before the command reads the shot to after its last write, so that
    two commands on one shot (two `estimate --set`) run one after the other and no update is lost."""
    from .._files import folder_lock
    from ..usd import layers

    with folder_lock(layers.shot_folder(shot)):
        yield


def say(quiet: bool):
    """The ``echo`` a command gives the API: stderr, or nothing with ``--quiet``."""
    return (lambda msg: None) if quiet else (lambda msg: click.echo(msg, err=True))


def said(stage: str, section, quiet: bool) -> None:
    """The one line a stage ends with."""
    if quiet:
        return
    if stage == "simulate":
        click.echo(f"simulate: {section['frames']} frames, {section['bodies']} rigid bodies, "
                   f"{len(section['moving_prims'])} moving, dt {section['dt'] * 1000:.2f} ms, "
                   f"{section['total_seconds']:.2f} s", err=True)
    elif stage == "render":
        click.echo(f"render: {section['video']} ({section['frames']} frames, "
                   f"{section['frames_per_second']:.1f} frames/s)", err=True)


class OneLineUsage(click.Group):
    """A subcommand's usage error (a missing -o, an unknown option, a bad choice) as one ``error:`` line and
    exit 2, as every other bad input is; click would print the command's usage and a hint around it."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:
            where = exc.ctx.command_path if exc.ctx is not None else ctx.command_path
            message = exc.format_message()
            fail(f"{where}: {message[:-1] if message.endswith('.') else message}; see `{where} --help`", 2)


@lru_cache(maxsize=1)
def exit_without_collecting() -> None:
    """Python's exit walks the whole heap with its cycle collector once per module it clears: seconds of CPU
    after the last line is printed, for the objects that warp's kernels and Newton leave. Nothing is left to
    reclaim from a process that is ending, so the heap is moved out of the collector's reach first; objects
    are still freed as their modules are cleared, and atexit handlers still run."""
    import atexit
    import gc

    atexit.register(gc.freeze)


def stop_on_signals() -> dict:
    """SIGTERM and SIGHUP (what `timeout`, farm managers and Kubernetes send) unwind a command as Ctrl-C
    does, so its files are put back; SIGINT too where it was inherited ignored (a script's background
    job). A SIGHUP ignored on purpose (nohup) stays ignored; a second signal while unwinding is ignored.
    Returns the handlers it replaced."""
    import signal
    import threading

    from ..errors import Interrupted, forget_signals, note_signal

    if threading.current_thread() is not threading.main_thread():
        return {}
    state = {"stopping": False}
    forget_signals()

    def stop(signum, frame):
        if state["stopping"]:
            return
        state["stopping"] = True
        # noted as well as raised: if a library swallows the exception, the commit (all_or_nothing) and the
        # command's end (errors) still see the signal, so the files are put back and the exit is 128 + N
        if note_signal(signum):
            raise Interrupted(signum)

    previous = {}
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        old = signal.getsignal(sig)
        if sig == signal.SIGHUP and old is signal.SIG_IGN:
            continue
        previous[sig] = old if old is not None else signal.SIG_DFL
        signal.signal(sig, stop)
    return previous
