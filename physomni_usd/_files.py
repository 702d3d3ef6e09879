"""Writing files so that a crash never leaves one half-written (a temporary file, then a rename), checking
before any work that every file a command will write can be written, and grouping a command's writes so
that either all of them take effect or none (:func:`all_or_nothing`).

A command that writes into a folder holds an advisory lock there (``fcntl.flock`` on ``.physomni.lock``)
until its last file is in place, so two writers never interleave; the lock file doubles as the command's
journal (which files it replaced, where their old content is kept, which temporary files it made). The
kernel drops a dead process's lock, so whoever next gets the lock and finds a journal knows its writer is
gone, and puts the folder back as it was before that command (see :func:`_recover`).
"""

from __future__ import annotations

import contextvars
import errno
import fcntl
import json
import os
import pathlib
import shutil
import stat
import sys
import tempfile
import time
from contextlib import contextmanager

from .errors import InputError, PhysOmniError, raise_if_signalled, received_signal, signals_held

#: The lock (and journal) file in each folder a command writes to; removed when the command ends.
LOCK = ".physomni.lock"
#: Seconds a second writer waits for the folder's lock before it gives up with one line.
LOCK_WAIT_S = float(os.environ.get("PHYSOMNI_LOCK_WAIT", "120"))
#: What our temporary and kept files are called, so that leftovers of a killed run are recognised and
#: nothing a user named is ever taken for one: ``.NAME.physomni-XXXX.keep``, ``.STEM.physomni-XXXX.EXT``.
TAG = "physomni-"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


class _Lock:
    """The lock of one folder, held by this process; its file holds the journal of what was changed."""

    def __init__(self, folder: pathlib.Path, wait_s: float | None = None):
        self.folder = folder
        self.path = folder / LOCK
        wait_s = LOCK_WAIT_S if wait_s is None else wait_s
        deadline = time.monotonic() + wait_s
        while True:
            try:
                # O_NOFOLLOW: a lock planted as a link (to a file anywhere) must not get our journal written
                # into what it points at
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o666 & ~_umask())
            except OSError as exc:
                if exc.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO):
                    refuse_link(self.path)
                    raise InputError(f"cannot write in {folder}: {self.path} is not a file; remove it") from None
                if exc.errno not in (errno.EACCES, errno.EPERM, errno.EROFS):
                    raise
                raise InputError(f"cannot write in {folder}: the folder {folder} is not writable "
                                 f"({exc.strerror})") from None
            if not stat.S_ISREG(os.fstat(fd).st_mode):  # a FIFO or a device of that name
                os.close(fd)
                raise InputError(f"cannot write in {folder}: {self.path} is not a file; remove it")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                if time.monotonic() >= deadline:
                    raise PhysOmniError(f"{folder} is being written by another physomni-usd command "
                                        f"({_holder(self.path)}); waited {wait_s:g} s (set PHYSOMNI_LOCK_WAIT "
                                        "to wait longer)") from None
                time.sleep(0.1)
                continue
            try:  # the file may have been removed by the holder we waited for: lock the one on disk
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        self.fd = fd
        try:
            _recover(folder, self.read(), self.raw())
            self.journal = {"pid": os.getpid(), "saved": {}, "temporary": []}
            self.write()
        except BaseException:
            self.release()
            raise

    def raw(self) -> bytes:
        try:
            return os.pread(self.fd, 1 << 20, 0)
        except OSError:
            return b""

    def read(self):
        """The journal left in the lock file: None where there is none (or it is no JSON at all, as a
        journal cut short by a full disk), else whatever JSON it holds (:func:`journal_refusal` judges it)."""
        data = self.raw()
        try:
            return json.loads(data) if data.strip() else None
        except ValueError:
            return None

    def write(self) -> None:
        # No fsync: the journal is read back after a process died, and a killed process's writes are
        # already the kernel's. Power loss is another matter, which an fsync of the journal alone would not
        # cover (the renamed files are not synced either); it cost about 1 ms a write, a dozen writes a run.
        data = json.dumps(self.journal).encode()
        try:
            os.pwrite(self.fd, data, 0)
            os.ftruncate(self.fd, len(data))
        except OSError as exc:  # a full disk shows here first: name the folder, not our lock file
            raise OSError(exc.errno, exc.strerror, str(self.folder)) from None

    def release(self) -> None:
        try:
            os.unlink(self.path)  # while still held: a waiter re-checks the inode and takes a fresh file
        except OSError:
            pass
        os.close(self.fd)


def _holder(path: pathlib.Path) -> str:
    try:
        pid = json.loads(path.read_text() or "{}").get("pid")
    except (OSError, ValueError):
        pid = None
    return f"pid {pid}" if pid else "another process"


def _plain(name) -> bool:
    """Whether ``name`` is a plain file name in a folder: no separator, not absolute, not ``.`` or ``..``."""
    return (isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\\" not in name
            and "\0" not in name and os.path.basename(name) == name)


def _kept_name(name: str, backup) -> bool:
    """Whether ``backup`` is what :meth:`_Writes.keep` calls the kept copy of ``name``."""
    return _plain(backup) and backup.startswith(f".{name}.{TAG}") and backup.endswith(".keep")


def journal_refusal(journal) -> str | None:
    """Why ``journal`` (read from a folder's lock file) cannot be what one of our commands wrote, or None.

    A shot folder travels (a colleague's tarball, a share), so its lock file is input like any other: only
    plain names in the folder are followed, each kept copy named as :meth:`_Writes.keep` names it. Anything
    else (an absolute name, ``..``, a separator, another file given as a kept copy) would let the folder
    delete or replace files anywhere, or move one of its own files (``edits.usda``) over another."""
    if not isinstance(journal, dict):
        return "it is not a journal"
    saved, temporary = journal.get("saved") or {}, journal.get("temporary") or []
    if not isinstance(saved, dict) or not isinstance(temporary, list):
        return "it is not a journal"
    for name, backup in saved.items():
        if not _plain(name):
            return f"it names {name!r}, which is not a file in the folder"
        if backup is not None and not _kept_name(name, backup):
            return f"it names {backup!r} as the old content of {name}, which is not a copy we keep"
    for name in temporary:
        if not (_plain(name) and name.startswith(".") and TAG in name):
            return f"it names {name!r} as a temporary file, which is not one of ours"
    return None


def _set_aside(folder: pathlib.Path, data: bytes) -> str:
    """Keep a refused journal's text beside the lock as ``.physomni.lock.bad`` (``.bad.1``, … if taken), never
    through a link and never over a file; returns its name."""
    n = 0
    while True:
        name = f"{LOCK}.bad" + (f".{n}" if n else "")
        try:
            fd = os.open(folder / name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666 & ~_umask())
        except FileExistsError:
            n += 1
            continue
        try:
            os.write(fd, data)
        finally:
            os.close(fd)
        return name


def _recover(folder: pathlib.Path, journal: dict | None, raw: bytes = b"") -> None:
    """Put ``folder`` back as it was before a command that died while it held the lock (its journal says
    what it had changed), and remove our temporary and kept files any earlier run left behind. A journal
    that names anything but our own files in the folder is not followed at all: it is set aside, with one
    line."""
    refusal = journal_refusal(journal) if journal is not None else None
    if refusal is not None:
        kept = _set_aside(folder, raw)
        sys.stderr.write(f"warning: {folder / LOCK} is no journal of ours ({refusal}); nothing was restored "
                         f"from it, and it is kept as {kept}\n")
    elif journal:
        for name, backup in (journal.get("saved") or {}).items():
            path = folder / name
            try:
                if backup is None:
                    if path.is_file() or path.is_symlink():  # a link is removed, never what it points at
                        path.unlink()
                elif stat.S_ISREG(os.lstat(folder / backup).st_mode):
                    os.replace(folder / backup, path)
            except OSError:
                pass
    # with the lock held nobody else writes here: any of our temporary files left is an orphan
    for p in list(folder.glob(f".*.{TAG}*")) + list(folder.glob(".physomni-probe.*")):
        try:
            if p.is_file():
                p.unlink()
        except OSError:
            pass


class _Writes:
    """What one command changed on disk, so that a failure can put everything back.

    ``saved`` maps each replaced or removed file to a hard link (or copy) of its old content, or to
    ``None`` where the command created it; ``dirs`` are the folders the command created; ``locks`` the
    folders it holds (each with the journal of what was changed there).
    """

    def __init__(self):
        self.saved: dict[pathlib.Path, pathlib.Path | None] = {}
        self.dirs: list[pathlib.Path] = []
        self.locks: dict[pathlib.Path, _Lock] = {}

    def hold(self, folder: pathlib.Path) -> _Lock:
        """The lock of ``folder``, taken on the first write there and kept to the end of the command."""
        # the folder as it is on disk: a shot folder the user reached through a link (allowed) is one lock, whether
        # it is named by the link (the command's lock before it reads) or by itself (save_layer resolves the folder);
        # two names would be two locks on one file, and the second would wait on the first
        folder = pathlib.Path(os.path.realpath(folder))
        if folder not in self.locks:
            self.locks[folder] = _Lock(folder)
        return self.locks[folder]

    def note_temporary(self, tmp: pathlib.Path) -> None:
        lock = self.hold(tmp.parent)
        lock.journal["temporary"].append(tmp.name)
        lock.write()

    def keep(self, path: pathlib.Path) -> None:
        """Remember ``path``'s content before its first change in this command."""
        path = pathlib.Path(os.path.abspath(path))
        if path in self.saved:
            return
        refuse_link(path)  # its old content would be read through the link, and put back into the link
        lock = self.hold(path.parent)
        if not path.is_file():
            self.saved[path] = None
        else:
            fd, backup = tempfile.mkstemp(prefix=f".{path.name}.{TAG}", suffix=".keep", dir=path.parent)
            os.close(fd)
            os.unlink(backup)
            try:
                os.link(path, backup)
            except OSError:  # a file system without hard links
                shutil.copy2(path, backup)
            self.saved[path] = pathlib.Path(backup)
        # journal first, change after: a kill between the two leaves a journal that restores nothing new
        lock.journal["saved"][path.name] = None if self.saved[path] is None else self.saved[path].name
        lock.write()

    def commit(self) -> None:
        """The command's files are all in place: emptying the journals is the commit (a kill before it
        puts the old shot back, one after it keeps the new); then the kept old contents go."""
        for lock in self.locks.values():
            lock.journal = {"pid": os.getpid(), "saved": {}, "temporary": []}
            lock.write()
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
        for lock in self.locks.values():
            for name in lock.journal.get("temporary", ()):
                try:
                    (lock.folder / name).unlink()
                except OSError:
                    pass
            lock.journal = {"pid": os.getpid(), "saved": {}, "temporary": []}
            lock.write()

    def release(self) -> None:
        for lock in self.locks.values():
            lock.release()
        self.locks.clear()
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
    # a signal that came before this block was dealt with by whoever caught it (the preview stops on Ctrl-C,
    # then writes its take): only one that comes while the block runs undoes the block
    earlier = received_signal()
    done = False
    try:
        yield
        done = True
    except BaseException:
        with signals_held():  # a signal now would leave the roll-back half done
            writes.roll_back()
        raise
    finally:
        if not done:
            _ACTIVE.reset(token)
            writes.release()
    # From the last look for a signal to the end of the commit a signal is only noted: it must not cut the
    # commit in half (the journals are emptied folder after folder); one noted meanwhile is raised after it.
    with signals_held():
        try:
            try:
                if earlier is None:
                    raise_if_signalled()  # one whose exception was swallowed on the way still undoes the command
            except BaseException:
                writes.roll_back()
                raise
            writes.commit()
            writes.dirs.clear()  # kept: the command succeeded
        finally:
            _ACTIVE.reset(token)
            writes.release()


@contextmanager
def folder_lock(folder: os.PathLike | str):
    """Hold ``folder``'s lock from now on: inside :func:`all_or_nothing` to the end of the command (so that
    what a command reads there before it writes cannot change under it: ``estimate --set`` reading
    ``edits.usda``), else for the block. A folder that does not exist yet is locked on its first write."""
    folder = pathlib.Path(folder)
    writes = _ACTIVE.get()
    if not folder.is_dir():
        yield
    elif writes is not None:
        writes.hold(folder)
        yield
    else:
        lock = _Lock(pathlib.Path(os.path.abspath(folder)))
        try:
            yield
        finally:
            lock.journal = {}
            lock.write()
            lock.release()


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
    refuse_link(path)
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
    refuse_link(path)  # the rename would replace the link, not write through it; but the link was someone's
    with all_or_nothing():  # a lone write still takes the folder's lock and journals its temporary file
        writes = _ACTIVE.get()
        writes.hold(path.parent)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.{TAG}", suffix=path.suffix, dir=path.parent)
        os.close(fd)
        writes.note_temporary(pathlib.Path(tmp))
        try:
            try:
                yield pathlib.Path(tmp)
            except OSError as exc:  # a write that failed names the file it was for, not the temporary
                if exc.errno in IO_FAILURES and not exc.filename:
                    raise OSError(exc.errno, exc.strerror, str(path)) from None
                raise
            except Exception as exc:  # USD's own error for a full disk (pxr.Tf.ErrorException)
                why = next((e for e in IO_FAILURES if os.strerror(e) in str(exc)), None)
                if why is not None:
                    raise OSError(why, os.strerror(why), str(path)) from None
                raise
            os.chmod(tmp, 0o666 & ~_umask())
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


def refuse_link(path: os.PathLike | str) -> None:
    """Raise :class:`InputError` (exit 2) if ``path`` is a symbolic link: a shot folder may come from anyone,
    and a link in it must not carry a write (or a removal) to a file outside."""
    if os.path.islink(path):
        try:
            to = f" (to {os.readlink(path)})"
        except OSError:
            to = ""
        raise InputError(f"cannot write {path}: it is a symbolic link{to}, and files are written only inside "
                         "the folder, never through a link; remove the link (or put the file itself there)")


def _link_below(path: pathlib.Path, inside: pathlib.Path) -> pathlib.Path | None:
    """The first folder between ``inside`` (excluded: the user may have made it a link) and ``path`` that is
    a symbolic link, or None; also None when ``path`` is not under ``inside`` (an output the user named)."""
    path, inside = pathlib.Path(os.path.abspath(path)), pathlib.Path(os.path.abspath(inside))
    try:
        parts = path.parent.relative_to(inside).parts
    except ValueError:
        return None
    for k in range(1, len(parts) + 1):
        if os.path.islink(inside.joinpath(*parts[:k])):
            return inside.joinpath(*parts[:k])
    return None


def check_writable(paths, inside: os.PathLike | str | None = None) -> None:
    """Raise :class:`InputError` naming the first of ``paths`` that could not be written: a folder in its
    place, a file where a folder must be, a folder that refuses new files, or a symbolic link (the file
    itself, or a folder between ``inside``, the shot's folder, and it). Called before any work.

    Folders are probed by creating (and removing) a temporary file in them, which is what the writes do;
    missing folders count as writable where their nearest existing ancestor is.
    """
    probed: dict[pathlib.Path, str | None] = {}
    for p in paths:
        p = pathlib.Path(p)
        refuse_link(p)
        link = _link_below(p, inside) if inside is not None else None
        if link is not None:
            refuse_link(link)
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
        if p.is_file() and _locked_down(p):
            raise InputError(f"cannot replace {p}: the file is immutable or append-only (lsattr shows it; "
                             "chattr -i or -a lifts it)")


#: Linux's inode flags ioctl (FS_IOC_GETFLAGS) and its immutable and append-only bits.
_GETFLAGS, _IMMUTABLE, _APPEND = 0x80086601, 0x10, 0x20


def _locked_down(path: pathlib.Path) -> bool:
    """Whether ``path`` is immutable or append-only: even root cannot rename over it, which a write
    would find only after all its work."""
    import array

    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError:
        return False
    try:
        flags = array.array("l", [0])
        fcntl.ioctl(fd, _GETFLAGS, flags, True)
        return bool(flags[0] & (_IMMUTABLE | _APPEND))
    except OSError:  # a file system without these flags
        return False
    finally:
        os.close(fd)


def _probe(folder: pathlib.Path) -> str | None:
    try:
        fd, tmp = tempfile.mkstemp(prefix=".physomni-probe.", dir=folder)
    except OSError as exc:
        return f"the folder {folder} is not writable ({exc.strerror})"
    os.close(fd)
    os.unlink(tmp)
    return None


#: I/O failures that are the disk's or the file system's, not a bug: errno → (what to say, exit code).
IO_FAILURES = {errno.ENOSPC: ("no space left on the device", 1), errno.EDQUOT: ("disk quota exceeded", 1),
               errno.EFBIG: ("the file would be too large", 1), errno.EIO: ("input/output error", 1),
               errno.EROFS: ("the file system is read-only", 2), errno.EACCES: ("permission denied", 2),
               errno.EPERM: ("the operation is not permitted (an immutable file?)", 2)}


def shown_name(path) -> str:
    """The file a user knows for ``path``: a temporary file beside it (``.sim.physomni-XXXX.usdc``) is
    named as the file it was to replace (``sim.usdc``)."""
    if path is None:
        return "a file"
    p = pathlib.Path(os.fsdecode(path))
    stem, sep, rest = p.name.partition(f".{TAG}")
    if sep and stem.startswith("."):
        suffix = rest.partition(".")[2]
        return str(p.with_name(stem[1:] + (f".{suffix}" if suffix and suffix != "keep" else "")))
    return str(p)


def io_failure(exc: OSError) -> tuple[str, int] | None:
    """``(one line, exit code)`` for an :class:`OSError` of the disk (full, read-only, failing), else None."""
    known = IO_FAILURES.get(exc.errno)
    if known is None:
        return None
    why, code = known
    return f"cannot write {shown_name(exc.filename)}: {why}; the shot's files are as they were", code
