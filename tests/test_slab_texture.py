"""What a slab (an extruded outline: the bundled motorcycle) shows once it moves or a camera orbits it: nothing
painted behind objects its placed mesh stands in front of."""

from __future__ import annotations

import json
import pathlib

import pytest
from pxr import Usd

import physomni_usd as api
from physomni_usd.render.video import ShotRenderer

EXAMPLE = pathlib.Path(__file__).resolve().parents[1] / "examples" / "motorcycle"


@pytest.fixture(scope="module")
def motorcycle(tmp_path_factory):
    spec = json.loads((EXAMPLE / "example.json").read_text())
    out = tmp_path_factory.mktemp("motorcycle") / "shot"
    result = api.build(EXAMPLE / spec["photo"], out, [str(EXAMPLE / m) for m in spec["masks"]])
    stage = Usd.Stage.Open(str(result.shot))
    return json.loads((out / "report.json").read_text()), ShotRenderer(stage)


def test_nothing_is_painted_behind_what_the_placed_meshes_put_behind(motorcycle):
    # the motorcycle's convex closure takes in the bench and the bin behind it, so the photo's order says they
    # hide it; its mesh stands in front of both, and a grey fill there would follow it as a slab once it moves
    report, renderer = motorcycle
    order = {(o["front"], o["behind"]): o["kept"] for o in report["stages"]["build"]["occlusion"]}
    bike = next(o for o in report["objects"] if o["name"].startswith("motorcycle"))
    assert set(bike["occluded_by"]) == {"bench_1", "bin_2"}
    assert all(order[(k, bike["name"])] < 0.5 for k in bike["occluded_by"])
    assert bike["completed"]["pixels"] == 0
    k = next(i for i, o in enumerate(renderer.objects) if o.path.endswith(bike["name"]))
    photo_half = renderer.objects[k].texture[:, : renderer.objects[k].texture.shape[1] // 2, 3]
    assert not (photo_half == 254).any()

