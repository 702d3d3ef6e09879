"""bench render: both figures come from real renders of the bundled example (tiny, so it is quick)."""

from __future__ import annotations

import json
import pathlib

from .conftest import cli

EXAMPLE = pathlib.Path(__file__).resolve().parents[1] / "examples" / "motorcycle"


def test_bench_render_reports_plain_and_passes_frames_per_second(tmp_path):
    out = tmp_path / "render.json"
    proc = cli("bench", "render", "--example", EXAMPLE, "--size", "96", "--quick", "--json", out, check=True)
    numbers = json.loads(out.read_text())
    assert numbers["width"] == 96 and numbers["frames"] == 10 and numbers["camera"] == "static"
    assert numbers["plain_frames_per_second"] > 0 and numbers["passes_frames_per_second"] > 0
    assert numbers["passes"] == ["depth", "normal", "flow", "mask"]
    assert "all passes" in proc.stdout
