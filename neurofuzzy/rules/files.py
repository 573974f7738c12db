"""Rule files as YAML with line numbers: :mod:`neurofuzzy.io.safe_yaml` with a rule file's size
limit (:data:`MAX_RULE_FILE_BYTES`)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from ..io import safe_yaml
from ..io.safe_yaml import Mapping, Sequence

__all__ = ["Mapping", "Sequence", "load", "loads", "fingerprint", "MAX_RULE_FILE_BYTES"]

#: largest rule file read (the shipped ones are a few kB)
MAX_RULE_FILE_BYTES = 2**20


def load(path) -> object:
    """Parse a rule file; bad YAML raises ``InputError`` with the file and line."""
    return safe_yaml.load(path, max_bytes=MAX_RULE_FILE_BYTES, kind="rule file")


def loads(text: str, source: str) -> object:
    """Parse the text of a rule file (not yet written to ``source``), with
    :func:`load`'s size limit and messages."""
    if len(text.encode("utf-8")) > MAX_RULE_FILE_BYTES:
        from ..errors import InputError

        raise InputError(f"is larger than {MAX_RULE_FILE_BYTES // 2**20} MB; a rule file is "
                         "a few kB", source=source)
    return safe_yaml.loads(text, source)


def fingerprint(path, text: str | None = None) -> tuple[str, str]:
    """``(file, sha256)`` of a rule file as read: its bytes, or ``text`` (an editor's unsaved
    content) encoded as UTF-8; the checksum ``sha256sum FILE`` prints."""
    data = Path(path).read_bytes() if text is None else text.encode("utf-8")
    return str(path), hashlib.sha256(data).hexdigest()
