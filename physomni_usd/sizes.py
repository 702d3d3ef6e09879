"""Typical real-world sizes of everyday objects, looked up by keywords of an object's label.

Beside the material rules (``defaults.py``): a photo shows shapes up to one
unknown scale, and what a label says about an object's size is the best
built-in evidence of that scale. Each entry gives the longest dimension and
the height of the object as it usually rests on a surface (a pencil lies, a
bottle stands), in metres, and its usual shape: ``box``, ``round`` (a
cylinder or a disc), ``ball`` or ``long`` (a thin rod). Sizes are medians of
common products, rounded; real objects vary by a factor of about 1.5, which
the scale fit tolerates (see ``align/scale.py``).

Amorphous materials (sand, water, jelly, snow, …) have no typical size: they
are in the table so that their labels are recognised, but they never vote on
the scale.

A label is split into words (``tower_left`` → ``tower``, ``left``; plurals
lose their ``s``); a word that marks a toy or a model (``toy``, ``model``,
``rubber``, ``plastic``, ``miniature``, ``mini``) makes a large thing
toy-sized. The first keyword of the table found among the words wins.
``python -m physomni_usd.sizes`` prints the table as Markdown.

Besides sizes, a label says what kind of body the built-in lifter should
give an outline (:func:`body_kind`): ``organic`` things (fruit, toys, bags,
animals) are rounded, inflated solids; ``boxy`` ones (boxes, books) have
flat faces and square edges; ``vessel`` ones (bowls, basins, pots, buckets,
pans, dishes) are open containers, hollow, so what lies in them rests on
their inner floor; the rest take what their outline says.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class SizePrior:
    keyword: str
    longest_m: float | None  # None: no typical size (amorphous)
    height_m: float | None  # as it usually rests on a surface
    shape: str  # 'box' | 'round' | 'ball' | 'long' | 'any'

    @property
    def votes(self) -> bool:
        return self.longest_m is not None


def _p(keyword, longest, height, shape="box"):
    return SizePrior(keyword, longest, height, shape)


#: (keyword, longest m, resting height m, shape), most specific first.
SIZES: tuple[SizePrior, ...] = (
    # desk and pocket things
    _p("coin", 0.024, 0.002, "round"), _p("pencil", 0.19, 0.008, "long"), _p("pen", 0.14, 0.011, "long"),
    _p("marker", 0.13, 0.016, "long"), _p("crayon", 0.09, 0.009, "long"), _p("eraser", 0.05, 0.012),
    _p("cap", 0.03, 0.012, "round"), _p("lid", 0.08, 0.015, "round"), _p("lighter", 0.08, 0.012),
    _p("key", 0.06, 0.003), _p("card", 0.086, 0.001), _p("battery", 0.05, 0.014, "long"),
    _p("phone", 0.15, 0.008), _p("wallet", 0.11, 0.02), _p("watch", 0.045, 0.012, "round"),
    _p("glasses", 0.14, 0.04), _p("ruler", 0.3, 0.003, "long"), _p("scissors", 0.2, 0.012),
    _p("stapler", 0.15, 0.05), _p("tape", 0.1, 0.025, "round"), _p("notebook", 0.21, 0.012),
    _p("book", 0.24, 0.03), _p("laptop", 0.33, 0.02), _p("keyboard", 0.44, 0.03), _p("mouse", 0.11, 0.04),
    _p("remote", 0.18, 0.02), _p("letter", 0.06, 0.015), _p("shell", 0.08, 0.04), _p("dice", 0.016, 0.016),
    _p("die", 0.016, 0.016), _p("cube", 0.057, 0.057), _p("candle", 0.15, 0.15, "round"),
    _p("camera", 0.12, 0.08), _p("candy", 0.015, 0.008, "round"), _p("sweet", 0.015, 0.008, "round"),
    _p("button", 0.02, 0.003, "round"), _p("washer", 0.02, 0.002, "round"), _p("token", 0.025, 0.003, "round"),
    _p("ticket", 0.1, 0.001), _p("paper", 0.3, 0.001), _p("sheet", 0.3, 0.002), _p("tile", 0.1, 0.008),
    _p("part", 0.06, 0.005), _p("bracket", 0.06, 0.005), _p("chip", 0.03, 0.003, "round"),
    # kitchen and table
    _p("saucer", 0.15, 0.02, "round"), _p("plate", 0.26, 0.02, "round"), _p("tray", 0.4, 0.02),
    _p("bowl", 0.16, 0.07, "round"),
    _p("cup", 0.11, 0.095, "round"), _p("mug", 0.12, 0.095, "round"), _p("glass", 0.12, 0.12, "round"),
    _p("jar", 0.13, 0.13, "round"), _p("can", 0.12, 0.12, "round"), _p("bottle", 0.25, 0.25, "round"),
    _p("vase", 0.3, 0.3, "round"), _p("teapot", 0.22, 0.16, "round"), _p("kettle", 0.25, 0.22, "round"),
    _p("pot", 0.25, 0.15, "round"), _p("pan", 0.45, 0.06, "round"), _p("spoon", 0.17, 0.02, "long"),
    _p("fork", 0.19, 0.02, "long"), _p("knife", 0.22, 0.02, "long"), _p("spatula", 0.3, 0.03, "long"),
    _p("bread", 0.3, 0.12), _p("cake", 0.22, 0.1, "round"), _p("donut", 0.09, 0.03, "round"),
    _p("sandwich", 0.12, 0.05), _p("pizza", 0.3, 0.02, "round"),
    # fruit and vegetables
    _p("apple", 0.08, 0.08, "ball"), _p("orange", 0.08, 0.08, "ball"), _p("lemon", 0.07, 0.06, "ball"),
    _p("tomato", 0.07, 0.06, "ball"), _p("onion", 0.08, 0.08, "ball"), _p("potato", 0.1, 0.06, "ball"),
    _p("pear", 0.1, 0.1), _p("banana", 0.2, 0.04, "long"), _p("carrot", 0.18, 0.03, "long"),
    _p("egg", 0.06, 0.045, "ball"), _p("melon", 0.25, 0.2, "ball"), _p("watermelon", 0.35, 0.3, "ball"),
    _p("pumpkin", 0.3, 0.25, "ball"), _p("fruit", 0.08, 0.08, "ball"),
    # balls, toys and soft things
    _p("ball", 0.22, 0.22, "ball"), _p("balloon", 0.3, 0.3, "ball"), _p("teddy", 0.3, 0.3),
    _p("plush", 0.3, 0.25), _p("doll", 0.3, 0.1), _p("toy", 0.2, 0.12), _p("figure", 0.2, 0.2),
    _p("pillow", 0.5, 0.15), _p("cushion", 0.45, 0.12), _p("towel", 1.0, 0.5), _p("shoe", 0.28, 0.1),
    _p("hat", 0.3, 0.12), _p("helmet", 0.3, 0.25, "ball"), _p("bag", 0.4, 0.3), _p("backpack", 0.45, 0.45),
    _p("suitcase", 0.65, 0.65),
    # containers
    _p("box", 0.4, 0.3), _p("carton", 0.25, 0.2), _p("package", 0.35, 0.2), _p("parcel", 0.35, 0.2),
    _p("crate", 0.6, 0.4), _p("bin", 0.6, 0.45), _p("bucket", 0.3, 0.3, "round"), _p("basket", 0.4, 0.25),
    _p("barrel", 0.9, 0.9, "round"),
    # household
    _p("lamp", 0.5, 0.5), _p("clock", 0.3, 0.3, "round"), _p("plant", 0.4, 0.4), _p("flower", 0.3, 0.3),
    _p("speaker", 0.25, 0.25), _p("monitor", 0.55, 0.4), _p("tv", 1.1, 0.7), _p("guitar", 1.0, 0.35),
    _p("umbrella", 0.9, 0.1, "long"), _p("chair", 0.9, 0.9), _p("stool", 0.6, 0.6), _p("table", 1.2, 0.75),
    _p("desk", 1.2, 0.75), _p("bench", 1.5, 0.5), _p("shelf", 1.0, 1.0), _p("sofa", 2.0, 0.85),
    _p("bed", 2.0, 0.6), _p("door", 2.0, 2.0), _p("rock", 0.2, 0.12), _p("stone", 0.1, 0.06),
    _p("brick", 0.22, 0.065), _p("block", 0.05, 0.05), _p("cone", 0.7, 0.7, "round"),
    # animals and people
    _p("cat", 0.45, 0.25), _p("dog", 0.7, 0.55), _p("bird", 0.2, 0.15), _p("person", 1.7, 1.7),
    _p("man", 1.75, 1.75), _p("woman", 1.65, 1.65), _p("child", 1.2, 1.2), _p("whale", 15.0, 4.0),
    # vehicles and outdoor things
    _p("bicycle", 1.75, 1.05), _p("bike", 1.8, 1.05), _p("motorcycle", 2.1, 1.15), _p("scooter", 1.8, 1.1),
    _p("tyre", 0.65, 0.2, "round"), _p("tire", 0.65, 0.2, "round"), _p("wheel", 0.6, 0.2, "round"),
    _p("car", 4.5, 1.5), _p("van", 5.0, 2.0), _p("truck", 7.0, 3.0), _p("bus", 12.0, 3.2),
    _p("boat", 5.0, 1.5), _p("tree", 8.0, 8.0), _p("house", 10.0, 8.0), _p("building", 20.0, 20.0),
    _p("tower", 30.0, 30.0, "long"), _p("rocket", 50.0, 50.0, "long"), _p("vehicle", 4.5, 1.5),
    # amorphous: recognised, never a vote
    _p("sand", None, None, "any"), _p("water", None, None, "any"), _p("liquid", None, None, "any"),
    _p("jelly", None, None, "any"), _p("snow", None, None, "any"), _p("mud", None, None, "any"),
    _p("slime", None, None, "any"), _p("dough", None, None, "any"), _p("clay", None, None, "any"),
    _p("foam", None, None, "any"), _p("smoke", None, None, "any"),
)
_BY_KEY = {p.keyword: p for p in SIZES}
#: Words that make a large thing toy-sized ("rubber whale", "toy car", "model rocket").
TOY_WORDS = frozenset({"toy", "model", "rubber", "plastic", "miniature", "mini", "figurine"})
TOY = SizePrior("toy", 0.2, 0.12, "box")
#: Above this longest dimension a "toy" word shrinks the thing to TOY.
TOY_ABOVE_M = 0.5


def label_words(label: str) -> list[str]:
    """Lower-case words of a label, plurals reduced (``'Red_Cups'`` → ``['red', 'cup']``)."""
    words = [w for w in re.split(r"[^a-z]+", label.lower()) if w]
    out = []
    for w in words:
        out.append(w)
        if w.endswith("s") and len(w) > 3 and w[:-1] in _BY_KEY:
            out[-1] = w[:-1]
        elif w.endswith("es") and w[:-2] in _BY_KEY:
            out[-1] = w[:-2]
    return out


def size_prior(label: str) -> SizePrior | None:
    """The table's prior for the label's words (first table keyword found), or None if none matches."""
    words = label_words(label)
    found = None
    for p in SIZES:
        if p.keyword in words:
            found = p
            break
    if found is None:
        return TOY if TOY_WORDS & set(words) else None
    if TOY_WORDS & set(words) and found.longest_m is not None and found.longest_m > TOY_ABOVE_M:
        return SizePrior(f"{'+'.join(sorted(TOY_WORDS & set(words)))} {found.keyword}", TOY.longest_m,
                         TOY.height_m, found.shape)
    return found


#: Keywords of things with soft, rounded bodies: the lifter inflates their outline.
ORGANIC = frozenset({
    "apple", "orange", "lemon", "lime", "tomato", "onion", "potato", "pear", "banana", "carrot", "egg", "melon",
    "watermelon", "pumpkin", "fruit", "vegetable", "bread", "donut", "sandwich", "teddy", "plush", "doll", "toy",
    "figure", "figurine", "pillow", "cushion", "bag", "backpack", "shoe", "hat", "cat", "dog", "bird", "whale",
    "fish", "duck", "animal", "rock", "stone", "shell", "sponge", "mouse", "wallet"})
#: Keywords of things with flat faces and square edges: the lifter gives them a cuboid.
BOXY = frozenset({
    "box", "book", "notebook", "carton", "package", "parcel", "crate", "brick", "block", "cube", "dice", "die",
    "laptop", "keyboard", "phone", "remote", "stapler", "eraser", "lighter", "suitcase", "speaker", "monitor",
    "tv", "shelf", "bin", "cabinet", "drawer"})
#: Keywords of open round containers: seen from above their rim, the lifter makes them hollow
#: (``lift/vessel.py``). A tray is no such thing: it is lifted as the plate its outline shows.
VESSEL = frozenset({"bowl", "basin", "pot", "bucket", "pan", "dish"})


def body_kind(label: str) -> str | None:
    """'organic', 'boxy', 'vessel' or None (the outline decides) for a label, from its words (a toy word makes
    it organic)."""
    words = set(label_words(label))
    if words & VESSEL and not words & TOY_WORDS:
        return "vessel"
    if words & BOXY and not words & TOY_WORDS:
        return "boxy"
    if words & ORGANIC or words & TOY_WORDS:
        return "organic"
    return None


def markdown_table() -> str:
    """The table as Markdown rows (keyword, longest, height, shape), for the README."""
    rows = ["| keyword | longest | height | shape |", "|---|---:|---:|---|"]
    for p in SIZES:
        fmt = lambda m: "—" if m is None else (f"{m * 100:g} cm" if m < 1 else f"{m:g} m")  # noqa: E731
        rows.append(f"| {p.keyword} | {fmt(p.longest_m)} | {fmt(p.height_m)} | {p.shape} |")
    return "\n".join(rows)


if __name__ == "__main__":  # pragma: no cover
    print(markdown_table())
