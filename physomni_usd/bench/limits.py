"""The benches' own numbers — a photo's size, repeats, scene counts, simulated seconds — with their ranges
and defaults, one table per bench. Each bench function checks its arguments against its table
(:meth:`Limits.check`: an :class:`~physomni_usd.errors.InputError` naming the option), and each ``bench``
command reads its options' defaults and ranges from the same table, so that the Python call and the
command refuse the same values with the same line."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class Limit:
    """One number of a bench: its option (``flag``), what it is (``text``, one sentence), its default
    (None: a choice the bench makes, said in ``default_text``) and its closed range ``[lo, hi]``
    (``hi`` None: unbounded); ``whole`` for a count."""

    flag: str
    text: str
    lo: float
    hi: float | None
    default: float | int | None = None
    whole: bool = False
    default_text: str = ""

    def span(self) -> str:
        """The range in words, e.g. ``64 ≤ value ≤ 8192``."""
        return f"{self.lo:g} ≤ value" + (f" ≤ {self.hi:g}" if self.hi is not None else "")

    def check(self, value) -> None:
        """Refuse ``value`` (None: not given, the bench's own choice) outside the range, or not whole where
        it must be."""
        if value is None:
            return
        number = float(value)
        whole = not self.whole or (not isinstance(value, bool) and number == int(number))
        if not (math.isfinite(number) and whole and self.lo <= number
                and (self.hi is None or number <= self.hi)):
            kind = "a whole number, " if self.whole else ""
            shown = f"{value:g}" if isinstance(value, float) else value
            raise InputError(f"{self.flag} {shown}: must be {kind}{self.span()}")


class Limits(dict):
    """A bench's numbers by argument name (name → :class:`Limit`)."""

    def check(self, **values) -> None:
        """Refuse the first of ``values`` (argument name → value, or an iterable of values for a repeatable
        option) that its :class:`Limit` does not allow."""
        for name, value in values.items():
            for one in (value if isinstance(value, (list, tuple)) else (value,)):
                self[name].check(one)


_SIZE = "Longer side of the photo, pixels."
PIPELINE = Limits(
    size=Limit("--size", _SIZE, 64, 8192, 880, whole=True),
    repeats=Limit("--repeats", "Builds to time.", 1, 50, 3, whole=True),
)
RENDER = Limits(
    size=Limit("--size", "Longer side of the photo and of the frames, pixels.", 64, 4096, 880, whole=True),
    seconds=Limit("--seconds", "Simulated (and rendered) seconds.", 0.1, 30, 1.0),
)
BATCH = Limits(
    size=Limit("--size", _SIZE, 64, 4096, 320, whole=True),
    seconds=Limit("--seconds", "Simulated seconds per shot.", 0.1, 30, 1.0),
    fps=Limit("--fps", "Frames per second.", 1, 120, 30.0),
)
SCALE = Limits(
    repeats=Limit("--repeats", "Rounds over the sizes, alternating (medians are reported).", 1, 20, 1, whole=True),
)
LOOK = Limits(
    size=Limit("--size", "Longer side of the rendered frames, pixels.", 64, 4096, 880, whole=True),
    seconds=Limit("--seconds", "Simulated seconds", 0.1, 30, None, default_text="each example's own"),
)
PHOTOS = Limits(
    pitches=Limit("--pitch", "Camera pitch of a synthetic scene, degrees; repeatable", 0, 89.5, None,
                  default_text="5, 30, 60 and 85"),
    seconds=Limit("--seconds", "Simulated seconds of each run (0: build only).", 0, 60, 0.5),
)
GENERAL = Limits(
    n=Limit("--n", "How many scenes to generate and build.", 1, 1000, 10, whole=True),
    seed=Limit("--seed", "Seed of the run (scene i is drawn from seed × 1000 + i)", 0, 10**9, None, whole=True,
               default_text="a new one, printed"),
    seconds=Limit("--seconds", "Simulated seconds with nothing pushed.", 0.1, 60, 2.0),
    materials=Limit("--materials", "Per scene, this many objects (drawn from the scene's seed) switched in turn to "
                                   "mpm_elastic, mpm_sand and pbd_cloth on the first build, each simulated 1 s: "
                                   "no stop, nothing non-finite (minutes per object on a CPU).", 0, 100, 0,
                    whole=True),
)
PEER = Limits(
    repeats=Limit("--repeats", "Timed runs of each engine per case, alternating.", 1, 20, 3, whole=True),
    seconds=Limit("--seconds", "Simulated seconds a run.", 0.1, 20.0, 2.0),
)
