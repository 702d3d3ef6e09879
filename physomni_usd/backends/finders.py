"""Objects found from words: the text-promptable finder protocol, ``--find`` phrases, and the objects they
give ``build`` (each labelled by its phrase, numbered after the masks and boxes).

A finder is a backend of kind ``finder`` (``physomni-sam3`` registers ``sam3``); none is built in.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from . import registry

#: The finder ``--find`` uses when ``--finder`` names none.
DEFAULT_FINDER = "sam3"


@runtime_checkable
class Finder(Protocol):
    def find(self, photo: np.ndarray, phrases: list[str]) -> list[list[np.ndarray]]:
        """For each phrase, the (H, W) bool mask of every instance of it in the photo (best first); an empty
        list where it found none."""


def parse_phrases(text: str | None) -> list[str]:
    """``'cup, saucer, spoon'`` → ``['cup', 'saucer', 'spoon']`` (empty parts dropped, repeats kept once)."""
    out = []
    for part in (text or "").split(","):
        phrase = " ".join(part.split())
        if phrase and phrase not in out:
            out.append(phrase)
    return out


def load_finder(text: str | None, name: str | None):
    """The finder to run for ``--find text``, loaded and checked ready (one line, exit 2, otherwise); None
    when there is nothing to find. Called before anything is computed."""
    from ..perceive.masks import checked_label

    for phrase in parse_phrases(text):  # each phrase labels the objects it finds, and so names files
        checked_label(phrase, "--find", text)
    if not parse_phrases(text):
        if text is not None and text.strip(" ,") == "" and text != "":
            raise InputError(f"--find {text!r}: no phrase in it; e.g. --find 'cup, saucer, spoon'")
        if name:
            raise InputError(f"--finder {name} needs --find PHRASES, e.g. --find 'cup, saucer, spoon'")
        return None
    if name is None and not any(e.kind == "finder" for e in registry.entries()):
        raise InputError(f"--find {text!r} needs a text-promptable finder and none is installed: "
                         "pip install -e 'plugins/physomni-sam3[models]' and set PHYSOMNI_SAM3_WEIGHTS")
    return registry.load("finder", name or DEFAULT_FINDER)


def find_objects(photo: np.ndarray, text: str, finder, first_index: int, echo=lambda m: None) -> list:
    """The objects ``finder`` finds for the phrases of ``text``: ``ObjectMask`` each, labelled by its phrase
    and numbered from ``first_index`` on, phrase by phrase. Refuses (one line) a search that finds nothing."""
    from ..perceive.masks import MIN_MASK_PIXELS, ObjectMask

    phrases = parse_phrases(text)
    found = finder.find(photo, phrases)
    if len(found) != len(phrases):
        raise InputError(f"finder {type(finder).name} answered {len(found)} phrases for {len(phrases)}")
    objects = []
    for phrase, masks in zip(phrases, found):
        kept = [np.asarray(m, bool) for m in masks]
        kept = [m for m in kept if m.shape == photo.shape[:2] and MIN_MASK_PIXELS <= m.sum() < m.size]
        if not kept:
            echo(f"find: no {phrase!r} in the photo")
        for m in kept:
            index = first_index + len(objects)
            objects.append(ObjectMask(phrase, index, m, f"find:{phrase}", {"method": f"find:{type(finder).name}"}))
    if not objects:
        raise InputError(f"--find {text!r}: the {type(finder).name} finder found none of "
                         + ", ".join(repr(p) for p in phrases) + " in the photo; try other words, or --box")
    echo(f"find: {len(objects)} object(s): " + ", ".join(o.name for o in objects))
    return objects
