"""Rule files as YAML with line numbers: :mod:`neurofuzzy.safe_yaml` with a rule file's size
limit (:data:`MAX_RULE_FILE_BYTES`)."""

from __future__ import annotations

from .. import safe_yaml
from ..safe_yaml import Mapping, Sequence

__all__ = ["Mapping", "Sequence", "load", "MAX_RULE_FILE_BYTES"]

#: largest rule file read (the shipped ones are a few kB)
MAX_RULE_FILE_BYTES = 2**20


def load(path) -> object:
    """Parse a rule file; bad YAML raises ``InputError`` with the file and line."""
    return safe_yaml.load(path, max_bytes=MAX_RULE_FILE_BYTES, kind="rule file")
