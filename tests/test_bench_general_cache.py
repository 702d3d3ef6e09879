"""``bench general -o``: a scene folder already rendered for the same seed and objects is read back
(``general_render.load_rendered``), anything else (another seed, a file missing) is rendered again."""

from __future__ import annotations

import json

import cv2
import numpy as np

from physomni_usd.bench import general_render


def _fake_render(scene: dict, folder, seed=None) -> list[np.ndarray]:
    """What ``render_scene`` leaves in ``folder`` (truth.json, photo, masks), without Blender."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    masks, objects = [], []
    for k, o in enumerate(scene["objects"]):
        m = rng.uniform(size=(24, 32)) > 0.5
        masks.append(m)
        cv2.imwrite(str(folder / f"modal_{k}.png"), m.astype(np.uint8) * 255)
        cv2.imwrite(str(folder / f"amodal_{k}.png"), (~m).astype(np.uint8) * 255)
        objects.append({"name": o["name"], "label": o["label"], "modal": f"modal_{k}.png",
                        "amodal": f"amodal_{k}.png"})
    cv2.imwrite(str(folder / "photo.png"), np.zeros((24, 32, 3), np.uint8))
    (folder / "truth.json").write_text(json.dumps({"seed": scene["seed"] if seed is None else seed,
                                                   "objects": objects}))
    return masks


def test_a_rendered_scene_is_read_back_and_anything_else_is_not(tmp_path):
    scene = general_render.describe_scene(4242)
    masks = _fake_render(scene, tmp_path / "same")
    truth = general_render.load_rendered(scene, tmp_path / "same")
    assert truth is not None and len(truth["modal"]) == len(scene["objects"])
    assert all(np.array_equal(a, b) for a, b in zip(truth["modal"], masks))
    assert all(np.array_equal(a, ~b) for a, b in zip(truth["amodal"], masks))
    _fake_render(scene, tmp_path / "other", seed=scene["seed"] + 1)
    assert general_render.load_rendered(scene, tmp_path / "other") is None
    (tmp_path / "same" / "amodal_0.png").unlink()
    assert general_render.load_rendered(scene, tmp_path / "same") is None
    assert general_render.load_rendered(scene, tmp_path / "nothing") is None
