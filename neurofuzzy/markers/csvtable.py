"""CSV tables of marker, map, force and manifest files: a header, rows with their lines, and
``# key: value`` statements; numbers read with the file's line in every message."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from ..errors import InputError
from .units import Stated

__all__ = ["read_csv_table", "number", "TIME_TOLERANCE"]

#: relative tolerance on times: a time within this fraction of a frame period is "on" a frame
TIME_TOLERANCE = 1e-6


def read_csv_table(path: Path, required: list[tuple[str, ...]]):
    """Header (column name → index), data rows as (line, cells), and the ``# key: value``
    comment lines (a :class:`~.units.Stated`, with their lines)."""
    source = str(path)
    if not path.is_file():
        raise InputError("no such file", source=source)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read the file ({error})", source=source) from None
    stated = Stated()
    header = None
    rows = []
    for line, cells in enumerate(csv.reader(text.splitlines()), start=1):
        if not cells or not "".join(cells).strip():
            continue
        if cells[0].lstrip().startswith("#"):
            comment = ",".join(cells).lstrip()[1:]
            if ":" in comment:
                key, value = comment.split(":", 1)
                stated.state(key.strip().lower(), value.strip(), line, source)
            continue
        if header is None:
            header = {name.strip().lower(): i for i, name in enumerate(cells)}
            for choices in required:
                if not any(choice in header for choice in choices):
                    wanted = ",".join(choice[0] if len(choice) == 1 else "|".join(choice)
                                      for choice in required)
                    raise InputError(f"missing column {'/'.join(choices)!r}; the header must "
                                     f"name the columns {wanted}, got {','.join(cells)}",
                                     source=source, line=line)
            width = len(cells)
            continue
        if len(cells) != width:
            raise InputError(f"{len(cells)} values; the header has {width} columns",
                             source=source, line=line)
        rows.append((line, cells))
    if header is None:
        raise InputError("empty file: no header line", source=source)
    return header, rows, stated


def number(text: str, source: str, line: int, column: str, *,
           allow_missing: bool = False) -> float:
    """The number in a cell; an :class:`InputError` naming FILE:LINE and the column if it is
    none (``allow_missing``: empty, ``nan`` and ``na`` are NaN, infinity is refused)."""
    text = text.strip()
    if allow_missing and text.lower() in ("", "nan", "na"):
        return float("nan")
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{column} is {text!r}; expected a number", source=source,
                         line=line) from None
    if allow_missing and math.isinf(value):
        raise InputError(f"{column} is infinite", source=source, line=line)
    return value
