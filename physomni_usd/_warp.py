"""One place that imports warp: quietly, and with the device picked the same way for every stage."""

from __future__ import annotations


def load_warp():
    """The ``warp`` module, configured to print errors only (its banner would interleave with progress)."""
    import warp as wp

    wp.config.log_level = getattr(wp, "LOG_ERROR", wp.config.log_level)
    wp.config.quiet = True
    return wp


def pick_device(requested: str | None = None) -> str:
    """``requested`` if given, else ``cuda:0`` when a GPU is usable, else ``cpu``."""
    wp = load_warp()
    if requested:
        return requested
    return "cuda:0" if wp.is_cuda_available() else "cpu"
