"""One ``fit-many`` per results folder: :func:`folder_lock`.

The lock is the file ``OUT/fit-many.lock`` holding its owner's host, process id, start time
and manifest (JSON), and an exclusive ``flock`` on it for as long as the run lasts. The
operating system drops the ``flock`` of a process that dies, however it dies (``SIGKILL``
included), so the file a dead run leaves behind is *stale*: the next run on the same host
finds it free, reports whose it was and takes it over. A second run while the first is alive
cannot take the ``flock`` and is refused, naming the owner (:class:`FolderInUseError`, exit
2). A lock left by a run on another host, whose process cannot be checked from here, is
refused with the file to remove once that run is known to be over.

Where ``fcntl`` is missing (Windows) the lock is the file alone, and a stale one is known by
its owner's process id on this host no longer running.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from pathlib import Path

from ..errors import FolderInUseError, InputError
from .manifest import LOCK_NAME

__all__ = ["LOCK_NAME", "folder_lock"]


@contextlib.contextmanager
def folder_lock(out: Path, manifest, *, notes=None):
    """Hold the lock of the results folder ``out`` while the block runs.

    Parameters
    ----------
    out : Path
        The results folder; created if needed (and removed again on leaving when it was
        created here and is empty, so that a refused run leaves no folder behind).
    manifest : path
        Recorded in the lock, for the message another run prints.
    notes : callable, optional
        ``notes(text)`` is told of a stale lock that was taken over.

    Raises
    ------
    FolderInUseError
        A live run holds the folder, or a run on another host left its lock.
    """
    if out.exists() and not out.is_dir():
        raise InputError("is a file; --out names the folder of the results", source=str(out))
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK_NAME
    handle = None
    try:
        handle = _take(path, manifest, notes)
        yield path
    finally:
        if handle is not None:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()          # while still holding it: the next run makes a new file
            handle.close()
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()            # only when empty: a refused run leaves nothing


def _take(path: Path, manifest, notes):
    """Open, lock and fill ``path``; the open file (its ``flock`` held) is returned."""
    while True:
        handle = open(path, "a+", encoding="utf-8")
        try:
            if not _flock(handle):
                raise _in_use(_owner(path), path)
            if not _same_file(handle, path):
                handle.close()         # its owner removed it as it finished: lock the new one
                continue
            owner = _owner(path)
            if owner is not None:
                _check_stale(owner, path, notes)
            handle.seek(0)
            handle.truncate()
            json.dump({"host": socket.gethostname(), "pid": os.getpid(),
                       "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                       "manifest": str(Path(manifest).resolve())}, handle)
            handle.flush()
            return handle
        except BaseException:
            handle.close()
            raise


def _flock(handle) -> bool:
    """Take the exclusive ``flock`` without waiting; False when another process holds it."""
    try:
        import fcntl
    except ImportError:                # Windows: the pid check alone (see the module)
        return True
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _same_file(handle, path: Path) -> bool:
    try:
        return os.fstat(handle.fileno()).st_ino == path.stat().st_ino
    except FileNotFoundError:
        return False


def _owner(path: Path) -> dict | None:
    """The owner recorded in the lock file (None when empty or unreadable: a run killed as it
    wrote its lock)."""
    try:
        owner = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return owner if isinstance(owner, dict) else None


def _check_stale(owner: dict, path: Path, notes) -> None:
    """A lock whose ``flock`` is free: stale when its owner ran on this host (and, without
    ``fcntl``, is not running any more); another host's is refused."""
    here = socket.gethostname()
    if owner.get("host") != here:
        raise FolderInUseError(
            f"was locked by a fit-many on another host ({_describe(owner)}), which cannot be "
            f"checked from {here}; if that run is over, delete {path} and run again",
            source=str(path.parent), key="--out")
    pid = owner.get("pid")
    alive = isinstance(pid, int) and _running(pid)
    try:
        import fcntl  # noqa: F401
    except ImportError:
        if alive:
            raise _in_use(owner, path) from None
    if notes is not None:
        why = "no longer running" if not alive else "running but no longer holding the lock"
        notes(f"fit-many: took over the stale lock of a run that ended without releasing "
              f"it ({_describe(owner)}: {why})")


def _in_use(owner: dict | None, path: Path) -> FolderInUseError:
    return FolderInUseError(f"another fit-many is writing this results folder "
                            f"({_describe(owner)}); wait for it to finish, or choose another "
                            "--out", source=str(path.parent), key="--out")


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:            # another user's process: it exists
        return True
    return True


def _describe(owner: dict | None) -> str:
    if owner is None:
        return "owner unknown"
    return (f"pid {owner.get('pid')} on {owner.get('host')}, started {owner.get('started')}, "
            f"manifest {owner.get('manifest')}")
