"""How much of a video moves: per frame, the share of pixels that changed since the previous frame, and
how many frames "have motion" — the figure each bundled example's README gives for its video.

Run on a video: ``python -m physomni_usd.metrics.motion VIDEO [--levels L] [--share S]``.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
from collections.abc import Iterable

import numpy as np

#: A pixel changed when one of its channels moved by more than this many levels (of 255) since the
#: previous frame: above the few levels an H.264 encode adds to a still picture.
CHANGE_LEVELS = 12
#: A frame has motion when more than this share of its pixels changed (0.1 %: a 20-pixel-wide ball
#: moving a few pixels in a 640×480 frame counts; encoder flicker does not).
MOTION_SHARE = 0.001


def changed_shares(frames: Iterable[np.ndarray], levels: int = CHANGE_LEVELS) -> np.ndarray:
    """Share of each frame's pixels (0..1) whose largest channel difference from the previous frame
    exceeds ``levels``; frames are uint8 (H, W[, C]) of one shape. Returns (N,) float, the first 0."""
    shares = []
    previous = None
    for frame in frames:
        current = np.asarray(frame, np.int16)
        if current.ndim == 2:
            current = current[..., None]
        if previous is None:
            shares.append(0.0)
        else:
            if current.shape != previous.shape:
                raise ValueError(f"frames differ in shape: {previous.shape} vs {current.shape}")
            diff = np.abs(current - previous).max(axis=2)
            shares.append(float((diff > levels).mean()))
        previous = current
    return np.asarray(shares, np.float64)


def frames_with_motion(shares: np.ndarray, share: float = MOTION_SHARE) -> int:
    """How many frames of ``changed_shares``' (N,) output have motion (more than ``share`` of pixels changed)."""
    return int((np.asarray(shares) > share).sum())


def read_frames(video: str | pathlib.Path) -> Iterable[np.ndarray]:
    """The frames of a video file, one uint8 (H, W, 3) array at a time (imageio's FFMPEG reader)."""
    import imageio.v2 as imageio

    reader = imageio.get_reader(str(video), format="FFMPEG")
    try:
        for frame in reader:
            yield np.asarray(frame)[..., :3]
    finally:
        reader.close()


def video_motion(video: str | pathlib.Path, levels: int = CHANGE_LEVELS, share: float = MOTION_SHARE) -> dict:
    """Motion of a video file: {"frames": N, "with_motion": M, "shares": [N floats], "last_motion": index
    of the last frame with motion or None}."""
    shares = changed_shares(read_frames(video), levels)
    moving = np.flatnonzero(shares > share)
    return {"frames": int(len(shares)), "with_motion": int(len(moving)), "shares": shares.tolist(),
            "last_motion": int(moving[-1]) if len(moving) else None}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m physomni_usd.metrics.motion",
                                     description="Count the frames of a video that have motion.")
    parser.add_argument("video", type=pathlib.Path)
    parser.add_argument("--levels", type=int, default=CHANGE_LEVELS,
                        help=f"a pixel changed above this many levels of 255 (default {CHANGE_LEVELS})")
    parser.add_argument("--share", type=float, default=MOTION_SHARE,
                        help=f"a frame has motion above this share of changed pixels (default {MOTION_SHARE})")
    args = parser.parse_args(argv)
    if not args.video.is_file():
        print(f"error: VIDEO: no such file: {args.video}", file=sys.stderr)
        return 2
    try:
        result = video_motion(args.video, args.levels, args.share)
    except Exception as exc:  # imageio/ffmpeg's own errors: one line naming the file
        print(f"error: VIDEO: cannot read {args.video}: {exc}", file=sys.stderr)
        return 2
    print(f"{args.video}: {result['with_motion']} of {result['frames']} frames with motion "
          f"(over {args.share:.2%} of pixels changed by more than {args.levels} levels); "
          f"last motion at frame {result['last_motion']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
