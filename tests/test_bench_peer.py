"""``bench peer``: without Genesis it says how to install it and runs nothing; its scenes are what its
help says; with Genesis (a separate environment) one short case gives a ratio."""

import importlib.util
import json

import numpy as np
import pytest

from physomni_usd.bench import peer

from .conftest import cli

HAS_GENESIS = importlib.util.find_spec("genesis") is not None


def test_without_genesis_says_how_to_install_and_runs_nothing(monkeypatch):
    monkeypatch.setattr(peer, "genesis_available", lambda: False)
    ran = []
    monkeypatch.setattr(peer, "run_case", lambda *a, **k: ran.append(a))
    said = []
    assert peer.bench_peer(echo=said.append) == {"genesis": None}
    assert ran == [] and len(said) == 1
    assert "genesis: not installed" in said[0] and "physomni-usd[peer]" in said[0]


@pytest.mark.skipif(HAS_GENESIS, reason="genesis is installed here")
def test_cli_without_genesis_exits_0_and_writes_nothing(tmp_path):
    out = tmp_path / "peer.json"
    proc = cli("bench", "peer", "--json", out)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().count("\n") == 0 and "not installed" in proc.stdout
    assert not out.exists()


def _boxes(objects):
    return np.array([o.mesh.bounds for o in objects])  # (n, 2, 3): min and max corners, m


def test_boxes_at_rest_stand_on_the_ground_apart():
    b = _boxes(peer.boxes_at_rest())
    assert len(b) == 10 and np.allclose(b[:, 0, 2], 0.0)
    centres = b.mean(axis=1)[:, :2]
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2) + np.eye(10) * 9
    assert gaps.min() >= 0.4 - 1e-9


def test_box_pile_starts_apart_and_each_upper_box_lands_on_one_below():
    b = _boxes(peer.box_pile())
    lo, hi = b[:, 0], b[:, 1]
    n = len(b)
    overlap = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])  # (n, n, 3)
    touching = (overlap > 0).all(axis=2) & ~np.eye(n, dtype=bool)
    assert not touching.any()  # no start overlap: the pile's collisions come from the fall
    for i in range(5, n):
        below = range((i // 5 - 1) * 5, (i // 5) * 5)
        xy = [overlap[i, j, 0] > 0 and overlap[i, j, 1] > 0 for j in below]
        assert any(xy), f"box {i} falls past the layer below"
        # shifted, not stacked square: it lands on an edge and topples
        assert not any(np.allclose(lo[i, :2], lo[j, :2]) for j in below)


@pytest.mark.skipif(not HAS_GENESIS, reason="genesis-world is not installed (the peer extra)")
def test_boxes_at_rest_against_genesis_gives_a_ratio():
    import genesis as gs

    gs.init(backend=gs.cpu, logging_level="warning")
    r = peer.run_case("boxes_at_rest", repeats=1, seconds=0.2)
    assert r["genesis"]["substeps"] == r["ours"]["substeps"]
    assert r["ours"]["captured_frames"] > 0  # the stepping timed is simulate's, graphs replayed
    assert r["ratio"]["min"] > 0
    # CPU seconds beside the wall's, both sides: the steps took some, and a simulated second's CPU cannot
    # exceed the two cores' worth of its wall by much (the clocks agree)
    for side in ("ours", "genesis"):
        cpu, wall = r[side]["cpu_seconds_per_sim_second"][0], r[side]["seconds_per_sim_second"][0]
        assert 0 < cpu <= 2.5 * wall + 0.05
    assert r["cpu_ratio"]["min"] > 0
    json.dumps(r)
