"""Support is what the photo shows (issue 38, part 3): a block the photo shows on a larger block rests on it, not
on the ground behind it, and stays there; a box that rests on nothing the masks show (hung on a wall, on a shelf)
stands where its size agrees with the others', held there, not on the floor far behind."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import trimesh

from physomni_usd.align.support import RAISE_RATIO, raise_unseen
from physomni_usd.bench.real_photos import rest_check
from physomni_usd.bench.synthetic import render_truth
from physomni_usd.building import build_shot
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.metrics.geometry import world_meshes
from physomni_usd.usd import layers

CAMERA = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -0.55, 0.35))


def _box(size, at):
    b = trimesh.creation.box(size)
    b.apply_translation([at[0], at[1], at[2] + size[2] / 2])
    return b


def _write(folder, truth, labels):
    photo, masks = render_truth(CAMERA, truth, np.random.default_rng(5))
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(photo, cv2.COLOR_RGB2BGR))
    specs = []
    for k, (m, label) in enumerate(zip(masks, labels)):
        cv2.imwrite(str(folder / f"m{k}.png"), m.astype(np.uint8) * 255)
        specs.append(f"{folder / f'm{k}.png'}:{label}")
    return specs


def test_a_block_on_a_bigger_block_rests_on_it_and_stays(tmp_path):
    truth = [_box((0.30, 0.20, 0.10), (0, 0, 0)), _box((0.08, 0.08, 0.08), (-0.06, 0.02, 0.10)),
             _box((0.07, 0.07, 0.07), (0.25, -0.05, 0.0))]
    specs = _write(tmp_path, truth, ["block"] * 3)
    build_shot(tmp_path / "photo.png", tmp_path / "shot", masks=specs)
    report = json.loads((tmp_path / "shot" / "report.json").read_text())
    starts = {o["name"]: o["start"] for o in report["objects"]}
    assert starts["block_1"]["support"] == "block_0", starts
    meshes = world_meshes(layers.open_shot(tmp_path / "shot"), 0)
    lower, upper = meshes["block_0"], meshes["block_1"]
    # it rests on the top of the lower block: its base within 1 cm of that top, its middle over it
    assert abs(upper.vertices[:, 2].min() - lower.vertices[:, 2].max()) <= 0.01
    lo, hi = lower.vertices[:, :2].min(0), lower.vertices[:, :2].max(0)
    assert np.all(upper.centroid[:2] >= lo) and np.all(upper.centroid[:2] <= hi)
    rest = rest_check(tmp_path / "shot" / "shot.usda", seconds=2.0)
    assert rest["max_drift_m"] <= 0.01 and rest["max_turn_deg"] <= 5.0, rest
    end = layers.open_shot(tmp_path / "shot")
    after = world_meshes(end, end.GetEndTimeCode())
    assert abs(after["block_1"].vertices[:, 2].min() - after["block_0"].vertices[:, 2].max()) <= 0.01


def test_a_box_on_no_mask_stands_where_its_size_agrees_with_the_others_held_there(tmp_path):
    # two boxes on the floor and a third, their size, 25 cm up behind them (on a wall or shelf the photo
    # shows no mask of): stood on the floor its foot's ray lands far behind, and it comes out twice too big
    truth = [_box((0.12, 0.12, 0.12), (-0.12, 0.05, 0.0)), _box((0.12, 0.12, 0.12), (0.12, 0.0, 0.0)),
             _box((0.12, 0.12, 0.12), (0.0, 0.35, 0.25))]
    specs = _write(tmp_path, truth, ["box"] * 3)
    build_shot(tmp_path / "photo.png", tmp_path / "shot", masks=specs)
    report = json.loads((tmp_path / "shot" / "report.json").read_text())
    objs = {o["name"]: o for o in report["objects"]}
    assert objs["box_2"]["start"]["support"] == "held" and objs["box_2"].get("fixed"), objs["box_2"]
    meshes = world_meshes(layers.open_shot(tmp_path / "shot"), 0)
    sizes = {k: float(np.ptp(m.vertices, axis=0).max()) for k, m in meshes.items()}
    # the same size as its neighbours, not twice it, and off the floor
    assert sizes["box_2"] <= 1.3 * max(sizes["box_0"], sizes["box_1"]), sizes
    assert meshes["box_2"].vertices[:, 2].min() >= 0.1 * sizes["box_0"] / 0.12
    rest = rest_check(tmp_path / "shot" / "shot.usda", seconds=1.0)
    assert rest["max_drift_m"] <= 0.01, rest


class _Lifted:
    def __init__(self, vertices):
        self.vertices = np.asarray(vertices, float)
        self.contact = self.vertices[np.argmin(self.vertices[:, 1])]
        self.info = {}


@pytest.mark.parametrize("far", [False, True])
def test_raise_unseen_moves_only_an_oversized_object_behind_the_others(far):
    camera = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -1.0, 1.0))
    near = [_box((0.1, 0.1, 0.1), (-0.15, 0.0, 0.0)), _box((0.1, 0.1, 0.1), (0.15, 0.0, 0.0))]
    # the third is three times their size: behind them (far) it is raised, beside them it is left alone
    big = _box((0.3, 0.3, 0.3), (0.0, 1.0, 0.0) if far else (0.5, -0.1, 0.0))
    lifted = [_Lifted(m.vertices) for m in near + [big]]
    before = lifted[2].vertices.copy()
    supports = {}
    done = raise_unseen(lifted, ["box", "box", "box"], supports, camera)
    if not far:
        assert done == {} and np.array_equal(lifted[2].vertices, before)
        return
    assert done[2]["size_ratio"] > RAISE_RATIO and done[2].get("held")
    # nearer along the camera's rays: the same outline, a third the size, off the floor
    uv0, _ = camera.project(before)
    uv1, _ = camera.project(lifted[2].vertices)
    assert np.allclose(uv0, uv1, atol=1e-6)
    assert np.ptp(lifted[2].vertices, axis=0).max() == pytest.approx(0.1, rel=0.05)
    assert lifted[2].vertices[:, 2].min() > 0.3


def test_raise_unseen_leaves_one_that_holds_up_the_top_of_a_pile_from_behind():
    # the same oversized box behind the others, but read as holding up one the photo showed on it (the back
    # fruit of a pile, on the ground behind the top one it holds: ``align.photo_scene.lift_all``'s ``holds``)
    camera = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -1.0, 1.0))
    near = [_box((0.1, 0.1, 0.1), (-0.15, 0.0, 0.0)), _box((0.1, 0.1, 0.1), (0.15, 0.0, 0.0))]
    lifted = [_Lifted(m.vertices) for m in near + [_box((0.3, 0.3, 0.3), (0.0, 1.0, 0.0))]]
    lifted[2].info["holds"] = [0]
    before = lifted[2].vertices.copy()
    assert raise_unseen(lifted, ["box", "box", "box"], {}, camera) == {}
    assert np.array_equal(lifted[2].vertices, before)
