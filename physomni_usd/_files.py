"""Writing files so that a crash never leaves one half-written: a temporary file, then a rename."""

from __future__ import annotations

import os
import pathlib
import tempfile
from contextlib import contextmanager


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_path(path: os.PathLike | str):
    """Yield a temporary path beside ``path`` (same extension); on success it replaces ``path``.

    The result gets the usual permissions (0666 less the umask) rather than
    the private ones of a temporary file. On error the temporary file is removed
    and ``path`` is left as it was.
    """
    path = pathlib.Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        yield pathlib.Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_bytes(path: os.PathLike | str, data: bytes) -> pathlib.Path:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return pathlib.Path(path)
