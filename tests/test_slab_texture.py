"""What a slab (an extruded outline: the bundled motorcycle) shows once it moves or a camera orbits it: nothing
painted behind objects its placed mesh stands in front of, and an open back rather than its front again."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest
from pxr import Usd

import physomni_usd as api
from physomni_usd.rendering.video import ShotRenderer

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


def test_a_slabs_back_is_open_not_its_front_again(motorcycle):
    _, r = motorcycle
    pts = r.points_at(Usd.TimeCode(0))[r.faces]
    n = np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    to_cam = r.photo_camera.origin - pts.mean(1)
    cos = np.einsum("ij,ij->i", n, to_cam / np.linalg.norm(to_cam, axis=1, keepdims=True))
    corner = r.corner_px.reshape(-1, 3, 2)
    alpha = r.atlas_alpha[corner[..., 1].astype(int), corner[..., 0].astype(int)]  # (F, 3)
    k = next(i for i, o in enumerate(r.objects) if "motorcycle" in o.path)
    mine = r.face_object == k
    back, front = mine & (cos <= -0.3), mine & (cos >= 0.3)
    assert back.sum() > 100 and front.sum() > 100
    assert (alpha[back] == 0).all()  # a ray through the front's cut-outs leaves through the back
    assert (alpha[front] > 0).any(axis=1).mean() > 0.5  # the front is still the photo
