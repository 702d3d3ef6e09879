"""The one exception type users see: a message that fits on one line (with any credentials in a URL
taken out: :func:`redact`)."""

import re

#: ``scheme://user:secret@host`` → the part between ``//`` and ``@``.
_USERINFO = re.compile(r"(?<=://)[^/\s@]+@")


def redact(text: str) -> str:
    """``text`` with the user name and password of every URL in it replaced by ``***``."""
    return _USERINFO.sub("***@", str(text))


class PhysOmniError(Exception):
    """Bad input or a failed stage, said in one line for a person.

    The CLI prints ``error: <message>`` and exits with ``exit_code``; nothing
    else of the traceback reaches the terminal.
    """

    exit_code = 1

    def __init__(self, message: str, exit_code: int | None = None):
        super().__init__(redact(" ".join(str(message).split())))
        if exit_code is not None:
            self.exit_code = exit_code


class InputError(PhysOmniError):
    """The user's input cannot be used (exit code 2, as for usage errors)."""

    exit_code = 2


class Interrupted(KeyboardInterrupt):
    """A terminating signal (SIGTERM, SIGHUP, SIGINT) as Ctrl-C: it unwinds the command, so that every
    ``all_or_nothing`` block puts its files back; the CLI exits with 128 + the signal's number."""

    def __init__(self, signum: int, after_commit: bool = False):
        import signal

        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)
        self.name = signal.Signals(signum).name
        #: it came while the command's files were being put in place: they are the new ones
        self.after_commit = after_commit


#: The terminating signal this process received (None: none yet), and whether one that comes now is only to
#: be noted (:func:`signals_held`). Kept apart from the exception because the exception can be lost: a
#: handler's exception is raised wherever the main thread happens to be, and libraries that import their
#: optional parts under ``except BaseException`` (trimesh does) swallow it, after which the command would
#: finish and keep its files as if no signal had come. ``_files.all_or_nothing`` looks here before it
#: commits.
_SIGNAL = {"received": None, "held": False}


def note_signal(signum: int) -> bool:
    """Remember a terminating signal; returns whether it should be raised now (False while held)."""
    if _SIGNAL["received"] is None:
        _SIGNAL["received"] = int(signum)
    return not _SIGNAL["held"]


def forget_signals() -> None:
    """A new command starts (an in-process caller may run several): no signal received yet."""
    _SIGNAL.update(received=None, held=False)


def received_signal() -> int | None:
    return _SIGNAL["received"]


def raise_if_signalled() -> None:
    """Raise :class:`Interrupted` for a terminating signal received earlier, whether or not its first raise
    was swallowed on the way."""
    if _SIGNAL["received"] is not None:
        raise Interrupted(_SIGNAL["received"])


class signals_held:
    """While inside, a terminating signal is only noted, not raised: the commit of a command's files (the
    journals emptied, folder after folder) or its roll-back is never cut in half. One that came inside is
    raised on leaving (unless an exception is already on its way out)."""

    def __enter__(self):
        self.outer, self.before = _SIGNAL["held"], _SIGNAL["received"]
        _SIGNAL["held"] = True
        return self

    def __exit__(self, *exc):
        _SIGNAL["held"] = self.outer
        came = self.before is None and _SIGNAL["received"] is not None
        if came and exc[0] is None and not self.outer:
            raise Interrupted(_SIGNAL["received"], after_commit=True)
        return False
