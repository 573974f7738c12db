"""YAML files read defensively, with line numbers: rule bases, model files, manifests.

:func:`load` returns plain ``dict``/``list`` subclasses (:class:`Mapping`, :class:`Sequence`)
that remember the 1-based line of every item (``line``, ``line_of(key_or_index)``), so every
message about a file can say ``FILE:LINE``. It builds them from the parser's event stream
(no recursion, so no ``RecursionError`` whatever the nesting) and refuses, as an
:class:`~neurofuzzy.errors.InputError` naming the file and line:

- a file larger than ``max_bytes`` (checked before reading it);
- bytes that are not UTF-8, and characters YAML does not allow (NUL and other controls);
- nesting deeper than :data:`MAX_DEPTH`;
- aliases that expand the document beyond :data:`MAX_VALUES` values ("billion laughs": the
  expanded size is counted, never built) and an alias inside the node it names (a cycle);
- a key given twice in one mapping (both lines named), merge keys (``<<``), keys that are
  not plain values;
- tags other than the plain ones (``!!str``, ``!!int``, ``!!float``, ``!!bool``, ``!!null``,
  ``!!map``, ``!!seq``), e.g. ``!foo`` or ``!!python/…``, and a value its tag cannot read
  (``!!int abc``);
- more than one document.

Values are those of ``yaml.safe_load`` (YAML 1.1 scalars), except that a date stays the text
it is written as. libyaml's parser is used when PyYAML has it (much faster on model files).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import yaml

from ..errors import InputError

__all__ = ["Mapping", "Sequence", "load", "loads", "kind_of", "MAX_DEPTH", "MAX_VALUES"]

#: deepest nesting of mappings and sequences a file may have
MAX_DEPTH = 64
#: most values (scalars, mappings, sequences) a document may expand to through its aliases
MAX_VALUES = 20_000_000
#: default size limit of a file (bytes)
MAX_BYTES = 256 * 2**20

_TAG = "tag:yaml.org,2002:"
_SCALAR_TAGS = {_TAG + name for name in ("str", "int", "float", "bool", "null")}
_CONTAINER_TAGS = {"mapping": _TAG + "map", "sequence": _TAG + "seq"}
#: characters YAML 1.1 does not allow in a stream (C0 controls but tab/LF/CR, DEL, C1 but NEL,
#: surrogates, U+FFFE/U+FFFF)
_NOT_ALLOWED = re.compile("[^\x09\x0A\x0D\x20-\x7E\x85\xA0-\uD7FF\uE000-\uFFFD"
                          "\U00010000-\U0010FFFF]")
#: plain scalars that YAML 1.1 reads as the same int or float as Python does
_PLAIN_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)\Z")
_PLAIN_FLOAT = re.compile(r"[-+]?[0-9]+\.[0-9]*(?:[eE][-+][0-9]+)?\Z")
_Parser = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class Mapping(dict):
    """A YAML mapping; ``line`` is where it starts, ``line_of(key)`` where a key is."""

    line: int = 0

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.lines: dict = {}

    def line_of(self, key) -> int:
        return self.lines.get(key, self.line)


class Sequence(list):
    """A YAML sequence; ``line`` is where it starts, ``line_of(index)`` where an item is."""

    line: int = 0

    def __init__(self, *args):
        super().__init__(*args)
        self.lines: list = []

    def line_of(self, index) -> int:
        return self.lines[index] if 0 <= index < len(self.lines) else self.line


def kind_of(value) -> str:
    """What a YAML value is, in words, for messages ("a list", "a number", …)."""
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if value is None:
        return "nothing (null)"
    return f"the text {str(value)[:40]!r}"


def load(path: str | os.PathLike, *, max_bytes: int = MAX_BYTES,
         kind: str = "YAML file") -> object:
    """Read and parse a YAML file defensively (see the module docstring).

    Parameters
    ----------
    path : str or path
    max_bytes : int
        Largest file accepted; a larger one is refused before it is read.
    kind : str
        What the file is, for messages ("rule file", "model file").

    Raises
    ------
    InputError
        Naming the file and, where there is one, the line.
    """
    source = str(path)
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise InputError("no such file", source=source) from None
    except OSError as error:
        raise InputError(f"cannot read the file ({error.strerror or error})",
                         source=source) from None
    if path.is_dir():
        raise InputError(f"is a directory, not a {kind}", source=source)
    if size > max_bytes:
        raise InputError(f"is {size / 2**20:.1f} MB; a {kind} is at most "
                         f"{max_bytes / 2**20:.0f} MB, so this is not one (or it is broken)",
                         source=source)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise InputError(f"cannot read the file ({error.strerror or error})",
                         source=source) from None
    return loads(raw, source)


def loads(raw: bytes | str, source: str = "<yaml>") -> object:
    """Parse YAML text (bytes are decoded as UTF-8); see :func:`load`."""
    if isinstance(raw, bytes):
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as error:
            line = raw.count(b"\n", 0, error.start) + 1
            column = error.start - raw.rfind(b"\n", 0, error.start)
            raise InputError(f"not UTF-8 text (byte 0x{raw[error.start]:02x} at column "
                             f"{column}: "
                             f"{error.reason}); save the file as UTF-8", source=source,
                             line=line) from None
    else:
        text = raw
    bad = _NOT_ALLOWED.search(text)
    if bad is not None:
        line = text.count("\n", 0, bad.start()) + 1
        raise InputError(f"character U+{ord(bad.group()):04X} is not allowed in YAML (a binary "
                         "file, or a control character pasted in); remove it", source=source,
                         line=line)
    if not text.strip():
        raise InputError("the file is empty", source=source, line=1)
    try:
        return _Builder(source).build(yaml.parse(text, Loader=_Parser))
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        problem = error.problem or error.context or "cannot parse"
        if "nesting depth" in problem:              # libyaml's own limit (PyYAML >= 6.0.3)
            problem = f"nested more than {MAX_DEPTH} levels deep; neurofuzzy files are flat"
        raise InputError(f"malformed YAML: {problem}", source=source,
                         line=mark.line + 1 if mark else None) from None
    except yaml.YAMLError as error:
        raise InputError(f"malformed YAML: {str(error).splitlines()[0]}",
                         source=source) from None


class _Open:
    """A mapping or sequence being built."""

    __slots__ = ("value", "anchor", "key", "key_line", "size")

    def __init__(self, value, anchor):
        self.value, self.anchor = value, anchor
        self.key = self.key_line = None
        self.size = 1


class _Builder:
    def __init__(self, source: str):
        self.source = source
        self.anchors: dict[str, tuple[object, int]] = {}
        self.total = 0
        self.resolver = yaml.resolver.Resolver()
        self.constructor = yaml.constructor.SafeConstructor()

    def fail(self, message: str, event) -> None:
        raise InputError(message, source=self.source, line=event.start_mark.line + 1)

    def build(self, events):
        stack: list[_Open] = []
        root, documents = None, 0
        for event in events:
            if isinstance(event, yaml.ScalarEvent):
                value = self.scalar(event)
                if not stack:
                    root = "<<" if value is _MERGE else value
                self.add(stack, value, 1, event, event.anchor)
            elif isinstance(event, yaml.AliasEvent):
                if event.anchor not in self.anchors:
                    self.fail(f"the alias *{event.anchor} is used inside the node it names (a "
                              "cycle); write the value out", event)
                value, size = self.anchors[event.anchor]
                self.add(stack, value, size, event, None)
            elif isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                kind = "mapping" if isinstance(event, yaml.MappingStartEvent) else "sequence"
                if event.tag not in (None, "!", _CONTAINER_TAGS[kind]):
                    self.fail(_unknown_tag(event.tag), event)
                if stack and isinstance(stack[-1].value, Mapping) and stack[-1].key is None:
                    self.fail("a mapping key must be a plain value, not a "
                              f"{kind}", event)
                if len(stack) >= MAX_DEPTH:
                    self.fail(f"nested more than {MAX_DEPTH} levels deep; neurofuzzy files "
                              "are flat", event)
                value = Mapping() if kind == "mapping" else Sequence()
                value.line = event.start_mark.line + 1
                stack.append(_Open(value, event.anchor))
                self.count(1, event)
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                done = stack.pop()
                if done.anchor is not None:
                    self.anchors[done.anchor] = (done.value, done.size)
                if stack:
                    self.attach(stack[-1], done.value, done.size, event)
                else:
                    root = done.value
            elif isinstance(event, yaml.DocumentStartEvent):
                documents += 1
                if documents > 1:
                    self.fail("holds more than one YAML document ('---'); keep one", event)
        return root

    def add(self, stack, value, size, event, anchor):
        """A finished scalar or alias: the root, or an item of the innermost open node."""
        self.count(size, event)
        if anchor is not None:
            self.anchors[anchor] = (value, size)
        if stack:
            self.attach(stack[-1], value, size, event)

    def attach(self, parent: _Open, value, size, event):
        parent.size += size
        # a finished mapping or sequence is attached at its end event: use where it started
        line = value.line if isinstance(value, (Mapping, Sequence)) else event.start_mark.line + 1
        if isinstance(parent.value, Sequence):
            parent.value.append("<<" if value is _MERGE else value)
            parent.value.lines.append(line)
            return
        if parent.key is None:                            # a key
            if isinstance(value, (dict, list)):
                self.fail("a mapping key must be a plain value", event)
            if value is _MERGE:
                self.fail("merge keys ('<<') are not supported; write the keys out", event)
            if value in parent.value:
                self.fail(f"duplicate key {value!r} (first at line "
                          f"{parent.value.lines[value]}); keep one", event)
            parent.key, parent.key_line = value, line
            return
        parent.value[parent.key] = "<<" if value is _MERGE else value
        parent.value.lines[parent.key] = parent.key_line
        parent.key = None

    def count(self, size: int, event) -> None:
        self.total += size
        if self.total > MAX_VALUES:
            self.fail(f"expands to more than {MAX_VALUES:,} values (through aliases, or sheer "
                      "size); this is not a neurofuzzy file", event)

    def scalar(self, event):
        tag = event.tag
        if tag is None and event.implicit[0]:             # fast path: plain decimal numbers
            value = event.value
            if _PLAIN_INT.match(value):
                return int(value)
            if _PLAIN_FLOAT.match(value):
                return float(value)
        if tag in (None, "!"):
            if not event.implicit[0]:                     # quoted: a string
                return event.value
            tag = self.resolver.resolve(yaml.ScalarNode, event.value, event.implicit)
            if tag == _TAG + "merge":
                return _MERGE
            if tag not in _SCALAR_TAGS:                   # dates, '=': keep the text
                return event.value
        elif tag not in _SCALAR_TAGS:
            self.fail(_unknown_tag(tag), event)
        node = yaml.ScalarNode(tag, event.value, event.start_mark, event.end_mark, event.style)
        try:
            return self.constructor.yaml_constructors[tag](self.constructor, node)
        except (ValueError, TypeError, OverflowError, IndexError, KeyError, AttributeError,
                yaml.constructor.ConstructorError):     # e.g. !!int with no digits
            self.fail(f"{event.value!r} is not a valid {tag.rsplit(':', 1)[-1]}", event)


def _unknown_tag(tag: str) -> str:
    shown = "!!" + tag[len(_TAG):] if tag.startswith(_TAG) else tag    # as it is written
    return (f"unknown tag {shown}; neurofuzzy files hold plain numbers, words, lists and "
            "mappings: remove the tag")


class _MergeKey:
    def __repr__(self):
        return "'<<'"


_MERGE = _MergeKey()
