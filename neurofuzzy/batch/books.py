"""The books of a ``fit-many`` results folder: what it may hold, the manifest it was made
from, what ``--resume`` may keep, and each specimen's record.

A results folder ``OUT`` holds ``results.csv`` (and ``results.parquet``), ``fit-many.json``
(the manifest the folder was made from: its path, a SHA-256 of its content and every
specimen's id and input files) and one folder per specimen. Before anything runs,
:func:`check_folder` refuses an id that would collide with these files, an input that an
output would overwrite, an earlier run without ``resume``, and, with ``resume``, a folder made
from another manifest (another cohort's results are never mixed in or replaced).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from glob import escape as glob_escape
from pathlib import Path

from ..errors import InputError
from ..io.writing import atomic_write
from .manifest import BOOKS_NAME, FOLDER_FILES, LOCK_NAME, Specimen
from .task import OUTPUT_FILES

__all__ = ["RECORD_FORMAT", "check_folder", "finished", "write_books", "write_specimen", "sweep"]

#: marks the records this module writes (``fit.json``, ``error.json``, ``fit-many.json``)
RECORD_FORMAT = "neurofuzzy-fit-many/1"
#: the files of one specimen's folder
_SPECIMEN_FILES = ("fit.json", "error.json", *OUTPUT_FILES)


def _inputs_as_seen_from(out: Path, specimen: Specimen) -> list[str]:
    """The specimen's input files relative to the results folder (a folder moved with its
    inputs keeps its books)."""
    return sorted(Path(os.path.relpath(path, out.resolve())).as_posix()
                  for path in specimen.inputs)


def write_books(out: Path, manifest, specimens) -> None:
    """Record the manifest the folder is made from (before any result is written)."""
    manifest = Path(manifest)
    record = {"format": RECORD_FORMAT, "manifest": str(manifest.resolve()),
              "sha256": hashlib.sha256(manifest.read_bytes()).hexdigest(),
              "specimens": {s.id: _inputs_as_seen_from(out, s) for s in specimens}}
    _write_json(out / BOOKS_NAME, record)


def _books(out: Path) -> dict | None:
    try:
        record = json.loads((out / BOOKS_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if isinstance(record, dict) and record.get("format") == RECORD_FORMAT \
            and isinstance(record.get("specimens"), dict):
        return record
    return None


def check_folder(out: Path, report: Path | None, manifest, specimens, resume: bool) -> None:
    """Refuse, before anything runs, a results folder the batch could not leave resumable
    or would mix with another cohort, and outputs that would overwrite an input."""
    manifest = Path(manifest)
    if out.exists() and not out.is_dir():
        raise InputError("is a file; --out names the folder of the results", source=str(out))
    inputs = {manifest.resolve(): None,
              **{path.resolve(): s for s in specimens for path in s.inputs}}
    outputs = [out / name for name in FOLDER_FILES] + [
        out / s.id / name for s in specimens for name in _SPECIMEN_FILES]
    for path in outputs:
        if path.resolve() in inputs:
            owner = inputs[path.resolve()]
            raise InputError(f"is an input of the batch{f' (specimen {owner.id})' if owner else ''}"
                             f" and fit-many would write its results there; move the input "
                             "or choose another --out", source=str(path), key="--out")
    earlier = any((out / name).exists() for name in FOLDER_FILES if name != LOCK_NAME) \
        or any((out / s.id / name).exists() for s in specimens
               for name in ("fit.json", "error.json"))
    if earlier and not resume:
        raise InputError("holds the results of an earlier fit-many; add --resume to keep "
                         "what is finished and fit the rest, or choose another --out",
                         source=str(out))
    if earlier and resume:
        _same_cohort(out, manifest, specimens)
    if report is not None:
        _check_report(out, report, manifest, specimens, inputs)
        for path in (report, report.with_suffix(".json")):
            if path.resolve() in {output.resolve() for output in outputs}:
                raise InputError("is a file fit-many writes itself (a specimen's or the "
                                 "folder's); name the cohort report elsewhere",
                                 key="--report", source=str(path))


def _same_cohort(out: Path, manifest: Path, specimens) -> None:
    """``--resume`` continues a run of the same cohort: the manifest that made the folder, or
    one whose specimens include every earlier one with the same input files (options may
    change: those specimens are fitted again)."""
    books = _books(out)
    if books is None:
        return                      # a folder of an older fit-many: nothing to compare
    if books.get("sha256") == hashlib.sha256(manifest.read_bytes()).hexdigest():
        return
    now = {s.id: _inputs_as_seen_from(out, s) for s in specimens}
    missing = [ident for ident in books["specimens"] if ident not in now]
    moved = [ident for ident, files in books["specimens"].items()
             if ident in now and sorted(files) != now[ident]]
    if not missing and not moved:
        return
    why = (f"its specimens {', '.join(map(repr, missing[:3]))}{' …' if len(missing) > 3 else ''}"
           " are not in this manifest" if missing else
           f"specimen {moved[0]!r} reads other files there ({', '.join(books['specimens'][moved[0]][:2])})")
    raise InputError(f"was made from another manifest ({books.get('manifest')}): {why}; "
                     "--resume continues a run of the same cohort, and this one would mix "
                     f"with it and replace its table. Choose another --out for {manifest}",
                     source=str(out), key="--resume")


def _check_report(out, report: Path, manifest, specimens, inputs) -> None:
    twin = report.with_suffix(".json")
    if report.suffix.lower() == ".json":
        raise InputError("the report is HTML with a .json twin beside it; name an .html file",
                         key="--report", source=str(report))
    for path in (report, twin):
        if path.resolve() in inputs:
            raise InputError("is an input of the batch; neurofuzzy never writes over its "
                             "input", key="--report", source=str(path))
        if path.resolve().parent == out.resolve():
            clash = [s for s in specimens if s.id.lower() == path.name.lower()]
            if clash:
                raise clash[0].error(f"{clash[0].id!r} is the name of the cohort report "
                                     f"({path}) in the results folder; choose another id or "
                                     "another --report", "id")
        if path.resolve().parent == out.resolve() and path.name.lower() in FOLDER_FILES:
            raise InputError(f"would replace the batch's own {path.name}; choose another name",
                             key="--report", source=str(report))
    if twin.exists() and not _is_cohort_twin(twin):
        raise InputError(f"the report's JSON twin would replace {twin}, which is not a "
                         "neurofuzzy cohort report; move it or name another --report",
                         key="--report", source=str(report))


def _is_cohort_twin(path: Path) -> bool:
    from .cohort import REPORT_FORMAT

    try:
        return json.loads(path.read_text(encoding="utf-8")).get("format") == REPORT_FORMAT
    except (OSError, ValueError, AttributeError):
        return False


def finished(folder: Path, fingerprint: str) -> dict | None:
    """The record of a finished fit made from the same inputs, or None."""
    try:
        record = json.loads((folder / "fit.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if (isinstance(record, dict) and record.get("format") == RECORD_FORMAT
            and record.get("status") == "ok" and record.get("fingerprint") == fingerprint):
        return record
    return None


def write_specimen(folder: Path, specimen: Specimen, fingerprint: str, outcome: dict) -> dict:
    """Write one specimen's outputs atomically (``fit.json`` last) and return its record."""
    from ..formatting import json_safe

    record = {"format": RECORD_FORMAT, "id": specimen.id, "group": specimen.group,
              "status": outcome["status"], "fingerprint": fingerprint,
              "seconds": outcome.get("seconds"), "worker": outcome.get("worker"),
              "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    if outcome.get("retries"):
        record["retries"] = outcome["retries"]      # worker processes lost while fitting it
    folder.mkdir(parents=True, exist_ok=True)
    if outcome["status"] == "ok":
        for name, content in outcome["files"].items():
            with atomic_write(folder / name, "wb") as handle:
                handle.write(content)
        for name in set(OUTPUT_FILES) - set(outcome["files"]):       # of an earlier run
            (folder / name).unlink(missing_ok=True)
        record.update(fit=outcome["fit"], files=sorted(outcome["files"]))
        _write_json(folder / "fit.json", record)
        (folder / "error.json").unlink(missing_ok=True)
    else:
        (folder / "fit.json").unlink(missing_ok=True)       # an earlier result is stale now
        record.update({key: outcome[key] for key in ("kind", "error", "traceback")
                       if key in outcome})
        _write_json(folder / "error.json", record)
    return json_safe(record)


def sweep(out: Path, specimens, report: Path | None = None) -> list[Path]:
    """Remove what an interrupted run's atomic writes left half-written: the temporary files
    (``.NAME.*.tmp``) beside the folder's, each specimen's and the report's files. They are
    never read as results (a result is only ever its final name); they are not kept either.

    Returns
    -------
    list of Path
        The files removed.
    """
    places = [(out, FOLDER_FILES)] + [(out / s.id, _SPECIMEN_FILES) for s in specimens]
    if report is not None:
        places.append((report.parent, (report.name, report.with_suffix(".json").name)))
    removed = []
    for folder, names in places:
        for name in names:
            for path in folder.glob(f".{glob_escape(name)}.*.tmp"):
                path.unlink(missing_ok=True)
                removed.append(path)
    return removed


def _write_json(path: Path, value: dict) -> None:
    from ..formatting import json_safe

    with atomic_write(path, "w") as handle:
        json.dump(json_safe(value), handle, indent=1)
