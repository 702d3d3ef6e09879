"""The scene's one unknown scale, fixed from what the objects' labels say about their sizes.

A single photo fixes shapes and positions up to one scale. Each object whose
label has a typical size (``physomni_usd/sizes.py``) votes with the log of
(typical longest dimension / lifted longest dimension); the votes' median,
then the mean of the votes within max(3 MADs, log 1.5) of it, gives the
scale, so one mislabelled or badly cut object cannot drag the scene. Sizes the
user gives (``--size LABEL=METRES``, longest dimension) replace the votes;
``--camera-height`` replaces them too. With neither, nor any label in the
table, the camera is taken to stand 1 m above the ground, as before.

A label of things made in every size (``BROAD_LABELS``: a box, a toy, a
plant, a pot) votes only when no label of a narrower size does, or when the
narrower ones are more than ``DISAGREE_FACTOR`` off it: a card or a cup says
the scale, a box's typical size only guesses it.
Objects of one label are one thing seen several times: they vote once, with
the median of their sizes, so that eleven sweets do not outvote the one cup.
When the votes disagree by more than ``DISAGREE_FACTOR`` (a whale among toys,
a car on a desk: no single scale makes both labels right), averaging them
gives a scene that is wrong for all; instead each reading (the votes that
agree with one another) is tried, and the one whose camera a person could
hold (at most ``MAX_HANDHELD_M`` above the ground) under which no thing of a
table-top scene grows past ``TABLE_TOP_MAX_M`` wins; among equals, the one
with most labels; readings that are still equal share the scale (the robust
mean of their votes). The losers, or the compromise, are named in
``warnings``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..sizes import size_prior

#: Votes farther than this (natural log) from the median are outliers even when the MAD is tiny.
MIN_OUTLIER_LOG = math.log(1.5)
DEFAULT_CAMERA_HEIGHT_M = 1.0
#: Votes further apart than this factor cannot both be right: the scene is read one way or the other.
DISAGREE_FACTOR = 3.0
#: A photo of things a person handles is taken from at most this high (metres).
MAX_HANDHELD_M = 3.0
#: Labels whose typical size is at most this are table-top things; under a reading, nothing in a photo of
#: them grows past it (metres).
TABLE_TOP_MAX_M = 1.0
#: Labels of things made in every size (a ring box or a moving carton, a figurine or a plush, a seedling or a
#: shrub, a flower pot or a stock pot): their typical size is a guess, not a measure, so they vote on the scale
#: only when no label of a narrower size (a card, a coin, a cup, a fruit, a bottle, a book) does, or when the
#: narrower ones read a scale more than DISAGREE_FACTOR off theirs (a card hung on a wall lifted as if it
#: stood far off on the ground: one failed lift must not size the scene). Keywords of ``physomni_usd/sizes.py``.
BROAD_LABELS = frozenset({"box", "toy", "figure", "plant", "flower", "pot", "bag", "basket", "package", "parcel",
                          "bin", "crate", "container"})
#: An object whose vote is this many times off a reading's scale is a failed lift under it, not a thing that
#: size: it does not stop the reading from being a table top (it is that reading's outlier, and reported so).
FAILED_LIFT_FACTOR = 10.0


@dataclass
class ScaleFit:
    factor: float  # multiply the scene (built under a camera at height_unit) by this
    source: str  # 'size' | 'camera-height' | 'priors' | 'default'
    votes: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # votes overruled because no scale agrees with them
    readings: list[dict] = field(default_factory=list)  # the readings tried when the votes disagreed

    def as_dict(self, camera_height_m: float) -> dict:
        return {"factor": round(self.factor, 6), "source": self.source, "camera_height_m": round(camera_height_m, 4),
                "votes": self.votes} | ({"warnings": self.warnings, "readings": self.readings}
                                        if self.warnings or self.readings else {})


def parse_sizes(specs, objects) -> dict[str, float]:
    """``['coin=0.024']`` → ``{'coin_0': 0.024}``; ``objects`` are (prim name, label) pairs.

    LABEL is a label (every object carrying it) or a prim name; the size is the
    object's longest dimension in metres.
    """
    out = {}
    for spec in specs or ():
        key, sep, value = str(spec).partition("=")
        key = key.strip()
        try:
            metres = float(value)
        except ValueError:
            metres = float("nan")
        if not sep or not key:
            raise InputError(f"--size {spec!r}: expected LABEL=METRES, e.g. coin=0.024")
        if not math.isfinite(metres) or not 1e-4 <= metres <= 1e4:
            raise InputError(f"--size {spec!r}: the size must be a number of metres in [0.0001, 10000]")
        hits = [name for name, label in objects if key in (name, label)]
        if not hits:
            known = ", ".join(sorted({label for _, label in objects})) or "none"
            raise InputError(f"--size {spec!r}: no object labelled {key!r} (known: {known})")
        out.update(dict.fromkeys(hits, metres))
    return out


def robust_log_mean(logs) -> tuple[float, np.ndarray]:
    """Mean of the values within max(3·1.4826·MAD, log 1.5) of their median, and the inlier flags."""
    x = np.asarray(logs, float)
    med = float(np.median(x))
    mad = 1.4826 * float(np.median(np.abs(x - med)))
    inlier = np.abs(x - med) <= max(3.0 * mad, MIN_OUTLIER_LOG)
    return float(x[inlier].mean()), inlier


def fit_scale(names, labels, longest_m, user_sizes: dict[str, float] | None = None,
              camera_height_m: float | None = None, unit_height_m: float = DEFAULT_CAMERA_HEIGHT_M) -> ScaleFit:
    """The factor taking a scene lifted under a camera ``unit_height_m`` high to real metres.

    ``longest_m`` are the objects' longest dimensions as lifted. Order of
    authority: ``user_sizes`` (prim name → metres), then ``camera_height_m``,
    then the label priors, then a camera 1 m high.
    """
    user_sizes = user_sizes or {}
    votes = []
    for name, label, size in zip(names, labels, longest_m):
        prior = size_prior(label)
        vote = {"name": name, "label": label, "measured_m": round(float(size), 5)}
        if name in user_sizes:
            vote |= {"size_m": user_sizes[name], "from": "user"}
        elif prior is not None and prior.votes:
            vote |= {"size_m": prior.longest_m, "from": f"prior '{prior.keyword}'"}
        else:
            vote |= {"size_m": None, "from": "no typical size" if prior else "label not in the size table"}
        votes.append(vote)
    users = [v for v in votes if v["from"] == "user" and v["measured_m"] > 0]
    if users:
        logs = [math.log(v["size_m"] / v["measured_m"]) for v in users]
        mean, _ = robust_log_mean(logs)
        return ScaleFit(math.exp(mean), "size", votes)
    if camera_height_m is not None:
        return ScaleFit(camera_height_m / unit_height_m, "camera-height", votes)
    priors = [v for v in votes if v["size_m"] is not None and v["measured_m"] > 0]
    narrow = [v for v in priors if v["from"] not in {f"prior '{k}'" for k in BROAD_LABELS}]
    broad = [v for v in priors if v not in narrow]
    if narrow and broad and abs(_votes_log(narrow) - _votes_log(broad)) <= math.log(DISAGREE_FACTOR):
        for v in priors:
            if v not in narrow:
                v |= {"inlier": False, "broad": "a label of things made in every size: it votes only where no "
                                                "narrower one does"}
        priors = narrow
    if priors:
        return _fit_priors(priors, votes, unit_height_m)
    return ScaleFit(DEFAULT_CAMERA_HEIGHT_M / unit_height_m, "default", votes)


def _votes_log(votes: list[dict]) -> float:
    """The robust mean of ``votes``' log(typical / measured)."""
    return robust_log_mean([math.log(v["size_m"] / v["measured_m"]) for v in votes])[0]


def _fit_priors(priors: list[dict], votes: list[dict], unit_height_m: float) -> ScaleFit:
    """The label priors' scale: one vote per label, and one reading of the scene where the votes disagree."""
    by_label: dict[str, list[dict]] = {}
    for v in priors:
        by_label.setdefault(v["from"], []).append(v)
    labels = list(by_label)
    logs = np.array([math.log(by_label[k][0]["size_m"] / float(np.median([v["measured_m"] for v in by_label[k]])))
                     for k in labels])
    mean, inlier = robust_log_mean(logs)
    readings, warnings = [], []
    if float(np.ptp(logs)) > math.log(DISAGREE_FACTOR):
        # every group of labels agreeing within the factor is a reading of the scene
        tried = []
        for seed in np.argsort(logs):
            members = np.abs(logs - logs[seed]) <= math.log(DISAGREE_FACTOR)
            m, _ = robust_log_mean(logs[members])
            factor = math.exp(m)
            # what grows past a metre under this reading, leaving out lifts that are absurd under it
            sane = np.abs(logs - m) <= math.log(FAILED_LIFT_FACTOR)
            biggest_m = max(v["measured_m"] for k, ok in zip(labels, sane) if ok for v in by_label[k]) * factor
            table_top = all(by_label[k][0]["size_m"] <= TABLE_TOP_MAX_M for k, ok in zip(labels, members) if ok)
            plausible = factor * unit_height_m <= MAX_HANDHELD_M
            reading = {"labels": [by_label[k][0]["label"] for k, ok in zip(labels, members) if ok],
                       "factor": round(factor, 6), "camera_height_m": round(factor * unit_height_m, 4),
                       "plausible": plausible, "largest_m": round(biggest_m, 4)}
            if reading["labels"] in [r["labels"] for r in readings]:
                continue
            readings.append(reading)
            # a person's camera first, then a table-top scene with nothing past a metre (a generic 'box' prior
            # outvoting a book's must not make the book a metre tall), then most labels
            tried.append(((plausible, not (table_top and biggest_m > TABLE_TOP_MAX_M), int(members.sum())), members))
        top = max(key for key, _ in tried)
        chosen = np.logical_or.reduce([members for key, members in tried if key == top])
        if chosen.sum() < len(labels):
            mean, inlier = robust_log_mean(logs[chosen])[0], chosen
        winners = [v["name"] for k, ok in zip(labels, chosen) if ok for v in by_label[k]]
        losers = [v["name"] for k, ok in zip(labels, chosen) if not ok for v in by_label[k]]
        if losers:
            warnings.append(f"typical sizes disagree by more than {DISAGREE_FACTOR:g}×: {', '.join(losers)} against "
                            f"{', '.join(winners)}; the scale follows {', '.join(winners)} (a camera "
                            f"{math.exp(mean) * unit_height_m:.2g} m high), so {', '.join(losers)} "
                            f"{'is' if len(losers) == 1 else 'are'} not the size "
                            f"{'its label suggests' if len(losers) == 1 else 'their labels suggest'} "
                            f"(give --size to say otherwise)")
        else:  # no reading is better than another: their compromise, said so
            warnings.append(f"typical sizes disagree by more than {DISAGREE_FACTOR:g}× among {', '.join(winners)} "
                            f"and none reads the scene better; the scale is their compromise (a camera "
                            f"{math.exp(mean) * unit_height_m:.2g} m high; give --size to say otherwise)")
    for k, ok in zip(labels, inlier):
        for v in by_label[k]:
            v["inlier"] = bool(ok)
    return ScaleFit(math.exp(mean), "priors", votes, warnings, readings)
