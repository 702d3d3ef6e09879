"""``bench photos`` on one synthetic scene: the issue's acceptance at a steep pitch, through the command."""

from __future__ import annotations

import json

import pytest

from .conftest import cli


@pytest.mark.slow  # 295 s under a load of 26; bench runs in the quick set (bench render, bench peer)
def test_bench_photos_meets_the_acceptance_at_60_degrees(tmp_path):
    proc = cli("bench", "photos", "--pitch", "60", "--seconds", "0.3", "--json", tmp_path / "p.json", check=True)
    row = json.loads((tmp_path / "p.json").read_text())["rows"][0]
    assert row["finished"] and row["passes"], row
    assert row["pitch_error_deg"] <= 5 and row["fov_error_frac"] <= 0.10
    assert row["max_position_error_frac"] <= 0.05 and row["max_height_error_frac"] <= 0.15
    assert row["ssim_frame0"] > 0.9 and row["scale_source"] == "priors"
    assert "synthetic" in proc.stdout
