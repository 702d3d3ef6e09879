"""Motion worth watching: the "frames with motion" figure each example's README gives, and the bundled
motorcycle's video moving for at least half its frames."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from physomni_usd.metrics.motion import CHANGE_LEVELS, changed_shares, frames_with_motion, video_motion


EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def _frames(moving: set[int], n: int = 12, noise: int = CHANGE_LEVELS // 2) -> list[np.ndarray]:
    """n 120×160 frames of a picture with ±``noise`` levels of fresh noise in each (an encoder's flicker:
    two frames differ by up to twice it); a 10 px square steps 3 px right in the frames listed in ``moving``."""
    rng = np.random.default_rng(1)
    base = rng.integers(60, 190, (120, 160, 3)).astype(np.int16)
    x, out = 20, []
    for i in range(n):
        x += 3 if i in moving else 0
        f = base + rng.integers(-noise, noise + 1, base.shape)
        f[50:60, x:x + 10] = 250
        out.append(np.clip(f, 0, 255).astype(np.uint8))
    return out


def test_frames_with_motion_counts_the_frames_where_something_moved():
    moving = {2, 3, 7}
    shares = changed_shares(_frames(moving))
    assert shares[0] == 0.0 and len(shares) == 12
    assert set(np.flatnonzero(shares > 0.001)) == moving  # flicker up to the threshold is not motion
    assert frames_with_motion(shares) == 3
    assert frames_with_motion(changed_shares(_frames(set()))) == 0
    assert frames_with_motion(changed_shares(_frames(set(), noise=40))) == 11  # louder than it: all but frame 0


def test_the_command_counts_a_videos_frames_and_names_a_bad_file(tmp_path):
    import imageio.v2 as imageio

    video = tmp_path / "v.mp4"
    with imageio.get_writer(str(video), format="FFMPEG", fps=10, codec="libx264", quality=8,
                            macro_block_size=16) as w:
        for f in _frames({3, 4, 5, 6, 9}, n=16, noise=0):
            w.append_data(f)
    result = video_motion(video)
    assert result["frames"] == 16 and result["with_motion"] == 5 and result["last_motion"] == 9
    proc = subprocess.run([sys.executable, "-m", "physomni_usd.metrics.motion", str(video)],
                          capture_output=True, text=True)
    assert proc.returncode == 0 and "5 of 16 frames with motion" in proc.stdout, proc.stdout + proc.stderr
    proc = subprocess.run([sys.executable, "-m", "physomni_usd.metrics.motion", str(tmp_path / "none.mp4")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "VIDEO" in proc.stderr, proc.stderr


@pytest.mark.slow  # builds, simulates and renders the motorcycle example: about a minute on a 2-core machine
def test_the_motorcycle_examples_video_moves_for_at_least_half_its_frames(motorcycle_run):
    """Run by examples/motorcycle/run.sh (its example.json: masks and push, no --seconds; the session's run,
    tests/conftest.py, which tests/test_still_world.py reads too)."""
    spec = json.loads((EXAMPLES / "motorcycle" / "example.json").read_text())
    assert "seconds" not in spec  # the take ends a second after the last motion: the still tail counts too
    proc, out = motorcycle_run
    assert proc.returncode == 0, proc.stdout + proc.stderr
    result = video_motion(out / "video.mp4")
    assert result["with_motion"] >= result["frames"] / 2, result
