"""The benches' own numbers — a photo's size, repeats, scene counts, simulated seconds — with their ranges
and defaults, one table per bench (:class:`~physomni_usd.limits.Limits`): each bench function checks its
arguments against its table before any work, and its ``bench`` command reads its options from it."""

from __future__ import annotations

import pathlib

from ..limits import Limit, Limits
from ..settings import RenderSettings

#: The bundled example a bench runs when none is named (a path in the project's checkout, where benches run).
EXAMPLE = pathlib.Path("examples/motorcycle")
#: ``bench batch``'s numbers of shots, ``bench scale``'s photo sizes (megapixels: the examples' sizes up to a
#: full-frame camera's, the --max-pixels cap) and its stages, when none are named.
BATCH_COUNTS = (1, 2, 4, 8)
SCALE_SIZES_MP = (0.3, 1.0, 4.0, 12.0, 40.0)
SCALE_STAGES = ("build", "simulate", "render")
#: ``bench scale --whole-box``: the photo's size (W, H: the 1.4 MP of issue 42's box over a whole frame) and
#: the clicks on and off the example's objects, drawn from one seed.
WHOLE_BOX = {"size": (1282, 1105), "on": 12, "off": 8, "seed": 0}

_SIZE = "Longer side of the photo, pixels."
PIPELINE = Limits(
    size=Limit("--size", _SIZE, 64, 8192, 880, whole=True),
    repeats=Limit("--repeats", "Builds to time.", 1, 50, 3, whole=True),
    seconds=Limit("--seconds", "Simulated seconds in the run.", None, None, 2.0),  # simulate itself checks the range
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
    seconds=Limit("--seconds", "Simulated seconds.", None, None, 3.0),  # simulate itself checks the range
    max_size=Limit("--max-size", "render --max-size.", None, None, RenderSettings.model_fields["max_size"].default,
                   whole=True),  # render's own default, and render checks it
    objects=Limit("--objects", "Boxes dropped in one run of the object axis", 1, 1000, None, whole=True,
                  default_text="none"),
    whole_box=Limit("--whole-box", "Each side of the whole-box photo, pixels", 128, 8192, None, whole=True,
                    default_text="none"),
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
