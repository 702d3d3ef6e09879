"""What every video the project writes needs of its frames."""

from __future__ import annotations

import numpy as np


def even_sides(frame: np.ndarray) -> np.ndarray:
    """H.264 in yuv420p needs even sides: ``frame`` (H, W, ...) without its last row or column where needed."""
    h, w = frame.shape[:2]
    return np.ascontiguousarray(frame[:h - h % 2, :w - w % 2])


#: x264's preset: how hard it searches for the smallest file at the quality asked for. "veryfast" encodes a
#: 1920×1296 shot in 2.1 CPU seconds against the default "medium"'s 4.9 (91 frames, the 12 MP motorcycle's),
#: its file no larger there (1.19 against 1.39 MB): what x264 gains by a longer search is a few per cent of file
#: size on detailed motion, and a video of a few seconds is small either way.
X264_PRESET = "veryfast"


def video_writer(path, fps: float, quality: float):
    """An H.264 (yuv420p) MP4 writer for ``path``. Its ffmpeg prints nothing of its own (``quiet``): when it
    stops, :func:`encoder_failure` names the cause in one line instead of ffmpeg's lines on the user's
    terminal."""
    import imageio.v2 as imageio

    return imageio.get_writer(str(path), format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=quality,
                              macro_block_size=1, pixelformat="yuv420p", ffmpeg_log_level="quiet",
                              output_params=["-preset", X264_PRESET])


#: Below this much free space on the video's file system, a stopped encoder is taken to have filled it.
FULL_DISK_BYTES = 4 << 20


def encoder_failure(exc: OSError, path) -> OSError:
    """What to raise for ``exc``, an encoder's failure writing the video ``path``: the disk's own error
    naming ``path`` when its file system is full (ffmpeg says so only on its stderr, which it keeps quiet;
    imageio passes on a broken pipe), else ``exc`` itself."""
    import errno
    import os
    import pathlib
    import shutil

    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EROFS):
        return OSError(exc.errno, os.strerror(exc.errno), str(path))
    try:
        free = shutil.disk_usage(pathlib.Path(path).parent).free
    except OSError:
        return exc
    if free < FULL_DISK_BYTES:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return exc
