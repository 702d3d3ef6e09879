"""Support: a cup standing on its saucer in the photo stands on it in the scene, and stays there."""

from __future__ import annotations

import json

import numpy as np

from physomni_usd.align.support import find_supports
from physomni_usd.bench.photos import make_cup_on_saucer, make_known_scene, write_scene
from physomni_usd.metrics.geometry import max_penetration, world_meshes
from physomni_usd.usd import layers

from .conftest import cli


def test_supports_are_found_from_the_masks_and_side_by_side_objects_are_not():
    for pitch in (20.0, 45.0, 80.0):
        scene = make_cup_on_saucer(pitch)
        assert find_supports(scene.masks) == {0: (1, find_supports(scene.masks)[0][1])}, pitch
    assert find_supports(make_known_scene(30.0).masks) == {}


def _cup_and_saucer(stage, t):
    meshes = world_meshes(stage, t)
    cup = next(m for k, m in meshes.items() if k.startswith("cup"))
    saucer = next(m for k, m in meshes.items() if k.startswith("saucer"))
    return cup, saucer, meshes


def test_a_cup_on_its_saucer_stays_on_it(tmp_path):
    scene = make_cup_on_saucer(20.0)
    specs = write_scene(scene, tmp_path / "in")
    masks = [a for s in specs for a in ("--mask", s)]
    out = tmp_path / "shot"
    cli("build", tmp_path / "in" / "photo.png", "-o", out, "-q", *masks, check=True)
    report = json.loads((out / "report.json").read_text())
    assert report["shot"]["alignment"]["supports"] == {"cup_0": {"on": "saucer_1", "seen": "contact"}}
    stage = layers.open_shot(out)
    cup, saucer, meshes = _cup_and_saucer(stage, 0)
    top = saucer.vertices[:, 2].max()
    assert abs(cup.vertices[:, 2].min() - top) <= 0.005
    # it stands where the photo shows it: above the saucer, not pushed off onto the ground
    assert np.linalg.norm(cup.centroid[:2] - saucer.centroid[:2]) < 0.5 * np.ptp(saucer.vertices[:, 0])
    assert max_penetration(meshes) <= 0.002

    cli("simulate", out / "shot.usda", "--seconds", "2", "-q", check=True)
    stage = layers.open_shot(out)
    end = int(stage.GetEndTimeCode())
    cup, saucer, _ = _cup_and_saucer(stage, end)
    assert abs(cup.vertices[:, 2].min() - saucer.vertices[:, 2].max()) <= 0.005
    sim = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    assert sim["max_penetration_m"] <= 0.002
