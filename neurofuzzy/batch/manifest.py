"""The manifest of ``fit-many``: one row per specimen, read and checked at the boundary.

A manifest is a CSV file (one header line, one row per specimen, ``#`` comment lines) or a
YAML file (``specimens:``, a list of mappings, with optional ``defaults:`` that every
specimen takes unless it says otherwise). Both know the same columns (:data:`COLUMNS`):

=============== =========================================================================
``id``          the specimen's name: letters, digits, ``.``, ``_``, ``-`` (its folder)
``group``       its group label (``healthy``, ``fibrotic``, …)
``experiments`` experiment files (``.npz``); in CSV several are separated by ``;``
``markers``     or marker recordings (CSV/C3D, one per load case), with ``start``
``forces``      force CSVs of the marker recordings (one per recording)
``units``       the length unit of the marker CSVs (``m``, ``cm``, ``mm``)
``dt``          the frame spacing (s) to resample marker recordings to
``start``       a start model (YAML, e.g. written by ``neurofuzzy mesh``)
``rules``       a rule base (YAML file or the name of a shipped one, ``liver``) …
``tissue``      … and its tissue (a start from the rules, or the words of the report)
``tie``         ``global``, ``groups`` or ``none``
``law``         the elements' material law (``st-venant-kirchhoff``, ``neo-hookean``, ``yeoh``)
``stiffening``  with ``law: yeoh``: Yeoh's C20/C10 to start from (as ``fit --stiffening``)
``relaxation``  Prony terms to fit: a number (1–3) or ``g:tau`` pairs (as ``fit --relaxation``)
``prior``       the rule base as a prior: ``off``, ``auto`` or a weight (default as ``fit``:
                ``auto`` with ``tie: none`` and a rule base)
``method``      ``gradient`` (default) or ``paper``
``cycles``      learning cycles / iterations per stage
``substeps``    integration steps per frame, or ``auto`` (default)
``learn_masses`` ``true`` to learn node masses too
``diagnose``    ``true`` to diagnose the fitted model (name the effect it lacks)
=============== =========================================================================

Paths are relative to the manifest's folder. Every problem names the manifest and the line
of the row (``cohort.csv:4: experiments: no such file s03/push.npz``); unknown columns get
the closest known one as a suggestion.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError, closest_name
from .options import fit_options
from .rows import COLUMNS, csv_rows, yaml_rows

__all__ = ["Specimen", "read_manifest", "relative_path", "COLUMNS", "MANIFEST_SUFFIXES",
           "FOLDER_FILES", "BOOKS_NAME", "LOCK_NAME"]

#: file types a manifest may be
MANIFEST_SUFFIXES = (".csv", ".yaml", ".yml")
#: columns that hold lists of files
_FILE_LISTS = ("experiments", "markers", "forces")
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
#: part of every fingerprint: a change in what a specimen's task computes invalidates results
_TASK_VERSION = "fit-many/1"
#: the record of the manifest a results folder was made from (what ``--resume`` checks)
BOOKS_NAME = "fit-many.json"
#: the lock of the run writing a results folder (:mod:`.lock`)
LOCK_NAME = "fit-many.lock"
#: the files fit-many keeps at the top of its results folder: no specimen's folder may take
#: their names (compared without letter case, as macOS and Windows file systems do)
FOLDER_FILES = ("results.csv", "results.parquet", BOOKS_NAME, LOCK_NAME)


@dataclass(frozen=True)
class Specimen:
    """One row of a manifest: what to fit and how.

    Attributes
    ----------
    id, group : str
    experiments : tuple of Path
        Experiment files (absolute), or empty when ``markers`` are given.
    markers, forces : tuple of Path
        Marker recordings and their force files (absolute; ``forces`` empty or one per
        recording).
    start : Path or None
        Start model file.
    rules : str or None
        A rule base file (absolute path) or the name of a shipped one.
    tissue : str or None
    options : dict
        ``tie``, ``prior``, ``method``, ``cycles``, ``substeps``, ``learn_masses``,
        ``diagnose``,
        ``units``, ``dt``: what was given, checked.
    source : str
        The manifest; ``line`` the row's line in it, for messages.
    """

    id: str
    group: str
    experiments: tuple[Path, ...] = ()
    markers: tuple[Path, ...] = ()
    forces: tuple[Path, ...] = ()
    start: Path | None = None
    rules: str | None = None
    tissue: str | None = None
    options: dict = field(default_factory=dict)
    source: str = "<manifest>"
    line: int | None = None

    @property
    def inputs(self) -> list[Path]:
        """Every input file of the fit (rule files included, with the files they extend)."""
        files = [*self.experiments, *self.markers, *self.forces]
        if self.start is not None:
            files.append(self.start)
        if self.rules is not None:
            files += _rule_files(_rule_path(self.rules))
        return files

    def fingerprint(self) -> str:
        """SHA-256 of what the fit depends on: the contents of every input file, the start,
        rules, tissue and options (not the group, nor where the files are)."""
        base = Path(self.source).parent
        rules = self.rules
        if rules is not None and Path(rules).is_absolute():
            rules = relative_path(Path(rules), base)
        given = [*self.experiments, *self.markers, *self.forces, *filter(None, [self.start])]
        described = {"rules": rules, "tissue": self.tissue, "options": self.options,
                     "files": [relative_path(path, base) for path in given]}
        digest = hashlib.sha256(_TASK_VERSION.encode())
        digest.update(json.dumps(described, sort_keys=True, default=str).encode())
        for path in self.inputs:
            with open(path, "rb") as handle:
                digest.update(hashlib.file_digest(handle, "sha256").digest())
        return digest.hexdigest()

    def error(self, message: str, key: str | None = None) -> InputError:
        """An :class:`InputError` naming the manifest, the row's line and ``key``."""
        return InputError(message, source=self.source, key=key, line=self.line)


def read_manifest(path: str | os.PathLike) -> list[Specimen]:
    """Read and check a manifest (CSV or YAML; see the module docstring).

    Parameters
    ----------
    path : path
        The manifest; relative paths in it are relative to its folder.

    Returns
    -------
    list of Specimen
        In the manifest's order, every file checked to exist, every option checked, every
        rule base's tissue checked to exist.

    Raises
    ------
    InputError
        Naming the manifest and the line: a missing or empty file, an unknown column (with
        the closest known one), a duplicate or unsafe id, a missing file, a bad option.
        Several problems are reported together, the first in full.
    """
    path = Path(path)
    source = str(path)
    suffix = path.suffix.lower()
    if suffix not in MANIFEST_SUFFIXES:
        raise InputError(f"a manifest is a CSV or YAML file; got {suffix or 'no extension'!r}",
                         source=source)
    if not path.is_file():
        raise InputError("no such file", source=source)
    rows = csv_rows(path) if suffix == ".csv" else yaml_rows(path)
    if not rows:
        raise InputError("lists no specimens", source=source)
    specimens, problems, seen, folded = [], [], {}, {}
    for line, row in rows:
        try:
            specimen = _specimen(row, path, line)
            if specimen.id in seen:
                raise specimen.error(f"{specimen.id!r} is also the id of line {seen[specimen.id]}"
                                     "; ids name the result folders and must be unique", "id")
            if specimen.id.lower() in folded:
                other, at = folded[specimen.id.lower()]
                raise specimen.error(f"{specimen.id!r} and {other!r} (line {at}) differ only in "
                                     "letter case: on macOS and Windows they name one folder; "
                                     "make the ids differ", "id")
            if specimen.id.lower() in FOLDER_FILES:
                raise specimen.error(f"{specimen.id!r} is the name of a file fit-many keeps in "
                                     f"the results folder ({', '.join(FOLDER_FILES)}); choose "
                                     "another id", "id")
            seen[specimen.id] = line
            folded[specimen.id.lower()] = (specimen.id, line)
            specimens.append(specimen)
        except InputError as problem:
            problems.append(problem)
    problems += _check_tissues(specimens)
    problems += _check_marker_units(specimens)
    if problems:
        more = "" if len(problems) == 1 else (
            f" (and {len(problems) - 1} more: " + "; ".join(
                f"line {p.line}: {p.detail}" if p.line else p.detail for p in problems[1:4])
            + ("; …" if len(problems) > 4 else "") + ")")
        first = problems[0]
        raise InputError(first.detail + more, source=first.source, key=first.key,
                         line=first.line)
    return specimens


# -- one specimen -----------------------------------------------------------------------------
def _specimen(row: dict, manifest: Path, line: int) -> Specimen:
    source = str(manifest)

    def problem(message, key=None):
        return InputError(message, source=source, key=key, line=line)

    text = {key: _text(value) for key, value in row.items()}
    identifier = text.get("id") or ""
    if not _ID.match(identifier):
        raise problem(f"got {identifier!r}; an id starts with a letter or digit and has only "
                      "letters, digits, '.', '_' and '-' (it names the specimen's folder)", "id")
    group = text.get("group") or ""
    if not group:
        raise problem("every specimen needs a group label (e.g. healthy, fibrotic)", "group")
    files = {key: tuple(_file(item, manifest.parent, problem, key)
                        for item in _items(row.get(key))) for key in _FILE_LISTS}
    start = _file(text["start"], manifest.parent, problem, "start") if text.get("start") else None
    if bool(files["experiments"]) == bool(files["markers"]):
        raise problem("give either experiment files or marker recordings (with a start model)",
                      "experiments")
    if files["markers"] and start is None:
        raise problem("marker recordings need a start model (its mesh is their topology)",
                      "start")
    if files["forces"] and len(files["forces"]) != len(files["markers"]):
        raise problem(f"{len(files['forces'])} force files for {len(files['markers'])} marker "
                      "recordings; give one per recording", "forces")
    rules = _rules(text.get("rules"), manifest.parent, problem)
    tissue = text.get("tissue") or None
    if rules is not None and tissue is None and start is None:
        raise problem("a rule base needs a tissue (or a start model whose regions name "
                      "theirs)", "tissue")
    if tissue is not None and rules is None:
        raise problem("a tissue needs a rule base (rules: liver, or a file)", "rules")
    options = fit_options(text, problem)
    if options.get("prior", "off") != "off":
        if rules is None:
            raise problem("a prior needs a rule base (rules: liver, or a file)", "prior")
        if options.get("method") == "paper":
            raise problem("the paper's learner has no prior; use method: gradient", "prior")
    return Specimen(id=identifier, group=group, start=start, rules=rules, tissue=tissue,
                    options=options, source=source, line=line, **files)


def _text(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value).strip()


def _items(value) -> list[str]:
    """A file list: a YAML list, or one string with ``;`` between files."""
    if value is None:
        return []
    if isinstance(value, list):
        return [_text(item) for item in value if _text(item)]
    return [item.strip() for item in _text(value).split(";") if item.strip()]


def _file(text: str, base: Path, problem, key: str) -> Path:
    path = (base / text).resolve()
    if not path.is_file():
        raise problem(f"no such file {text}" + (f" ({path})" if not Path(text).is_absolute()
                                                 else ""), key)
    return path


def _rules(text: str | None, base: Path, problem) -> str | None:
    """A rule file (absolute path); a bare name is the manifest folder's ``rules/NAME.yaml``,
    then ``NAME.yaml``, then the shipped rule base (:func:`neurofuzzy.rules.locate`)."""
    if not text:
        return None
    if Path(text).suffix.lower() in (".yaml", ".yml") or "/" in text or (base / text).exists():
        return str(_file(text, base, problem, "rules"))
    from ..rules import locate

    try:
        return str(locate(text, folder=base).resolve())
    except InputError:
        raise problem(f"no rule file {text!r} beside the manifest and no shipped rule base of "
                      "that name (liver, brain, kidney, muscle, fat, soft_tissue)",
                      "rules") from None


def _check_tissues(specimens: list[Specimen]) -> list[InputError]:
    """Every named tissue exists in its rule base (each rule base loaded once)."""
    from ..rules import resolve

    loaded, problems = {}, []
    for specimen in specimens:
        if specimen.rules is None or specimen.tissue is None:
            continue
        if specimen.rules not in loaded:
            try:
                loaded[specimen.rules] = resolve(specimen.rules)
            except InputError as error:
                problems.append(specimen.error(
                    f"rule base {specimen.rules}: {str(error).splitlines()[0]}", "rules"))
                loaded[specimen.rules] = None
        rules = loaded[specimen.rules]
        if rules is not None and specimen.tissue not in rules.tissues:
            hint = closest_name(specimen.tissue, rules.tissues)
            problems.append(specimen.error(
                f"{specimen.tissue!r} is not a tissue of {rules.name}"
                + (f"; did you mean {hint!r}?" if hint else
                   f"; it has {', '.join(rules.tissues)}"), "tissue"))
    return problems


def _check_marker_units(specimens: list[Specimen]) -> list[InputError]:
    """A row's ``units`` must agree with the unit its marker CSVs state (a unit given twice,
    differently, is refused here, not half-way through the batch)."""
    from ..markers.units import LENGTH_UNITS, header_statements, unit_factor

    problems = []
    for specimen in specimens:
        units = specimen.options.get("units")
        for path in specimen.markers if units else ():
            if path.suffix.lower() != ".csv":
                continue
            try:
                unit_factor(LENGTH_UNITS, what="length", stated=header_statements(path),
                            keys=("units", "length units"), source=str(path), given=units,
                            given_as="the manifest's units")
            except InputError as error:
                problems.append(specimen.error(f"markers {path.name}: {error}", "units"))
    return problems


def _rule_path(rules: str) -> Path:
    from ..rules import shipped

    return Path(rules) if Path(rules).is_absolute() else shipped(rules)


def _rule_files(path: Path) -> list[Path]:
    """A rule file and the files it extends (for fingerprints)."""
    from ..rules.files import load

    files = []
    while path not in files and path.is_file():
        files.append(path)
        try:
            data = load(path)
        except InputError:
            break              # the rule parser reports it; the bytes are fingerprinted
        parent = data.get("extends") if isinstance(data, dict) else None
        if not parent:
            break
        path = (path.parent / str(parent)).resolve()
    return files


def relative_path(path: Path, base: Path) -> str:
    """``path`` relative to the folder ``base`` (POSIX form), for records and links."""
    try:
        return Path(os.path.relpath(path, base)).as_posix()
    except ValueError:             # another drive (Windows)
        return path.as_posix()
