"""One place that imports warp: quietly, and with the device picked the same way for every stage."""

from __future__ import annotations

import os
import sys
import tempfile
from functools import lru_cache

#: What warp's native library prints on every start of a machine without a GPU; not news to a CPU user.
_NO_DRIVER = "Could not find or load the NVIDIA CUDA driver"


@lru_cache(maxsize=1)
def load_warp():
    """The initialised ``warp`` module, printing errors only.

    warp's banner and its native "no CUDA driver" notice would interleave with
    our progress output, so initialisation runs with the process's stdout and
    stderr captured; anything else it prints is passed on to stderr.
    """
    import warp as wp

    wp.config.log_level = getattr(wp, "LOG_ERROR", wp.config.log_level)
    wp.config.quiet = True
    with tempfile.TemporaryFile(mode="w+b") as sink:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = os.dup(1), os.dup(2)
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            wp.init()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        sink.seek(0)
        text = sink.read().decode(errors="replace")
    rest = [ln for ln in text.splitlines() if ln.strip() and _NO_DRIVER not in ln]
    if rest:
        print("\n".join(rest), file=sys.stderr)
    return wp


def pick_device(requested: str | None = None) -> str:
    """``requested`` if given, else ``cuda:0`` when a GPU is usable, else ``cpu``."""
    wp = load_warp()
    if requested:
        return requested
    return "cuda:0" if wp.is_cuda_available() else "cpu"
