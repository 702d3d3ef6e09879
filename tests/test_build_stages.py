"""``build`` is one path of stages: the built-in lifter and a plugin lifter are called the same way and their
meshes go through the same place, texture and write stages."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from physomni_usd.swappable import protocols, registry
from physomni_usd.backends import steps as backend_steps
from physomni_usd import building as build
from physomni_usd.backends.builtin import SilhouetteLifter


class StubLifter:
    """A plugin lifter: a 6 cm box per mask, 1 m in front of the camera, below its centre; records its calls."""

    kind, name = "lifter", "stub"
    calls: list = []

    @classmethod
    def missing(cls):
        return None

    @classmethod
    def weights(cls):
        return None

    def lift(self, photo, masks, labels):
        type(self).calls.append((photo.shape, len(masks), list(labels)))
        box = trimesh.creation.box((0.06, 0.06, 0.06))
        return [protocols.LiftedObject(np.asarray(box.vertices), np.asarray(box.faces), (1.0, 0.0, 0.0, 0.0),
                                       (0.1 * i - 0.05, 0.15, 1.0)) for i in range(len(masks))]


def _spy(monkeypatch, module, name, calls, tag):
    real = getattr(module, name)

    def spy(*args, **kwargs):
        calls.append((tag(), name))
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, spy)


def test_builtin_and_plugin_lifters_go_through_the_same_stages(tmp_path, photo, monkeypatch):
    entry = registry.Entry("lifter", "stub", f"{__name__}:StubLifter", "physomni-stub", "0")
    real_entries = registry.entries
    monkeypatch.setattr(registry, "entries", lambda: real_entries() + [entry])
    running = {"lifter": None}
    calls = []
    for name in ("lift", "record_lifted"):
        _spy(monkeypatch, backend_steps, name, calls, lambda: running["lifter"])
    for name in ("_lift", "_place", "_texture", "_estimate", "_write"):
        _spy(monkeypatch, build, name, calls, lambda: running["lifter"])
    masks = [f"{photo['cup']}:cup", f"{photo['box']}:box"]
    results = {}
    for lifter in ("silhouette", "stub"):
        running["lifter"] = lifter
        results[lifter] = build.build_shot(photo["photo"], tmp_path / lifter, masks=masks,
                                           backends={"lifter": lifter})
    stages = ["_lift", "lift", "_place", "_texture", "_estimate", "_write"]
    assert [n for t, n in calls if t == "silhouette"] == stages
    # a model's meshes are also kept in the shot (inputs/lifted), as ``--meshes`` reads them
    assert [n for t, n in calls if t == "stub"] == stages[:2] + ["record_lifted"] + stages[2:]
    assert StubLifter.calls == [((180, 240, 3), 2, ["cup", "box"])]
    assert (tmp_path / "stub" / "inputs" / "lifted" / "poses.json").is_file()
    assert [o["shape"] for o in results["stub"].objects] == ["external", "external"]
    assert all(o["shape"] != "external" for o in results["silhouette"].objects)


def test_builtin_lifter_implements_the_lifter_protocol(photo):
    import cv2

    assert isinstance(SilhouetteLifter(), protocols.Lifter)
    image = cv2.cvtColor(cv2.imread(str(photo["photo"])), cv2.COLOR_BGR2RGB)
    masks = [cv2.imread(str(photo[k]), cv2.IMREAD_GRAYSCALE) > 0 for k in ("cup", "box")]
    lifted = SilhouetteLifter().lift(image, masks, ["cup", "box"])
    assert len(lifted) == 2
    for o in lifted:
        # the pose puts the mesh in front of the camera, where the camera of its ground evidence sees it
        r = trimesh.transformations.quaternion_matrix(o.rotation_wxyz)[:3, :3]
        cam = o.vertices @ r.T + np.asarray(o.translation)
        assert cam[:, 2].min() > 0
        uv, _ = o.ground.camera.project(o.vertices)
        f = o.ground.camera.focal_px
        assert np.allclose(uv, cam[:, :2] / cam[:, 2:] * f + [120, 90], atol=1e-6)


class StubDepth:
    """A depth plugin that sees an endless floor under a camera pitched ``PITCH`` degrees down (vertical
    field of view ``FOV``): z where each pixel's ray meets it."""

    kind, name = "depth", "floor"
    PITCH, FOV = 31.0, 50.0

    @classmethod
    def missing(cls):
        return None

    @classmethod
    def weights(cls):
        return None

    def depth(self, photo):
        h, w = photo.shape[:2]
        f = 0.5 * h / np.tan(np.radians(self.FOV) / 2)
        vv, uu = np.mgrid[0:h, 0:w] + 0.5
        t = np.radians(self.PITCH)
        down = ((vv - h / 2) / f) * np.cos(t) + np.sin(t)  # each ray (z = 1) · world down, in OpenCV axes
        return protocols.DepthMap(np.where(down > 1e-6, 1.0 / np.maximum(down, 1e-6), 0.0).astype(np.float32), True)


def test_the_depth_ground_sets_the_pitch_unless_the_user_gave_one(tmp_path, photo, monkeypatch):
    """build reads the pitch from the depth backend's ground where it resolves its settings; --pitch wins."""
    import json

    from physomni_usd.settings import BuildSettings, CameraSettings

    entry = registry.Entry("depth", "floor", f"{__name__}:StubDepth", "physomni-stub", "0")
    real_entries = registry.entries
    monkeypatch.setattr(registry, "entries", lambda: real_entries() + [entry])
    masks = [f"{photo['cup']}:cup", f"{photo['box']}:box"]
    pitches = {}
    for given in (None, 12.0):
        settings = BuildSettings(camera=CameraSettings(fov_deg=StubDepth.FOV, pitch_deg=given))
        out = tmp_path / str(given)
        build.build_shot(photo["photo"], out, masks=masks, settings=settings, backends={"depth": "floor"})
        report = json.loads((out / "report.json").read_text())
        assert report["stages"]["build"]["depth_ground"]["pitch_deg"] == pytest.approx(StubDepth.PITCH, abs=0.5)
        pitches[given] = report["shot"]["pitch_deg"]
    assert pitches[None] == pytest.approx(StubDepth.PITCH, abs=0.5)
    assert pitches[12.0] == pytest.approx(12.0, abs=0.5)
