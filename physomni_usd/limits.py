"""A number that a function takes outside the settings models (a bench's photo size, a batch's retries, a
re-render's steps) with its option, default and range: the function that owns it keeps a table of them
(:class:`Limits`) and checks its arguments against it (:meth:`Limits.check`: an
:class:`~physomni_usd.errors.InputError` naming the option), and the command reads its option's default,
range and help from the same table, so that the Python call and the command refuse the same values with
the same line."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError


@dataclass(frozen=True)
class Limit:
    """One number: its option (``flag``), what it is (``text``, one sentence), its default (None: a choice
    made later, said in ``default_text``) and its range ``[lo, hi]`` (``lo`` None: any number; ``hi`` None:
    unbounded above; ``lo_open``: ``lo`` itself is out); ``whole`` for a count."""

    flag: str
    text: str
    lo: float | None
    hi: float | None
    default: float | int | None = None
    whole: bool = False
    default_text: str = ""
    lo_open: bool = False

    def span(self) -> str:
        """The range in words, e.g. ``64 ≤ value ≤ 8192``; empty for a number without one."""
        if self.lo is None:
            return ""
        below = f" ≤ {self.hi:g}" if self.hi is not None else ""
        return f"{self.lo:g} {'<' if self.lo_open else '≤'} value{below}"

    def check(self, value) -> None:
        """Refuse ``value`` (None: not given, a choice made later) outside the range, or not whole where
        it must be."""
        if value is None:
            return
        number = float(value)
        whole = not self.whole or (not isinstance(value, bool) and number == int(number))
        above = self.lo is None or (self.lo < number if self.lo_open else self.lo <= number)
        if not (math.isfinite(number) and whole and above and (self.hi is None or number <= self.hi)):
            kind = "a whole number" if self.whole else ("" if self.span() else "a finite number")
            shown = f"{value:g}" if isinstance(value, float) else value
            raise InputError(f"{self.flag} {shown}: must be " + ", ".join(x for x in (kind, self.span()) if x))


class Limits(dict):
    """A function's numbers by argument name (name → :class:`Limit`)."""

    def check(self, **values) -> None:
        """Refuse the first of ``values`` (argument name → value, or an iterable of values for a repeatable
        option) that its :class:`Limit` does not allow."""
        for name, value in values.items():
            for one in (value if isinstance(value, (list, tuple)) else (value,)):
                self[name].check(one)
