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

    def __init__(self, signum: int):
        import signal

        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)
        self.name = signal.Signals(signum).name
