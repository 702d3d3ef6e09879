"""`bench alignment --quick`: every row of both tables, the JSON keys, and the full method's targets."""

from __future__ import annotations

import json

from .conftest import cli

KEYS = {"table", "variant", "mask_iou", "penetration_rate", "support_violation_rate", "interaction_success_rate",
        "reprojection_px", "ssim", "seconds"}


def test_quick_bench_writes_both_tables(tmp_path):
    out = tmp_path / "align.json"
    proc = cli("bench", "alignment", "--quick", "--json", out, check=True)
    assert "coarse_to_fine" in proc.stdout and "agmf" in proc.stdout
    rows = json.loads(out.read_text())["rows"]
    assert {(r["table"], r["variant"]) for r in rows} == {
        ("scene", v) for v in ("none", "canonical", "ransac", "agmf")} | {
        ("camera", v) for v in ("initial", "global", "local", "coarse_to_fine")}
    assert all(KEYS <= set(r) for r in rows)
    full = next(r for r in rows if r["table"] == "scene" and r["variant"] == "agmf")
    assert full["mask_iou"] >= 0.9 and full["reprojection_px"] <= 3.0
    assert full["mesh_penetration_rate"] == 0.0 and full["support_violation_rate"] == 0.0
    assert full["interaction_success_rate"] == 1.0
    ransac = next(r for r in rows if r["table"] == "scene" and r["variant"] == "ransac")
    assert full["plane_error_deg"] < ransac["plane_error_deg"]
