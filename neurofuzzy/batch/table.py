"""The results table of ``fit-many``: one row per specimen and material region.

Columns (:data:`COLUMNS`): the specimen's ``id``, ``group`` and ``status`` (``ok``,
``failed`` or ``waiting``), the ``region`` and its ``tissue``, the learned materials
(:data:`QUANTITIES`: ``youngs_modulus`` Pa, ``poisson_ratio``, ``viscosity`` Pa·s,
``density`` kg/m³) with the rule base's word for each (``youngs_modulus_word`` …), the fit
quality (``rms_error`` m per marker, ``noise_rms`` m, ``noise_ratio`` and whether the fit
``explained`` the data to the noise, :mod:`neurofuzzy.learn.lack_of_fit`), the ``effects`` a
diagnosis
found, ``seconds``, the specimen's ``report`` (relative to the output folder) and ``error``.
"""

from __future__ import annotations

import csv
import importlib.util
import io
from pathlib import Path

from ..io.writing import atomic_write

__all__ = ["QUANTITIES", "COLUMNS", "TABLE_NAME", "table_rows", "write_table"]

#: the learned material quantities of a region (the keys of :func:`~neurofuzzy.tissues.materials`)
QUANTITIES = ("youngs_modulus", "poisson_ratio", "viscosity", "density")
COLUMNS = ("id", "group", "status", "region", "tissue", *QUANTITIES,
           *(f"{q}_word" for q in QUANTITIES), "rms_error", "noise_rms", "noise_ratio",
           "explained", "effects", "seconds", "report", "error")
TABLE_NAME = "results.csv"


def table_rows(specimens, records: dict) -> list[dict]:
    """Rows of the table (dicts keyed by :data:`COLUMNS`; missing values None).

    Parameters
    ----------
    specimens : sequence of Specimen
        In the manifest's order.
    records : dict
        Specimen id → record (see :class:`~neurofuzzy.batch.Cohort`), or None while waiting.
    """
    rows = []
    for specimen in specimens:
        record = records.get(specimen.id)
        base = {"id": specimen.id, "group": specimen.group,
                "status": "waiting" if record is None else record["status"]}
        if record is None or record["status"] != "ok":
            rows.append({**dict.fromkeys(COLUMNS), **base,
                         "error": None if record is None else record.get("error")})
            continue
        fit = record["fit"]
        quality = fit.get("quality", {})
        common = {**base, "rms_error": quality.get("rms_error", fit.get("rms_error")),
                  "noise_rms": quality.get("noise_rms"),
                  "noise_ratio": quality.get("noise_ratio"),
                  "explained": quality.get("explained"),
                  "effects": " ".join(fit["diagnosis"]["effects"]) if "diagnosis" in fit
                  else None,
                  "seconds": record.get("seconds"), "report": f"{specimen.id}/report.html"}
        for region, values in (fit.get("materials") or {None: {}}).items():
            words = values.get("labels") or {}
            rows.append({**dict.fromkeys(COLUMNS), **common, "region": region,
                         "tissue": values.get("tissue"),
                         **{q: values.get(q) for q in QUANTITIES},
                         **{f"{q}_word": words.get(q) for q in QUANTITIES}})
    return rows


def write_table(path: Path, specimens, records: dict) -> Path:
    """Write the table as CSV atomically (and as Parquet beside it when pyarrow is
    installed; neurofuzzy does not require it)."""
    rows = table_rows(specimens, records)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({key: "" if value is None else _cell(value) for key, value in row.items()}
                     for row in rows)
    with atomic_write(path, "w") as handle:
        handle.write(text.getvalue())
    if importlib.util.find_spec("pyarrow") is not None:
        import pyarrow
        import pyarrow.parquet

        with atomic_write(path.with_suffix(".parquet"), "wb") as handle:
            pyarrow.parquet.write_table(pyarrow.Table.from_pylist(rows), handle)
    return path


def _cell(value):
    return repr(value) if isinstance(value, float) else value
