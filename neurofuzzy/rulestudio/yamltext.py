"""Edit YAML text in place: every change replaces, inserts or removes only the characters of
the values it touches, so comments, order, quoting and the alignment of the rest stay as the
author wrote them.

Round-trip libraries (ruamel.yaml) keep comments and order but re-emit every line: measured on
the shipped rule files, 4 of 6 lose their aligned columns (``soft:  {…}`` becomes
``soft: {…}``) without any edit. Here the text is the document; PyYAML's composer only tells
where every node starts and ends (:func:`parse`), and the edits (:class:`YamlText`) splice new
text at those places. A value written anew is formatted in flow style (:func:`flow`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import yaml

from ..errors import InputError

__all__ = ["Node", "parse", "YamlText", "flow", "format_number"]

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass
class Node:
    """Where a YAML node lies in the text.

    Attributes
    ----------
    kind : {"scalar", "mapping", "sequence"}
    start, end : int
        Character offsets of the node's text (a block collection ends with its last value,
        before any trailing comment or blank line).
    line, end_line : int
        1-based lines of its first and last character.
    column : int
        0-based column of its start.
    flow : bool
        A flow collection (``{…}``, ``[…]``); scalars are False.
    value : str or None
        A scalar's text as parsed (``None`` for collections).
    entries : list of (Node, Node)
        A mapping's keys and values.
    items : list of Node
        A sequence's items.
    """

    kind: str
    start: int
    end: int
    line: int
    end_line: int
    column: int
    flow: bool = False
    value: str | None = None
    tag: str = ""
    entries: list = field(default_factory=list)
    items: list = field(default_factory=list)

    def get(self, key: str) -> tuple[Node, Node] | None:
        """The (key, value) nodes of ``key`` in a mapping, or None."""
        for k, v in self.entries:
            if k.kind == "scalar" and k.value == key:
                return k, v
        return None

    @property
    def is_null(self) -> bool:
        return self.kind == "scalar" and self.tag.endswith(":null")


def parse(text: str) -> Node:
    """The node tree of ``text`` (one document, no anchors or aliases).

    Raises
    ------
    InputError
        Malformed YAML (with its line), or anchors and aliases (which the studio does not
        edit in place).
    """
    try:
        root = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        raise InputError(f"malformed YAML: {error.problem or error.context}",
                         line=mark.line + 1 if mark else None) from None
    except yaml.YAMLError as error:
        raise InputError(f"malformed YAML: {str(error).splitlines()[0]}") from None
    if root is None:
        raise InputError("the file is empty", line=1)
    seen: set[int] = set()
    return _convert(root, text, seen)


def _convert(node, text: str, seen: set) -> Node:
    if id(node) in seen:
        raise InputError("uses YAML anchors and aliases (&name, *name), which the studio cannot "
                         "edit in place; write the values out in a text editor",
                         line=node.start_mark.line + 1)
    seen.add(id(node))
    start = node.start_mark.index
    if isinstance(node, yaml.ScalarNode):
        end = node.end_mark.index
        out = Node("scalar", start, end, 0, 0, 0, value=node.value, tag=node.tag)
    elif isinstance(node, yaml.MappingNode):
        entries = [(_convert(k, text, seen), _convert(v, text, seen)) for k, v in node.value]
        flow = bool(node.flow_style)
        end = node.end_mark.index if flow or not entries else _last_end(entries[-1][1],
                                                                         entries[-1][0])
        out = Node("mapping", start, end, 0, 0, 0, flow=flow, tag=node.tag, entries=entries)
    else:
        items = [_convert(item, text, seen) for item in node.value]
        flow = bool(node.flow_style)
        end = node.end_mark.index if flow or not items else items[-1].end
        out = Node("sequence", start, end, 0, 0, 0, flow=flow, tag=node.tag, items=items)
    out.line = text.count("\n", 0, out.start) + 1
    out.end_line = text.count("\n", 0, max(out.end - 1, out.start)) + 1
    out.column = out.start - (text.rfind("\n", 0, out.start) + 1)
    return out


def _last_end(value: Node, key: Node) -> int:
    """End of a block mapping's last entry: its value, or its key when the value is empty."""
    return value.end if value.end > value.start else key.end


# -- formatting new values ------------------------------------------------------------------
def format_number(value: float) -> str:
    """A number as YAML 1.1 reads it back as the same number: integers without a point,
    others with at most 6 significant digits and always a point before an exponent."""
    value = float(value)
    if not math.isfinite(value):
        raise InputError(f"got {value}; expected a finite number")
    if value == int(value) and abs(value) < 1e15:
        return str(int(value))
    text = f"{value:.6g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        if "." not in mantissa:
            mantissa += ".0"
        sign = exponent[0] if exponent[0] in "+-" else "+"
        text = f"{mantissa}e{sign}{exponent.lstrip('+-').lstrip('0') or '0'}"
    return text


def _number_of(text: str | None) -> float | None:
    """The number a plain scalar reads as, or None."""
    try:
        value = yaml.safe_load(text) if text is not None else None
    except yaml.YAMLError:
        return None
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) \
        else None


def _plain_ok(text: str) -> bool:
    """Whether ``text`` reads back as itself as a plain scalar, in block and flow context."""
    if not text or text != text.strip() or "\n" in text or "#" in text:
        return False
    try:
        return (yaml.safe_load(f"k: {text}") == {"k": text}
                and yaml.safe_load(f"{{k: {text}}}") == {"k": text})
    except yaml.YAMLError:
        return False


def flow(value) -> str:
    """``value`` (None, bool, number, str, list, dict) as flow-style YAML text."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return format_number(value)
    if isinstance(value, str):
        return value if _plain_ok(value) else json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow(item) for item in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{flow(str(k))}: {flow(v)}" for k, v in value.items()) + "}"
    raise InputError(f"cannot write {type(value).__name__} values")


# -- edits ----------------------------------------------------------------------------------
class YamlText:
    """A YAML text and its node tree; every edit returns a new :class:`YamlText`.

    Parameters
    ----------
    text : str
    """

    def __init__(self, text: str):
        self.text = text
        self.root = parse(text)

    def find(self, path) -> tuple[Node | None, Node] | None:
        """(key node or None, value node) at ``path`` (keys and sequence indices), or None."""
        key, node = None, self.root
        for step in path:
            if isinstance(step, int):
                if node.kind != "sequence" or not 0 <= step < len(node.items):
                    return None
                key, node = None, node.items[step]
            else:
                if node.kind != "mapping" or node.get(step) is None:
                    return None
                key, node = node.get(step)
        return key, node

    def _splice(self, start: int, end: int, new: str) -> YamlText:
        return YamlText(self.text[:start] + new + self.text[end:])

    def _line_start(self, index: int) -> int:
        return self.text.rfind("\n", 0, index) + 1

    def _line_end(self, index: int) -> int:
        """Offset after the newline ending the line that holds ``index`` (or the text's end)."""
        end = self.text.find("\n", index)
        return len(self.text) if end < 0 else end + 1

    def replace(self, node: Node, new_text: str) -> YamlText:
        """``node``'s text replaced by ``new_text``. A null value (``key:`` with nothing) is
        filled in after its key."""
        if node.kind == "scalar" and node.start == node.end:
            return self._splice(node.start, node.end, " " + new_text)
        return self._splice(node.start, node.end, new_text)

    def set_number(self, node: Node, value: float) -> YamlText:
        """A scalar set to a number, unless it already reads as that number."""
        if node.kind == "scalar" and _number_of(node.value) == float(value):
            return self
        return self.replace(node, format_number(value))

    def set_numbers(self, node: Node, values) -> YamlText:
        """A sequence of numbers changed element by element: only the numbers that differ are
        rewritten (same length), else the whole sequence."""
        values = list(values)
        if node.kind == "sequence" and len(node.items) == len(values) and all(
                item.kind == "scalar" for item in node.items):
            edited = self
            for item, value in reversed(list(zip(node.items, values))):
                if _number_of(item.value) != float(value):
                    edited = edited._splice(item.start, item.end, format_number(value))
            return edited
        return self.replace(node, flow(values))

    def delete_entry(self, mapping: Node, key: str) -> YamlText:
        """``key`` and its value removed from ``mapping``."""
        index = next(i for i, (k, _) in enumerate(mapping.entries) if k.value == key)
        k, v = mapping.entries[index]
        if mapping.flow:
            return self._delete_flow(mapping.entries, index, k.start, max(v.end, k.end))
        return self._splice(self._line_start(k.start), self._line_end(max(v.end, k.end) - 1),
                            "")

    def delete_item(self, sequence: Node, index: int) -> YamlText:
        """Item ``index`` removed from ``sequence`` (its ``- `` line(s) in block style)."""
        item = sequence.items[index]
        if sequence.flow:
            return self._delete_flow([(item, item) for item in sequence.items], index,
                                     item.start, item.end)
        return self._splice(self._line_start(item.start), self._line_end(item.end - 1), "")

    def _delete_flow(self, pairs, index, start, end) -> YamlText:
        if index + 1 < len(pairs):
            end = pairs[index + 1][0].start
        elif index > 0:
            start = pairs[index - 1][1].end
        return self._splice(start, end, "")

    def insert_entry(self, mapping: Node, key: str, value, *, block: str | None = None,
                     parent_key: Node | None = None) -> YamlText:
        """``key: value`` added after the last entry of ``mapping``.

        ``value`` is written in flow style; ``block`` (text indented from column 0, starting
        with ``key:``) is inserted instead for a block mapping. An empty (null) mapping value
        needs its ``parent_key`` and becomes a block mapping.
        """
        entry = block if block is not None else f"{flow(key)}: {flow(value)}"
        if mapping.kind == "scalar":               # key: (nothing) -> key:\n  entry
            if parent_key is None or not mapping.is_null:
                raise InputError("expected a mapping here")
            return self.fill_null(parent_key, mapping, entry)
        if mapping.flow:
            if block is not None:
                entry = f"{flow(key)}: {flow(value)}"
            if mapping.entries:
                last = mapping.entries[-1][1]
                return self._splice(last.end, last.end, f", {entry}")
            return self.replace(mapping, "{" + entry + "}")
        first_key = mapping.entries[0][0]
        indent = " " * first_key.column
        at = self._line_end(mapping.end - 1)
        prefix = "" if self.text[:at].endswith("\n") else "\n"
        return self._splice(at, at, prefix + _indented(entry, indent))

    def fill_null(self, key: Node, value: Node, block: str) -> YamlText:
        """An empty value (``key:`` with nothing after it) given the lines of ``block``,
        indented two columns more than ``key``."""
        if not value.is_null or value.end > value.start and self.text[
                value.start:value.end].strip() not in ("", "~", "null", "Null", "NULL"):
            raise InputError("expected an empty value here", line=value.line)
        colon = self.text.index(":", key.end)
        end = max(value.end, colon + 1)
        return self._splice(key.end, end, ":\n" + _indented(block, " " * (key.column + 2))
                            .rstrip("\n"))

    def insert_item(self, sequence: Node, item) -> YamlText:
        """``item`` (a dict is written as a block mapping, others in flow style) appended to
        ``sequence``."""
        if sequence.flow:
            text = flow(item)
            if sequence.items:
                return self._splice(sequence.items[-1].end, sequence.items[-1].end, f", {text}")
            return self.replace(sequence, f"[{text}]")
        first = sequence.items[0]
        dash = self.text.rfind("-", 0, first.start)
        dash_column = dash - self._line_start(dash)
        content = first.column if first.column > dash_column else dash_column + 2
        if isinstance(item, dict):
            lines = [f"{flow(str(k))}: {flow(v)}" for k, v in item.items()]
        else:
            lines = [flow(item)]
        text = (" " * dash_column + "-" + " " * (content - dash_column - 1) + lines[0] + "\n"
                + "".join(" " * content + line + "\n" for line in lines[1:]))
        at = self._line_end(sequence.end - 1)
        prefix = "" if self.text[:at].endswith("\n") else "\n"
        return self._splice(at, at, prefix + text)

    def append_section(self, block: str) -> YamlText:
        """A top-level ``block`` (``key:`` and its indented lines) added at the end."""
        text = self.text if self.text.endswith("\n") else self.text + "\n"
        return YamlText(text + block if block.endswith("\n") else text + block + "\n")

    def entry_block(self, mapping: Node, key: str) -> str | None:
        """The lines of a block mapping's entry (``key:`` and its value with their comments),
        dedented to column 0; None in a flow mapping or when the entry shares its line with
        something else."""
        pair = mapping.get(key)
        if pair is None or mapping.flow:
            return None
        k, v = pair
        start = self._line_start(k.start)
        if self.text[start:k.start].strip():
            return None
        lines = self.text[start:self._line_end(max(v.end, k.end) - 1)].splitlines()
        return "\n".join(line[k.column:] if line[:k.column].strip() == "" else line.lstrip()
                         for line in lines) + "\n"


def _indented(block: str, indent: str) -> str:
    lines = block.rstrip("\n").split("\n")
    return "".join((indent + line if line.strip() else line) + "\n" for line in lines)
