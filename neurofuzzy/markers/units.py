"""Units of marker and force files: stated in ``# key: value`` comment lines (or given as an
option), honoured or refused, never ignored; a unit stated twice, differently, is refused."""

from __future__ import annotations

from ..errors import InputError, closest_name

__all__ = ["LENGTH_UNITS", "TIME_UNITS", "FORCE_UNITS", "Stated", "unit_factor",
           "load_cell_factor",
           "check_statements", "header_statements"]

#: metres per unit of every length unit a file may state
LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
#: seconds per unit of every time unit a file may state
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}
#: newtons per unit of every force unit a file may state
FORCE_UNITS = {"N": 1.0, "mN": 1e-3, "kN": 1e3}


class Stated(dict):
    """The ``# key: value`` comment lines of a CSV file (keys in lower case), with the line of
    each (:meth:`line_of`)."""

    def __init__(self):
        super().__init__()
        self.lines: dict[str, int] = {}

    def state(self, key: str, value: str, line: int, source: str) -> None:
        """Record ``key: value`` from ``line``. A unit (or the mesh) stated again, differently,
        is refused (which one holds would be a guess); other comments are free text (the
        last one stands)."""
        if key in self and self[key] != value and ("unit" in key or key == "mesh"):
            raise InputError(f"'# {key}: {value}' contradicts '# {key}: {self[key]}' (line "
                             f"{self.lines[key]}); state it once", source=source, line=line)
        if key not in self or not ("unit" in key or key == "mesh"):
            self[key] = value
            self.lines[key] = line

    def line_of(self, key: str) -> int | None:
        return self.lines.get(key)


def _normalise(value: str, table: dict) -> str | None:
    """The key of ``table`` that ``value`` spells, or None (exact first, then by case where
    that is unambiguous)."""
    value = value.strip()
    if value in table:
        return value
    matches = [key for key in table if key.lower() == value.lower()]
    return matches[0] if len(matches) == 1 else None


def unit_factor(table: dict, *, what: str, stated: Stated, keys: tuple[str, ...],
                source: str, given: str | None = None, given_as: str = "",
                default: str | None = None, missing: str = "") -> float:
    """The factor of the unit a file states (under any of ``keys``) or is given (``given``,
    e.g. an option), checked against ``table``.

    Parameters
    ----------
    table : dict of unit → factor
    what : str
        "length", "time" or "force", for messages.
    stated : Stated
        The file's comment lines.
    keys : tuple of str
        The comment keys that state this unit (``("units", "length units")``).
    given : str, optional
        The unit given another way (``--units mm``); ``given_as`` names that way.
    default : str, optional
        The unit when none is stated (None: the unit must be stated, ``missing`` says how).

    Raises
    ------
    InputError
        An unknown unit (with a "did you mean"), two statements that differ (file lines and
        option named), or no unit where one is required.
    """
    sayings = [(stated[key], f"'# {key}: {stated[key]}' (line {stated.line_of(key)})"
                if stated.line_of(key) else f"the file's {key.upper()} {stated[key]!r}",
                stated.line_of(key) or None) for key in keys if key in stated]
    if given is not None:
        sayings.append((given, f"{given} ({given_as})" if given_as else repr(given), None))
    units = []
    for value, said, line in sayings:
        unit = _normalise(value, table)
        if unit is None:
            hint = closest_name(value.strip(), table)
            raise InputError(f"unknown {what} unit {value.strip()!r}; expected one of "
                             f"{', '.join(dict.fromkeys(table))}"
                             + (f" (did you mean {hint!r}?)" if hint else ""), source=source,
                             line=line)
        units.append((unit, said, line))
    differing = [u for u in units if table[u[0]] != table[units[0][0]]]
    if differing:
        first, other = units[0], differing[0]
        raise InputError(f"the {what} unit is given twice, differently: {first[1]} and "
                         f"{other[1]}; give it once", source=source,
                         line=other[2] or first[2])
    if units:
        return table[units[0][0]]
    if default is not None:
        return table[default]
    raise InputError(missing or f"the {what} unit is not stated", source=source)


def check_statements(stated: Stated, allowed: tuple[str, ...], source: str) -> None:
    """Refuse a comment statement about units that this kind of file does not read (a
    misspelt ``# lenght units:`` or a ``# force units:`` in a marker file would otherwise be
    ignored)."""
    for key in stated:
        if "unit" in key and key not in allowed:
            hint = closest_name(key, allowed)
            raise InputError(f"'# {key}:' is not read in this file" + (
                f"; did you mean '# {hint}:'?" if hint else
                f"; it states {', '.join(repr(k) for k in allowed)}"), source=source,
                line=stated.line_of(key))


def header_statements(path) -> Stated:
    """The ``# key: value`` lines of a CSV file before its header (without reading the data
    rows); an unreadable file gives none (its reader reports it)."""
    stated = Stated()
    try:
        with open(path, encoding="utf-8-sig") as handle:
            for line, text in enumerate(handle, start=1):
                text = text.strip()
                if not text:
                    continue
                if not text.startswith("#"):
                    break
                if ":" in text[1:]:
                    key, value = text[1:].split(":", 1)
                    stated.state(key.strip().lower(), value.strip().rstrip(","), line,
                                 str(path))
    except (OSError, UnicodeDecodeError):
        pass
    return stated


def load_cell_factor(header: dict, stated, source: str) -> float | None:
    """Newtons per unit of a file's ``fx,fy,fz`` columns (None without them): all three or
    none, and a ``# force units:`` line, never guessed."""
    forces = [c in header for c in ("fx", "fy", "fz")]
    if any(forces) and not all(forces):
        raise InputError("names some of fx, fy, fz; a load cell's force needs all three",
                         source=source)
    if not all(forces):
        return None
    if "force units" not in stated:
        raise InputError("has force columns but no '# force units: N' line (N, mN or kN): "
                         "a load cell's unit is never guessed", source=source)
    return unit_factor(FORCE_UNITS, what="force", stated=stated, keys=("force units",),
                       source=source)
