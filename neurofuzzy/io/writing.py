"""Writing results atomically: a temporary file beside the target, then a rename. (JSON-ready
values are :func:`neurofuzzy.formatting.json_safe`.)"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


__all__ = ["atomic_write"]


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb"):
    """Open a temporary file beside ``path``; on success flush it to the disk and rename it
    onto ``path``.

    Use as ``with atomic_write(path) as handle: ...``. On an exception the temporary file is
    removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)         # mkstemp makes 0600; outputs are ordinary files
    try:
        with os.fdopen(fd, mode) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())           # on disk before its name says it is there
        os.replace(temporary, path)
    except BaseException as error:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        if isinstance(error, OSError) and error.filename in (None, temporary):
            error.filename = str(path)          # a full disk names the file the user knows
        raise
