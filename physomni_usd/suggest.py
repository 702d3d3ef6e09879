"""The "did you mean …" of a refused name: the closest of the known names, for one-line errors."""

from __future__ import annotations

import difflib

#: How alike (difflib's ratio, 0 to 1) a known name must be to the typed one to be offered.
CUTOFF = 0.6


def did_you_mean(typed: str, known) -> str:
    """``'; did you mean 'cup'?'`` for the known name closest to ``typed``, or ``''`` when none is close."""
    close = difflib.get_close_matches(typed.strip(), sorted(set(known)), n=1, cutoff=CUTOFF)
    return f"; did you mean {close[0]!r}?" if close else ""
