"""The opened rule file: its text as edited, the check of that text, undo and redo, saving.

The text is checked by :func:`neurofuzzy.rules.load_rules` exactly as it would be written to
the opened file, so every problem carries the line it will have there, and the same message
``neurofuzzy rules check`` prints. Saving refuses a text with problems, writes atomically,
and only to the opened file or a new file named inside the opened file's folder.
"""

from __future__ import annotations

import hashlib
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError, RuleFileDeprecationWarning
from ..rules import RuleBase, RuleBaseError, load_rules
from .edits import NAME, EditError, apply_edit
from .yamltext import YamlText

__all__ = ["RuleDocument", "Check", "MAX_UNDO", "inside"]

#: undo steps kept
MAX_UNDO = 200
#: edits of the same thing within this many seconds are one undo step (typing, dragging)
MERGE_SECONDS = 1.5
_MAX_BYTES = 2**20


@dataclass
class Check:
    """The rule base of a text, or its problems.

    Attributes
    ----------
    rules : RuleBase or None
        None when there are problems.
    problems : list of dict
        ``{"file", "line", "message", "text"}``: ``text`` is ``FILE:LINE: message`` as
        ``neurofuzzy rules check`` prints it.
    notes : list of str
        Deprecation notes (the file still loads).
    """

    rules: RuleBase | None
    problems: list = field(default_factory=list)
    notes: list = field(default_factory=list)


def inside(folder: Path, name: str | Path) -> Path:
    """``folder / name`` resolved, refused (:class:`InputError`) unless it lies inside
    ``folder`` (no ``..``, no absolute path elsewhere, no symbolic link out)."""
    folder = folder.resolve()
    target = (folder / name).resolve()
    if target != folder and folder not in target.parents:
        raise InputError(f"{name}: refused, the studio only reads and writes inside the "
                         f"opened file's folder {folder}")
    return target


def _read(path: Path) -> str:
    try:
        size = path.stat().st_size
    except OSError as error:
        raise InputError(f"cannot read the file ({error.strerror or error})",
                         source=str(path)) from None
    if path.is_dir():
        raise InputError("is a folder; give a rule file (YAML)", source=str(path))
    if size > _MAX_BYTES:
        raise InputError(f"is {size / 2**20:.1f} MB; a rule file is a few kB",
                         source=str(path))
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError("is not UTF-8 text; save it as UTF-8", source=str(path)) from None


def _located(path: Path, text: str) -> YamlText:
    try:
        return YamlText(text)
    except InputError as error:
        raise InputError(error.detail, source=str(path), line=error.line) from None


class RuleDocument:
    """An opened rule file being edited.

    Parameters
    ----------
    path : path
        The rule file (it must exist and be YAML; it may have problems as a rule base).
    """

    def __init__(self, path):
        self.path = Path(path).resolve()
        self.folder = self.path.parent
        text = _read(self.path)
        self.doc = _located(self.path, text)
        self.saved_text = text
        self._disk = self._signature()
        self.undo_stack: list[str] = []
        self.redo_stack: list[str] = []
        self._merge: tuple | None = None
        self._check: tuple[str, Check] | None = None

    # -- the files it extends ----------------------------------------------------------------
    def parents(self) -> list[tuple[Path, YamlText]]:
        """The chain of files this one extends, nearest first (as far as they read)."""
        chain, doc, path, seen = [], self.doc, self.path, {self.path}
        while True:
            found = doc.find(["extends"])
            if found is None or found[1].kind != "scalar" or not found[1].value:
                return chain
            path = (path.parent / found[1].value).resolve()
            if path in seen or not path.is_file():
                return chain
            seen.add(path)
            try:
                doc = YamlText(_read(path))
            except InputError:
                return chain
            chain.append((path, doc))

    # -- editing -----------------------------------------------------------------------------
    @property
    def text(self) -> str:
        return self.doc.text

    @property
    def dirty(self) -> bool:
        return self.text != self.saved_text

    def apply(self, edit: dict) -> None:
        """Apply one edit (:mod:`.edits`); edits of the same target in a row within
        :data:`MERGE_SECONDS` are one undo step."""
        parents = [doc for _, doc in self.parents()]
        try:
            new = apply_edit(self.doc, parents, edit)
        except EditError:
            raise
        except InputError as error:
            raise EditError(error.detail, line=error.line) from None
        if new.text == self.text:
            return
        target = _target(edit)
        now = time.monotonic()
        if not (self._merge and self._merge[0] == target and now - self._merge[1]
                < MERGE_SECONDS and target is not None):
            self.undo_stack.append(self.text)
            del self.undo_stack[:-MAX_UNDO]
        self._merge = (target, now)
        self.redo_stack.clear()
        self.doc = new

    def undo(self) -> bool:
        if not self.undo_stack:
            return False
        self.redo_stack.append(self.text)
        self.doc = YamlText(self.undo_stack.pop())
        self._merge = None
        return True

    def redo(self) -> bool:
        if not self.redo_stack:
            return False
        self.undo_stack.append(self.text)
        self.doc = YamlText(self.redo_stack.pop())
        self._merge = None
        return True

    # -- checking ----------------------------------------------------------------------------
    def check(self, path: Path | None = None) -> Check:
        """The rule base of the current text as if written to ``path`` (default the opened
        file), or its problems."""
        path = path or self.path
        key = (str(path), self.text)
        if self._check and self._check[0] == key:
            return self._check[1]
        notes = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuleFileDeprecationWarning)
            try:
                result = Check(load_rules(path, text=self.text))
            except RuleBaseError as error:
                result = Check(None, [_problem(p) for p in error.problems])
            except InputError as error:
                result = Check(None, [_problem(error)])
        notes = [str(w.message) for w in caught
                 if issubclass(w.category, RuleFileDeprecationWarning)]
        result.notes = notes
        self._check = (key, result)
        return result

    # -- saving ------------------------------------------------------------------------------
    def _signature(self):
        try:
            data = self.path.read_bytes()
        except OSError:
            return None
        return hashlib.sha256(data).hexdigest()

    def save(self, name: str | None = None) -> Path:
        """Write the text to the opened file, or to a new file ``name`` in its folder (which
        then becomes the opened file). Refused while the text has problems, when the opened
        file changed on disk since it was read, or when ``name`` exists or lies elsewhere."""
        from ..io.writing import atomic_write

        target = self.path
        if name is not None:
            name = str(name).strip()
            if not name.endswith((".yaml", ".yml")):
                name += ".yaml"
            stem = Path(name).name.rsplit(".", 1)[0]
            if not NAME.match(stem.replace("-", "_")):
                raise EditError(f"{name!r}: name the new file with letters, digits, - and _")
            target = inside(self.folder, name)
            if target.exists():
                raise EditError(f"{target.name} exists already; the studio writes a new file "
                                "or the opened one, never another")
        check = self.check(target)
        if check.problems:
            raise EditError(f"not saved: the rule base has {len(check.problems)} problem(s); "
                            f"the first: {check.problems[0]['text']}")
        if name is None and self._signature() != self._disk:
            raise EditError(f"not saved: {self.path.name} changed on disk since the studio "
                            "read it; save under a new name, or reopen it")
        with atomic_write(target, "w") as handle:
            handle.write(self.text)
        if name is not None:
            self.path = target
        self.saved_text = self.text
        self._disk = self._signature()
        return target


def _problem(error: InputError) -> dict:
    return {"file": Path(error.source).name if error.source else None,
            "path": error.source, "line": error.line, "message": error.detail,
            "text": str(error)}


def _target(edit: dict):
    """What an edit changes, for merging consecutive edits into one undo step."""
    if not isinstance(edit, dict) or edit.get("op") not in ("set_term", "set_rule",
                                                            "set_tissue", "set_universe"):
        return None
    return tuple(str(edit.get(k)) for k in ("op", "role", "variable", "term", "index",
                                            "tissue"))
