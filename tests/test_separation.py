"""The last pass of placement (``align/separate.py``): whatever the cues before it did, ``build`` writes no scene
that ``simulate`` refuses. A block standing on a larger block is built from its photo's masks, with the placement
made to sink it 1 cm into the one under it (as a wrong pitch or a mask taking in part of the other does); the
build must come out with no start overlap deeper than the contact margin, or end with one line naming the pair."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from pxr import Usd

from physomni_usd.align import separate
from physomni_usd import building as build_module
from physomni_usd.building import build_shot
from physomni_usd.errors import PhysOmniError
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.metrics.geometry import max_penetration, world_meshes
from physomni_usd.physics.diagnose import first_error, scene_findings

from .conftest import rendered_blocks

CAMERA = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -0.55, 0.35))
SUNK_M = 0.01


def _box(size, at):
    b = trimesh.creation.box(size)
    b.apply_translation([at[0], at[1], at[2] + size[2] / 2])
    return b


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    """The photo and mask specs of a 8 cm block standing on a 30 cm one, and a 7 cm block beside them."""
    folder = tmp_path_factory.mktemp("stack")
    truth = [_box((0.30, 0.20, 0.10), (0, 0, 0)), _box((0.08, 0.08, 0.08), (-0.06, 0.02, 0.10)),
             _box((0.07, 0.07, 0.07), (0.25, -0.05, 0.0))]
    return folder, rendered_blocks(folder, CAMERA, truth)


@pytest.fixture
def sunk(monkeypatch):
    """The joint solve's result with whatever rests on another object sunk ``SUNK_M`` into it, or, where the
    test asks for it (``deep``), sunk half its height (deeper than ``simulate`` accepts)."""
    solve = build_module.solve_places
    depth = {"deep": False}

    def sinking(camera, verts, faces, masks, supports, *args, **kwargs):
        solved = solve(camera, verts, faces, masks, supports, *args, **kwargs)
        assert supports, "the photo shows a block on a block"
        for i in supports:
            v = solved.vertices[i]
            solved.vertices[i] = v - [0.0, 0.0, 0.5 * np.ptp(v[:, 2]) if depth["deep"] else SUNK_M]
        return solved

    monkeypatch.setattr(build_module, "solve_places", sinking)
    return depth


def test_a_block_sunk_1cm_into_the_one_under_it_is_built_simulable(stack, sunk, tmp_path):
    folder, specs = stack
    said = []
    build_shot(folder / "photo.png", tmp_path / "shot", masks=specs, echo=said.append)
    stage = Usd.Stage.Open(str(tmp_path / "shot" / "shot.usda"))
    findings = scene_findings(stage)
    assert first_error(findings) is None, [f.message for f in findings]
    assert not any(f.check == "penetration" for f in findings), [f.message for f in findings]
    assert max_penetration(world_meshes(stage, 0)) <= 0.002
    assert not any(line.startswith("check: error") for line in said), said
    report = json.loads((tmp_path / "shot" / "report.json").read_text())
    done = report["shot"]["alignment"]["separated"]
    assert done and done[0]["depth_mm"] >= 0.9 * SUNK_M * 1000 and done[0]["how"] in ("up", "apart", "shrink")
    # the remedy is the least change to the photo: the block rises back onto the one under it
    assert done[0]["how"] == "up" and done[0]["amount"] == pytest.approx(SUNK_M, abs=0.003)


def test_a_pair_no_pass_separates_ends_the_build_in_one_line_naming_it(stack, sunk, tmp_path, monkeypatch):
    folder, specs = stack
    sunk["deep"] = True
    monkeypatch.setattr(separate, "MAX_PASSES", 0)  # as if no remedy could part them
    with pytest.raises(PhysOmniError) as caught:
        build_shot(folder / "photo.png", tmp_path / "shot", masks=specs)
    said = str(caught.value)
    assert caught.value.exit_code == 1 and "\n" not in said
    assert "block_0 and block_1 overlap" in said and "simulate would refuse" in said
    assert not (tmp_path / "shot").exists()


def test_an_overlap_the_pass_left_ends_the_build_on_simulates_own_refusal(stack, sunk, tmp_path, monkeypatch):
    """Should the separation pass ever leave a pair inside each other (here it is skipped), the build's last check,
    the very refusal ``simulate`` makes (``physics.prepare.refuse_unsimulatable``), ends it: one line naming the
    pair, exit 1, no folder."""
    folder, specs = stack
    sunk["deep"] = True
    monkeypatch.setattr(build_module, "_separated", lambda scene, camera, verts, *args, **kwargs: verts)
    with pytest.raises(PhysOmniError) as caught:
        build_shot(folder / "photo.png", tmp_path / "shot", masks=specs)
    said = str(caught.value)
    assert caught.value.exit_code == 1 and "\n" not in said
    assert "starts" in said and "inside block_" in said and "after the separation pass" in said, said
    assert "simulate would refuse" in said
    assert not (tmp_path / "shot").exists()


def test_the_pass_leaves_separate_objects_alone():
    a, b = _box((0.1, 0.1, 0.1), (0, 0, 0)), _box((0.1, 0.1, 0.1), (0.2, 0, 0))
    verts, done = separate.separate_pairs([a.vertices, b.vertices], [a.faces, b.faces], [False, False], {}, CAMERA,
                                          (180, 240), ["a", "b"])
    assert done == [] and all(np.array_equal(v, m.vertices) for v, m in zip(verts, (a, b)))


def test_two_boxes_side_by_side_overlapping_1cm_are_moved_apart_or_shrunk_to_the_margin():
    a, b = _box((0.1, 0.1, 0.1), (0, 0, 0)), _box((0.06, 0.06, 0.06), (0.07, 0, 0))
    verts, done = separate.separate_pairs([a.vertices, b.vertices], [a.faces, b.faces], [False, False], {}, CAMERA,
                                          (180, 240), ["a", "b"])
    assert [d["how"] for d in done][:1] in (["apart"], ["shrink"])
    after = {k: trimesh.Trimesh(v, m.faces) for k, v, m in zip("ab", verts, (a, b))}
    assert max_penetration(after) <= separate.TARGET_M
    assert min(v[:, 2].min() for v in verts) >= -1e-9  # nothing pushed into the ground
