"""The backend registry: built-ins under their names, clear refusals, the report, and the depth's ground plane."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from physomni_usd.backends import steps
from physomni_usd.geometry.depth import ground_pitch
from physomni_usd.swappable import protocols, registry
from physomni_usd.errors import InputError

from .conftest import cli


def test_builtins_implement_their_protocols():
    checks = {"segmenter": protocols.Segmenter, "inpainter": protocols.Inpainter,
              "estimator": protocols.Estimator}
    for entry in registry.entries():
        if entry.builtin and entry.kind in checks:
            cls = entry.load()
            assert issubclass(cls, checks[entry.kind]), entry.name
            assert cls.missing() is None


def test_plugins_lists_every_kind_and_the_defaults():
    proc = cli("plugins", check=True)
    for kind in registry.KINDS:
        assert f"{kind}:" in proc.stdout
    assert "grabcut (default): built-in" in proc.stdout
    assert "rules (default): built-in" in proc.stdout
    assert "TORCH_IMPORTED=False" in proc.stderr  # listing reads metadata and asks plugins, loading no model


def test_unknown_backend_is_refused_before_anything_is_written(tmp_path, photo):
    out = tmp_path / "out"
    proc = cli("build", photo["photo"], "-o", out, "--mask", f"{photo['cup']}:cup", "--inpainter", "nope")
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "--inpainter nope" in errors[0] and "builtin" in errors[0]
    assert not out.exists()


def test_kind_without_any_backend_names_the_plugin(monkeypatch):
    monkeypatch.setattr(registry, "entries", lambda: [])  # as where no re-renderer plugin is installed
    with pytest.raises(InputError, match=r"--model wan-vace: no rerenderer .*pip install -e plugins/physomni-wan"):
        registry.find("rerenderer", "wan-vace")


def test_report_names_the_backends_of_a_default_build(shot):
    build = json.loads((shot["dir"] / "report.json").read_text())["stages"]["build"]
    assert {k: v["name"] for k, v in build["backends"].items()} == {
        "segmenter": "grabcut", "inpainter": "builtin", "outpainter": "exemplar", "lifter": "silhouette",
        "estimator": "rules"}
    assert all(v["builtin"] and v["version"] for v in build["backends"].values())


class _Empty:
    kind, name = "segmenter", "empty"

    def segment(self, photo, prompts):
        return [np.zeros(photo.shape[:2], bool) for _ in prompts]


def test_empty_mask_from_a_segmenter_is_one_clear_error():
    photo = np.full((32, 32, 3), 100, np.uint8)
    with pytest.raises(InputError, match=r"--box '4,4,20,20:cup' \(empty\) is empty"):
        steps.collect_objects(photo, [], ["4,4,20,20:cup"], _Empty())


def test_inpainter_output_is_kept_only_in_the_hole():
    class Grey:
        kind, name = "inpainter", "grey"

        def inpaint(self, photo, hole):
            return np.full_like(photo, 128)

    photo = np.random.default_rng(0).integers(0, 255, (40, 50, 3)).astype(np.uint8)
    mask = np.zeros((40, 50), bool)
    mask[10:20, 10:30] = True
    plate = steps.make_plate(photo, [mask], 0.0, Grey())
    assert (plate[mask] == 128).all()
    assert (plate[~mask] == photo[~mask]).all()


@pytest.mark.parametrize("pitch_deg,height,metric", [(20.0, 1.5, True), (35.0, 0.8, False)])
def test_ground_pitch_from_a_depth_map_of_a_floor(pitch_deg, height, metric):
    """Depth of an infinite floor seen by a camera pitched down: the fitted plane gives the pitch back."""
    h, w, fov = 90, 120, 50.0
    f = 0.5 * h / math.tan(math.radians(fov) / 2)
    vv, uu = np.mgrid[0:h, 0:w] + 0.5
    rays = np.stack([(uu - w / 2) / f, (vv - h / 2) / f, np.ones_like(uu)], -1)  # z = 1 per ray
    t = math.radians(pitch_deg)
    up = np.array([0.0, -math.cos(t), -math.sin(t)])  # world up in OpenCV camera axes
    down = -(rays @ up)
    depth = np.where(down > 1e-6, height / np.maximum(down, 1e-6), 0.0)  # z where the ray meets the floor
    scale = 1.0 if metric else 0.37
    found = ground_pitch(protocols.DepthMap((depth * scale).astype(np.float32), metric), fov,
                         np.ones((h, w), bool))
    assert found is not None
    assert found["pitch_deg"] == pytest.approx(pitch_deg, abs=0.5)
    if metric:
        assert found["camera_height_m"] == pytest.approx(height, rel=0.02)


def test_rerender_with_an_unknown_model_is_one_line_and_writes_nothing(shot):
    proc = cli("rerender", shot["shot"], "--model", "nope")
    assert proc.returncode == 2
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "--model nope" in errors[0]
    assert not (shot["dir"] / "rerender.mp4").exists()
    assert "TORCH_IMPORTED=False" in proc.stderr


def test_estimate_with_an_unknown_estimator_is_refused(shot):
    before = (shot["dir"] / "physics.usda").read_bytes()
    proc = cli("estimate", shot["shot"], "--estimator", "nope")
    assert proc.returncode == 2
    assert "--estimator nope" in proc.stderr and "rules" in proc.stderr
    assert (shot["dir"] / "physics.usda").read_bytes() == before


def test_a_plugin_importing_the_old_paths_gets_the_same_objects():
    """Installed plugins written before the plugin interface moved to swappable/ import it from backends/."""
    code = ("from physomni_usd.backends import registry as r\n"
            "from physomni_usd.backends.protocols import DepthMap, Lifter\n"
            "import physomni_usd.swappable.registry as new\n"
            "from physomni_usd.swappable import protocols\n"
            "assert r.load is new.load and r.entries is new.entries and r.KINDS is new.KINDS\n"
            "assert DepthMap is protocols.DepthMap and Lifter is protocols.Lifter\n")
    subprocess.run([sys.executable, "-c", code], check=True)
