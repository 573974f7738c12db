"""What every command shares: JSON output, checked options, refusing to write over inputs,
outputs staged and published together, "wrote" lines."""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import secrets
import shutil
import sys
from pathlib import Path

from ..formatting import json_safe
from ..errors import InputError, UnstableTimeStepError

__all__ = ["EXIT_BAD_INPUT", "print_json", "refuse_overwrite", "written", "usage", "Outputs",
           "positive", "at_least", "vtu_series", "naming", "rule_base_for",
           "load_rule_base", "rule_file", "require_tissue"]

EXIT_BAD_INPUT = 2


def print_json(value) -> None:
    """One JSON object on stdout (non-finite numbers as null)."""
    print(json.dumps(json_safe(value)))


def refuse_overwrite(out, inputs, option: str = "--out") -> None:
    """Refuse an output path that names one of the ``inputs`` (never write over input)."""
    if out is None:
        return
    target = Path(out).resolve()
    for path in inputs:
        if path is not None and Path(path).exists() and Path(path).resolve() == target:
            raise InputError(f"{option} names an input file; neurofuzzy never writes over its "
                             "input", source=str(out))


def positive(value, option: str, *, integer: bool = False):
    """``value`` if it is a finite number > 0, else an :class:`InputError` naming ``option``
    (never replaced by a default)."""
    if value is None:
        return None
    if not (math.isfinite(value) and value > 0):
        kind = "a positive integer" if integer else "a positive number"
        raise InputError(f"got {value}; expected {kind}", key=option)
    return value


def at_least(value, minimum, option: str):
    """``value`` if it is a finite number >= ``minimum``, else an :class:`InputError`."""
    if value is None:
        return None
    if not (math.isfinite(value) and value >= minimum):
        raise InputError(f"got {value}; expected {minimum} or more", key=option)
    return value


def load_rule_base(value, *, quiet: bool = False):
    """The rule base ``value`` names (:func:`neurofuzzy.rules.resolve`: a file, or a bare
    name as ``./rules/NAME.yaml``, ``./NAME.yaml``, else the shipped copy), said in one line
    on stderr (``rules: rules/liver.yaml (sha256 1a2b3c4d…)``) unless ``quiet``."""
    from ..rules import resolve

    rule_base = resolve(value)
    if not quiet:
        print(f"rules: {rule_base.origin}", file=sys.stderr)
    return rule_base


def rule_file(value) -> Path | None:
    """The file ``--rules VALUE`` reads (for the outputs that must not write over it)."""
    from ..rules import locate

    if value is None:
        return None
    try:
        return locate(value)
    except InputError:
        return Path(value)          # refused when it is read, with the reason


def rule_base_for(rules, tissue: str | None, option: str = "--tissue", *,
                  quiet: bool = False):
    """The rule base of ``--rules`` (None without one; :func:`load_rule_base`), with
    ``--tissue`` checked to be one of its tissues ("did you mean"); a tissue without a rule
    base is refused."""
    if rules is None:
        if tissue is not None:
            raise InputError(f"names tissue {tissue!r} of a rule base; give the rule base too "
                             "(--rules R)", key=option)
        return None
    rule_base = load_rule_base(rules, quiet=quiet)
    if tissue is not None:
        require_tissue(rule_base, tissue, option)
    return rule_base


def require_tissue(rule_base, tissue: str, option: str) -> None:
    """Refuse a tissue the rule base lacks, naming the rule file and the option."""
    from ..errors import closest_name

    if tissue not in rule_base.tissues:
        hint = closest_name(tissue, rule_base.tissues)
        raise InputError(f"no tissue {tissue!r} ({option})" + (
            f"; did you mean {hint!r}?" if hint else f"; tissues: {sorted(rule_base.tissues)}"),
            source=rule_base.source, key="tissue")


def mesh_check_option(args) -> bool | str:
    """A fit's ``mesh_check``: ``"auto"`` unless ``--mesh-check`` (one step, any element
    model, any size), ``--mesh-check-refit`` or ``--no-mesh-check``."""
    if args.no_mesh_check:
        return False
    return "refit" if args.mesh_check_refit else "step" if args.mesh_check else "auto"


def only_time_series_diagnosis(args, what: str) -> None:
    """Refuse the options of the time series' diagnosis (``--localise``, ``--max-time``,
    ``--window``) for a diagnosis of ``what`` that has no use for them."""
    for option, given in (("--localise", args.localise), ("--max-time", args.max_time),
                          ("--window", args.window not in (None, "auto"))):
        if given:
            raise InputError(f"is for the diagnosis of time series under loads; {what} is "
                             "diagnosed without it", key=option)


@contextlib.contextmanager
def naming(source):
    """Errors raised inside that name no file (an unstable time step of a model, a value
    the model's file holds) are re-raised naming ``source``."""
    try:
        yield
    except InputError as error:
        if error.source is not None:
            raise
        raise InputError(error.detail, source=str(source), key=error.key,
                         line=error.line) from None
    except UnstableTimeStepError as error:
        raise UnstableTimeStepError(f"{source}: {error}") from None


def vtu_series(stem: str) -> str:
    """The names of a ParaView frame series of ``stem`` (``stem_0000.vtu`` …), as a regular
    expression for :meth:`Outputs.folder`."""
    return re.escape(stem) + r"_\d{4,}\.vtu"


def written(*paths) -> None:
    for path in paths:
        if path:
            print(f"wrote {path}")


def usage(parser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_BAD_INPUT


class Outputs:
    """Every file and folder a command writes, staged beside its target and published together.

    ``outputs.file(args.out, "--out")`` returns the path to write to instead (a hidden name
    in the target's folder, so relative links between outputs hold; nothing is made yet).
    Write inside ``with outputs:``: when the block ends without an exception every staged
    output is renamed onto its target; on any exception (bad input found late, a failed fit,
    Ctrl-C) every staged file and every folder made for them is removed: nothing is left
    behind.

    Before anything runs it refuses, naming the path, an output that is an input, two outputs
    on one path, the file stdout is redirected to, and a derived file (a report's JSON twin)
    that would replace an existing file the user did not name.
    """

    def __init__(self, inputs=()):
        self.inputs = [Path(p) for p in inputs if p is not None]
        self.staged: list[tuple[Path, Path]] = []       # (staged, target)
        self.existed: dict[Path, Path] = {}             # output folder → its nearest
        #                                                 ancestor that existed before
        self.targets: dict[Path, str] = {}              # resolved target → option
        self.owns: dict[Path, str | None] = {}          # folder → names it replaces

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, kind, error, traceback) -> None:
        if kind is None:
            self.publish()
        else:
            self.discard()

    # -- registration ---------------------------------------------------------------------
    def file(self, target, option: str, *, twins: tuple[str, ...] = ()) -> Path | None:
        """Where to write the file ``target`` (None when the option was not given): a hidden
        name beside it, made only when written to.

        ``twins`` are the suffixes of files derived from it (``".json"``: the report's twin,
        written by the same call beside the staged path).
        """
        if target is None:
            return None
        target = Path(target)
        if target.is_dir():
            raise InputError(f"{option} names a folder; expected a file name",
                             source=str(target))
        self._claim(target, option)
        for suffix in twins:
            twin = target.with_suffix(suffix)
            self._claim(twin, f"{option}'s {suffix} twin")
            _refuse_foreign(twin, option)
        staged = self._stage(target, target.stem, target.suffix)
        for suffix in twins:
            self.staged.append((staged.with_suffix(suffix), target.with_suffix(suffix)))
        return staged

    def folder(self, target, option: str, *, owns: str | None = None) -> Path | None:
        """Where to write the folder ``target`` (None when the option was not given); its files
        join (and replace same-named files in) ``target`` when published, and files of
        ``target`` whose names match the regular expression ``owns`` (an earlier series of
        the same kind) that the new output lacks are removed then."""
        if target is None:
            return None
        target = Path(target)
        if target.exists() and not target.is_dir():
            raise InputError(f"{option} names a file; expected a folder", source=str(target))
        self._claim(target, option)
        self.owns[target] = owns
        return self._stage(target, target.name, "")

    def _stage(self, target: Path, stem: str, suffix: str) -> Path:
        folder = target.parent
        existing = folder
        while not existing.exists():
            existing = existing.parent
        self.existed[folder] = existing
        staged = folder / f".{stem}.nf-{secrets.token_hex(4)}{suffix}"
        self.staged.append((staged, target))
        return staged

    def target_of(self, path) -> Path:
        """The published path of a path under a staged file or folder."""
        path = Path(path)
        for staged, target in self.staged:
            if path == staged or staged in path.parents:
                return target / path.relative_to(staged)
        return path

    def _claim(self, target: Path, option: str) -> None:
        refuse_overwrite(target, self.inputs, option)
        key = target.resolve()
        if key in self.targets:
            raise InputError(f"{option} and {self.targets[key]} name the same path",
                             source=str(target))
        self.targets[key] = option
        if _is_stdout(target):
            raise InputError(f"{option} names the file stdout is redirected to; choose "
                             "another name", source=str(target))

    # -- the end ---------------------------------------------------------------------------
    def publish(self) -> None:
        """Move every staged output onto its target."""
        for staged, target in self.staged:
            if not staged.exists():
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            if staged.is_dir() and target.is_dir():
                owns = self.owns.get(target)
                if owns is not None:
                    new = {item.name for item in staged.iterdir()}
                    for old in target.iterdir():
                        if re.fullmatch(owns, old.name) and old.name not in new \
                                and old.is_file():
                            old.unlink()
                for item in sorted(staged.rglob("*")):
                    destination = target / item.relative_to(staged)
                    if item.is_dir():
                        destination.mkdir(exist_ok=True)
                    else:
                        os.replace(item, destination)
                shutil.rmtree(staged)
            else:
                os.replace(staged, target)
        self.staged.clear()
        self.existed.clear()

    def discard(self) -> None:
        """Remove every staged output and every folder made for them."""
        for staged, _ in self.staged:
            if staged.is_dir():
                shutil.rmtree(staged, ignore_errors=True)
            else:
                with contextlib.suppress(FileNotFoundError):
                    staged.unlink()
        for folder, existed in self.existed.items():     # folders made for the outputs
            while folder != existed and folder.is_dir():
                try:
                    folder.rmdir()
                except OSError:                        # not empty: someone else wrote there
                    break
                folder = folder.parent
        self.staged.clear()
        self.existed.clear()


def _refuse_foreign(derived: Path, option: str) -> None:
    """Refuse to replace an existing ``derived`` file unless an earlier report wrote it."""
    from ..report import REPORT_MARKER

    if not derived.exists():
        return
    ours = False
    if derived.is_file():
        try:
            with open(derived, encoding="utf-8") as handle:
                content = json.load(handle)
            ours = isinstance(content, dict) and REPORT_MARKER in content
        except (OSError, ValueError):
            ours = False
    if not ours:
        raise InputError(f"exists and is not a report's JSON twin; {option} would replace it "
                         "with the report's JSON. Move it, or name the report differently",
                         source=str(derived))


def _is_stdout(target: Path) -> bool:
    """Is ``target`` the regular file standard output is redirected to?"""
    try:
        out = os.fstat(sys.stdout.fileno())
        there = os.stat(target)
    except (AttributeError, ValueError, OSError):      # no real stdout (tests), no file
        return False
    return out.st_ino == there.st_ino and out.st_dev == there.st_dev
