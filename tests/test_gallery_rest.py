"""The regression net of a holistic scene: every bundled example and every real bench photo, nothing pushed, stays
where the photo put it.

Each case is built once per session (the ``built_case`` fixture of tests/conftest.py, which other modules'
frame-0 checks share) as a user would build it (the example's masks, boxes and sizes, or the photo's records in
``bench/real/photos.json``; no pushes, no forces) and a copy of it simulated for 2 s at the shot's frame rate through
``physomni_usd.simulate``, the function ``simulate`` runs (an exception here is a non-zero exit there). Then:

- the simulation finished;
- every *rigid* object's largest point displacement over the take is at most 1 cm, and its largest turn at
  most 5° (a small thing that tips over moves its points less than a centimetre). Sand, water, jelly and cloth
  are meant to move under gravity, so in those examples only their rigid objects (the crates) are held still;
  the MPM ones (jelly, water) run at a particle spacing of 10 cm (``PARTICLE_SPACING_M``) to keep time down —
  the crates' rest does not depend on it;
- no two objects' meshes start deeper in each other than 2 mm (signed distances, mesh against mesh);
- no solid is thinner than a third of its outline's smaller side unless its label or outline says flat
  (``metrics.geometry.thin_side``).

An example with no rigid object at all (the sand) has nothing to hold still: only its start is checked, and it is
not simulated here (``tests/test_deformables.py`` runs it).

A case that does not hold on today's code is marked ``xfail(strict=True)`` with the figures measured when the
mark was set: once a change to perceive or align fixes it, it XPASSes and fails the run — remove its mark then.
"""

from __future__ import annotations

import json
import re
import pathlib

import pytest

import physomni_usd as api
from physomni_usd.bench.real_photos import (REST_DRIFT_M, REST_SECONDS, START_OVERLAP_M, load_photo, load_truth,
                                            rest_check, write_inputs)

from .conftest import copy_of

#: Issue 38: nothing unpushed turns more than this in the take, degrees.
REST_TURN_DEG = 5.0

#: The whole net builds and simulates every example and bench photo: 15-20 minutes on a loaded 2-core machine.
#: Quicker tests run each command it runs (build, simulate).
pytestmark = pytest.mark.slow

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
SPECS = {p.parent.name: p for p in sorted(EXAMPLES.glob("*/example.json"))}
PHOTOS = load_truth()
PARTICLE_SPACING_M = 0.1
DEFORMABLE = {"cloth", "jelly", "sand", "water"}

#: Cases that fail on the code the net was cast on, with what was measured (see the module's docstring).
KNOWN: dict[str, str] = {}


def _cases():
    out = []
    for kind, names in (("example", SPECS), ("photo", PHOTOS)):
        for name in names:
            case = f"{kind}:{name}"
            marks = [pytest.mark.xfail(strict=True, reason=KNOWN[case])] if case in KNOWN else []
            out.append(pytest.param(case, marks=marks, id=case))
    return out


def _has_rigid(shot) -> bool:
    from physomni_usd.physics.objects import scene_objects
    from physomni_usd.usd import layers

    return any(o.family == "rigid" for o in scene_objects(layers.open_shot(shot)))


@pytest.mark.parametrize("case", _cases())
def test_nothing_pushed_nothing_moves(case, built_case, tmp_path):
    result, _ = built_case(case)
    name = case.split(":", 1)[1]
    if not _has_rigid(result.shot):  # the sand: nothing is meant to stay; only its start is checked
        from physomni_usd.metrics.geometry import max_penetration, world_meshes
        from physomni_usd.usd import layers

        stage = layers.open_shot(result.shot)
        deepest = max_penetration(world_meshes(stage, stage.GetStartTimeCode()))
        assert deepest <= START_OVERLAP_M, f"{case}: meshes start {deepest} m in each other"
        return
    spacing = PARTICLE_SPACING_M if case.startswith("example:") and name in DEFORMABLE else None
    result = copy_of(result, tmp_path / "shot")  # simulated here: the session's build stays as built
    rest = rest_check(result.shot, seconds=REST_SECONDS, particle_spacing=spacing)
    print(f"{case}: worst drift {1000 * rest['max_drift_m']:.1f} mm, turn {rest['max_turn_deg']:.1f}° of "
          f"{len(rest['rigid'])} rigid, worst start overlap {1000 * rest['max_overlap_m']:.1f} mm")  # under -s
    moved = {k: v for k, v in rest["drift_m"].items() if v > REST_DRIFT_M}
    turned = {k: v for k, v in rest["turn_deg"].items() if v > REST_TURN_DEG}
    deep = {k: v for k, v in rest["overlap_m"].items() if v > START_OVERLAP_M}
    assert not moved and not turned and not deep, (
        f"{case}: moved (m) {moved}; turned (°) {turned}; start overlaps (m) {deep}; worst drift "
        f"{rest['max_drift_m']} m, worst turn {rest['max_turn_deg']}°, worst overlap {rest['max_overlap_m']} m")


@pytest.mark.parametrize("case", [p.values[0] for p in _cases()])  # KNOWN marks the rest, not this
def test_no_solid_is_thinner_than_its_outline_allows(case, built_case):
    """Issue 38: a third of the outline's smaller side at least (a ball-shaped label round in depth), unless
    the label or the outline says flat; on the shot as built (its start)."""
    from physomni_usd.bench.alignment import _built_camera
    from physomni_usd.metrics.geometry import thin_side, world_meshes
    from physomni_usd.usd import layers

    result, _ = built_case(case)
    report = json.loads((result.folder / "report.json").read_text())
    stage = layers.open_shot(result.shot)
    shot = report["shot"]
    camera = _built_camera(stage, shot["fov_deg"], shot["width"], shot["height"])
    meshes = world_meshes(stage, stage.GetStartTimeCode())
    thin = {o["name"]: (round(t["thickness_m"], 4), round(t["side_m"], 4)) for o in report["objects"]
            if o["name"] in meshes and (t := thin_side(meshes[o["name"]].vertices, o["label"], camera.origin))}
    assert not thin, f"{case}: (thickness, outline's smaller side) m {thin}"


def test_every_example_and_photo_is_a_case():
    ids = {p.values[0] for p in _cases()}
    assert {f"example:{n}" for n in SPECS} | {f"photo:{n}" for n in PHOTOS} == ids
    assert len(SPECS) >= 8 and len(PHOTOS) >= 9
    assert set(KNOWN) <= ids, sorted(set(KNOWN) - ids)


# --- sizes and pitch on the same builds (issue 21's acceptance: identical objects alike, table tops under 1 m,
# disagreeing priors named, a top-down photo of flat parts seen top-down) ---------------------------------------

#: Photos of things on a table, a desk or a lightbox: nothing in them is larger than a metre.
TABLE_TOP = ("desk", "smarties", "coffee", "rubberwhale", "fruits", "heap", "parts")
#: Photos of identical objects: they must come out within 1.3× of each other.
IDENTICAL = ("smarties", "parts")
KNOWN_SIZES: dict = {}


def _sizes(result) -> dict[str, tuple[str, float]]:
    from physomni_usd.bench.real_photos import _longest

    return _longest(result.folder)


def _mark(key):
    return [pytest.mark.xfail(strict=True, reason=KNOWN_SIZES[key])] if key in KNOWN_SIZES else []


@pytest.mark.parametrize("name", [pytest.param(n, marks=_mark(("identical", n)), id=n) for n in IDENTICAL])
def test_identical_objects_come_out_alike(name, built_case):
    result, _ = built_case(f"photo:{name}")
    sizes = [m for _, m in _sizes(result).values()]
    assert max(sizes) <= 1.3 * min(sizes), f"{name}: {min(sizes):.3f}-{max(sizes):.3f} m"


@pytest.mark.parametrize("name", [pytest.param(n, marks=_mark(("table", n)), id=n) for n in TABLE_TOP])
def test_nothing_on_a_table_top_is_larger_than_a_metre(name, built_case):
    result, _ = built_case(f"photo:{name}")
    big = {k: round(m, 2) for k, (_, m) in _sizes(result).items() if m > 1.0}
    assert not big, f"{name}: {big} m"


@pytest.mark.parametrize("labels", [pytest.param(("whale", "box"), marks=_mark(("priors", "whale")), id="whale-box")])
def test_disagreeing_size_priors_are_named_in_one_warning(labels, tmp_path):
    """The rubber whale photo as the issue tells it: the toy labelled 'whale' (a 15 m animal in the size table)
    beside the yellow toy box labelled 'box' (0.4 m): one warning names both, and neither is over a metre."""
    record = PHOTOS["rubberwhale"]
    path, _, _ = write_inputs({**record, "objects": []}, load_photo(record), tmp_path / "input")
    boxes = [f"215,88,320,186:{labels[0]}", f"392,250,584,388:{labels[1]}"]  # the yellow box runs out of frame
    said = []
    result = api.build(path, tmp_path / "shot", [], boxes, echo=said.append)
    # the objects by name (whale_0, box_1): a line merely mentioning --box is not one naming the box
    naming = [ln for ln in said if "warning" in ln.lower() and all(re.search(rf"\b{lab}_\d", ln) for lab in labels)]
    sizes = {k: round(m, 2) for k, (_, m) in _sizes(result).items()}
    assert len(naming) == 1 and max(sizes.values()) <= 1.0, f"warnings {naming}; sizes {sizes} m"


@pytest.mark.parametrize("name", [pytest.param("parts", marks=_mark(("pitch", "parts")))])
def test_flat_parts_from_above_are_seen_from_above(name, built_case):
    result, _ = built_case(f"photo:{name}")
    pitch = json.loads((result.folder / "report.json").read_text())["shot"]["pitch_deg"]
    assert pitch >= 70.0, f"{name}: pitch {pitch:.1f}°"


@pytest.mark.parametrize("pitch", [pytest.param(p, marks=_mark(("given pitch", p)), id=f"pitch{p:g}")
                                   for p in (0.0, 30.0, 60.0, 90.0)])
def test_a_given_pitch_builds_the_parts(pitch, tmp_path):
    from physomni_usd.settings import BuildSettings, CameraSettings

    record = PHOTOS["parts"]
    path, masks, boxes = write_inputs(record, load_photo(record), tmp_path / "input")
    result = api.build(path, tmp_path / "shot", masks, boxes, BuildSettings(camera=CameraSettings(pitch_deg=pitch)))
    big = {k: round(m, 2) for k, (_, m) in _sizes(result).items() if m > 1.0}
    assert not big, f"--pitch {pitch:g}: {big} m"


def test_the_lime_behind_the_lemon_is_placed_behind_it_and_resting(built_case):
    """The fruit pile: the lemon hides the lime's lower part, so the lime stands behind the lemon (the placed
    meshes keep the photo's occlusion where it shows) and rests on what holds it, not in the air."""
    result, _ = built_case("photo:fruits")
    report = json.loads((result.folder / "report.json").read_text())
    order = {(o["front"], o["behind"]): o["kept"] for o in report["stages"]["build"]["occlusion"]}
    names = {o["label"]: o["name"] for o in report["objects"]}
    lime = next(o for o in report["objects"] if o["label"] == "lime")
    assert order[(names["lemon"], names["lime"])] >= 0.9, order
    assert abs(lime["start"]["clearance_m"]) <= 0.002, lime["start"]


def test_the_book_leaning_behind_the_boxes_comes_out_its_size(built_case):
    """The heap: two boxes hide the book's lower half; it must come out near its 24 cm, not metres tall."""
    result, _ = built_case("photo:heap")
    book = [m for label, m in _sizes(result).values() if label == "book"]
    assert len(book) == 1 and 0.24 / 1.5 <= book[0] <= 0.24 * 1.5, book
