"""Writing files so that a crash never leaves one half-written (a temporary file, then a rename), checking
before any work that every file a command will write can be written, and grouping a command's writes so
that either all of them take effect or none (:func:`all_or_nothing`)."""

from __future__ import annotations

import contextvars
import os
import pathlib
import shutil
import tempfile
from contextlib import contextmanager

from .errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


class _Writes:
    """What one command changed on disk, so that a failure can put everything back.

    ``saved`` maps each replaced or removed file to a hard link (or copy) of its old content, or to
    ``None`` where the command created it; ``dirs`` are the folders the command created.
    """

    def __init__(self):
        self.saved: dict[pathlib.Path, pathlib.Path | None] = {}
        self.dirs: list[pathlib.Path] = []

    def keep(self, path: pathlib.Path) -> None:
        """Remember ``path``'s content before its first change in this command."""
        path = pathlib.Path(os.path.abspath(path))
        if path in self.saved:
            return
        if not path.is_file():
            self.saved[path] = None
            return
        fd, backup = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".keep", dir=path.parent)
        os.close(fd)
        os.unlink(backup)
        try:
            os.link(path, backup)
        except OSError:  # a file system without hard links
            shutil.copy2(path, backup)
        self.saved[path] = pathlib.Path(backup)

    def commit(self) -> None:
        for backup in self.saved.values():
            if backup is not None and backup.exists():
                backup.unlink()

    def roll_back(self) -> None:
        for path, backup in self.saved.items():
            try:
                if backup is None:
                    if path.is_file():
                        path.unlink()
                else:
                    os.replace(backup, path)
            except OSError:
                pass
        for folder in reversed(self.dirs):
            try:
                folder.rmdir()  # only if empty: never anything a user put there
            except OSError:
                pass


_ACTIVE: contextvars.ContextVar[_Writes | None] = contextvars.ContextVar("physomni_writes", default=None)


@contextmanager
def all_or_nothing():
    """Group every write of a command: on any error (or Ctrl-C) each file written, replaced or removed
    inside the block gets its old content back, and folders created inside it are removed again.

    Nested blocks join the outermost one. Files are still written through a temporary file and a
    rename, so later stages of the same command read what earlier ones wrote.
    """
    if _ACTIVE.get() is not None:
        yield
        return
    writes = _Writes()
    token = _ACTIVE.set(writes)
    try:
        yield
    except BaseException:
        writes.roll_back()
        raise
    else:
        writes.commit()
    finally:
        _ACTIVE.reset(token)


def make_dirs(path: os.PathLike | str) -> pathlib.Path:
    """``mkdir -p`` whose new folders are removed again if the command fails."""
    path = pathlib.Path(path)
    missing = []
    p = path
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    path.mkdir(parents=True, exist_ok=True)
    writes = _ACTIVE.get()
    if writes is not None:
        writes.dirs.extend(reversed(missing))
    return path


def remove_file(path: os.PathLike | str) -> None:
    """Delete a file (its content comes back if the command fails)."""
    path = pathlib.Path(path)
    if not path.is_file():
        return
    writes = _ACTIVE.get()
    if writes is not None:
        writes.keep(path)
    path.unlink()


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
        writes = _ACTIVE.get()
        if writes is not None:
            writes.keep(path)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_bytes(path: os.PathLike | str, data: bytes) -> pathlib.Path:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return pathlib.Path(path)


def write_json(path: os.PathLike | str, data) -> pathlib.Path:
    """Write ``data`` as indented JSON (one trailing newline) to ``path`` atomically."""
    import json

    return write_bytes(path, (json.dumps(data, indent=2) + "\n").encode())


def check_writable(paths) -> None:
    """Raise :class:`InputError` naming the first of ``paths`` that could not be written: a folder in its
    place, a file where a folder must be, or a folder that refuses new files. Called before any work.

    Folders are probed by creating (and removing) a temporary file in them, which is what the writes do;
    missing folders count as writable where their nearest existing ancestor is.
    """
    probed: dict[pathlib.Path, str | None] = {}
    for p in paths:
        p = pathlib.Path(p)
        if p.is_dir():
            raise InputError(f"cannot write {p}: a folder of that name is in the way")
        parent = p.parent
        while not parent.exists() and parent.parent != parent:
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(f"cannot write {p}: {parent} is a file, not a folder")
        if parent not in probed:
            probed[parent] = _probe(parent)
        if probed[parent] is not None:
            raise InputError(f"cannot write {p}: {probed[parent]}")


def _probe(folder: pathlib.Path) -> str | None:
    try:
        fd, tmp = tempfile.mkstemp(prefix=".physomni-probe.", dir=folder)
    except OSError as exc:
        return f"the folder {folder} is not writable ({exc.strerror})"
    os.close(fd)
    os.unlink(tmp)
    return None
