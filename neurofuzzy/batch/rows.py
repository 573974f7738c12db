"""The rows of a ``fit-many`` manifest, read from a CSV or YAML file with every column checked
(:data:`COLUMNS`; an unknown one gets the closest known one as a suggestion)."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError, closest_name

__all__ = ["COLUMNS", "csv_rows", "yaml_rows"]

#: every column a manifest may have
COLUMNS = ("id", "group", "experiments", "markers", "forces", "units", "dt", "start", "rules",
           "tissue", "tie", "law", "stiffening", "relaxation", "prior", "method", "cycles",
           "substeps",
           "learn_masses", "diagnose")


def csv_rows(path: Path) -> list[tuple[int, dict]]:
    """``(line, {column: text})`` for every row of a CSV manifest."""
    from ..markers.readers import read_csv_table

    header, rows, _ = read_csv_table(path, required=[("id",)])
    _check_columns(header, str(path), _header_line(path))
    names = list(header)
    return [(line, {name: cells[header[name]].strip() for name in names})
            for line, cells in rows]


def _header_line(path: Path) -> int:
    for number, text in enumerate(path.read_text(encoding="utf-8-sig").splitlines(), 1):
        if text.strip() and not text.lstrip().startswith("#"):
            return number
    return 1


def yaml_rows(path: Path) -> list[tuple[int, dict]]:
    """``(line, {column: value})`` for every specimen of a YAML manifest, its ``defaults``
    applied."""
    from ..rules.files import load

    source = str(path)
    data = load(path)
    if isinstance(data, list):
        data_specimens, defaults, line = data, {}, data.line
    elif isinstance(data, dict):
        unknown = [key for key in data if key not in ("specimens", "defaults")]
        if unknown:
            hint = closest_name(str(unknown[0]), ("specimens", "defaults"))
            raise InputError(f"unknown key {unknown[0]!r}; a manifest has 'specimens' (and "
                             "'defaults')" + (f"; did you mean {hint!r}?" if hint else ""),
                             source=source, line=data.line_of(unknown[0]))
        data_specimens = data.get("specimens")
        defaults = data.get("defaults") or {}
        line = data.line_of("specimens")
        if data_specimens is None:
            raise InputError("has no 'specimens:' list", source=source, line=data.line)
        if not isinstance(defaults, dict):
            raise InputError("'defaults' must be a mapping of columns", source=source,
                             line=data.line_of("defaults"))
        _check_columns(defaults, source, data.line_of("defaults"), defaults)
    else:
        raise InputError("expected a 'specimens:' list", source=source, line=1)
    if not isinstance(data_specimens, list):
        raise InputError("'specimens' must be a list of mappings", source=source, line=line)
    rows = []
    for index, item in enumerate(data_specimens):
        item_line = data_specimens.line_of(index)
        if not isinstance(item, dict):
            raise InputError("each specimen must be a mapping (id: …, group: …)",
                             source=source, line=item_line)
        _check_columns(item, source, item_line, item)
        rows.append((item_line, {**defaults, **item}))
    return rows


def _check_columns(names, source: str, line: int, mapping=None) -> None:
    for name in names:
        if name not in COLUMNS:
            hint = closest_name(str(name), COLUMNS)
            at = mapping.line_of(name) if hasattr(mapping, "line_of") else line
            raise InputError(f"unknown column {name!r}" + (f"; did you mean {hint!r}?" if hint
                                                            else f"; known: {', '.join(COLUMNS)}"),
                             source=source, line=at)
