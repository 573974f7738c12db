"""Fit results beside the rule base: the learned material values of a ``fit --json`` output
(per region) or of a ``fit-many`` results folder (per specimen), each next to the start value
the rule base gives its tissue, with the words before and after.

The words are the rule base's as it is now: an expert who moves a term sees the words of the
learned values follow. The words recorded in the file at fit time are kept beside them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["read_fit", "read_results", "fit_view", "find_results", "MAX_FIT_BYTES"]

#: largest fit result read (per-element fits carry every element's values)
MAX_FIT_BYTES = 64 * 2**20
_QUANTITIES = ("youngs_modulus", "poisson_ratio", "viscosity", "density")


def read_fit(data, source: str) -> list[dict]:
    """The entries (one per region, or per specimen's region) of a parsed fit result.

    Parameters
    ----------
    data : dict
        A ``fit --json`` object (with ``materials``) or a fit-many record (``fit.json``:
        ``id``, ``group``, ``fit``).
    source : str
        Where it came from, for messages.

    Returns
    -------
    list of dict
        ``{"label", "group", "tissue", "values": {quantity: value}, "recorded": {quantity:
        word}}``.
    """
    if not isinstance(data, dict):
        raise InputError("is not a fit result (a JSON object)", source=source)
    specimen, group = None, None
    if isinstance(data.get("fit"), dict):          # a fit-many record
        if data.get("status") not in (None, "ok"):
            return []
        specimen, group = data.get("id"), data.get("group")
        data = data["fit"]
    materials = data.get("materials")
    if not isinstance(materials, dict) or not materials:
        raise InputError("has no 'materials' (fit --json writes them when the fit starts "
                         "from a rule base or a model with tissues)", source=source)
    entries = []
    for region, values in materials.items():
        if not isinstance(values, dict):
            continue
        found = {q: float(values[q]) for q in _QUANTITIES
                 if isinstance(values.get(q), (int, float)) and np.isfinite(values[q])}
        labels = values.get("labels") if isinstance(values.get("labels"), dict) else {}
        label = str(region) if specimen is None else f"{specimen} ({region})" \
            if len(materials) > 1 else str(specimen)
        entries.append({"label": label, "group": None if group is None else str(group),
                        "tissue": None if values.get("tissue") is None
                        else str(values["tissue"]),
                        "values": found, "recorded": {str(k): str(v) for k, v in labels.items()}})
    return entries


def _load_json(path: Path) -> object:
    try:
        if path.stat().st_size > MAX_FIT_BYTES:
            raise InputError(f"is larger than {MAX_FIT_BYTES // 2**20} MB", source=str(path))
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise InputError(f"cannot read it as JSON ({error})", source=str(path)) from None


def read_results(path: Path) -> list[dict]:
    """The entries of a fit result file, or of a fit-many folder (every ``*/fit.json``)."""
    if path.is_dir():
        records = sorted(path.glob("*/fit.json"))
        if not records:
            raise InputError("holds no */fit.json (a fit-many --out folder does)",
                             source=str(path))
        entries = []
        for record in records:
            entries += read_fit(_load_json(record), str(record))
        return entries
    return read_fit(_load_json(path), str(path))


def find_results(folder: Path, limit: int = 200) -> list[str]:
    """Fit results under ``folder``, relative to it: JSON files one or two levels deep, and
    fit-many folders (``NAME/`` holding ``*/fit.json``)."""
    cohorts = {record.parent.parent for pattern in ("*/fit.json", "*/*/fit.json")
               for record in folder.glob(pattern)}
    found = []
    for pattern in ("*.json", "*/*.json"):
        for path in sorted(folder.glob(pattern)):
            parts = path.relative_to(folder).parts
            if any(part.startswith(".") for part in parts) or path.parent.parent in cohorts:
                continue
            found.append("/".join(parts))
    found += sorted("/".join(c.relative_to(folder).parts) + "/" for c in cohorts
                    if c != folder and not c.name.startswith("."))
    return found[:limit]


def fit_view(entries: list[dict], rules) -> list[dict]:
    """Every entry with, per output of ``rules``: the learned value and its word now, the
    start value of its tissue and its word, and the word recorded at fit time."""
    out = []
    for entry in entries:
        start = {}
        if rules is not None and entry["tissue"] in rules.tissues:
            try:
                start = rules.tissue(entry["tissue"])
            except InputError:
                start = {}
        rows = []
        for name, variable in (rules.outputs.items() if rules is not None else ()):
            quantity = variable.quantity
            if quantity not in entry["values"]:
                continue
            learned = entry["values"][quantity]
            before = start.get(name)
            inside = variable.low <= learned <= variable.high
            rows.append({
                "output": name, "quantity": quantity, "learned": learned,
                "after": rules.describe({name: learned})[name].term if inside else None,
                "start": before,
                "before": rules.describe({name: before})[name].term if before is not None
                else None,
                "recorded": entry["recorded"].get(quantity), "outside": not inside})
        out.append({**entry, "rows": rows})
    return out
