"""YAML with line numbers: every mapping and sequence remembers where its items start.

``load(path)`` returns plain ``dict``/``list`` subclasses (:class:`Mapping`, :class:`Sequence`)
with ``line`` (the 1-based line of the node) and ``line_of(key_or_index)``, so every message
about a rule file can say ``FILE:LINE``.
"""

from __future__ import annotations

import yaml

from ..errors import InputError

__all__ = ["Mapping", "Sequence", "load"]


class Mapping(dict):
    line: int = 0

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.lines: dict = {}

    def line_of(self, key) -> int:
        return self.lines.get(key, self.line)


class Sequence(list):
    line: int = 0

    def __init__(self, *args):
        super().__init__(*args)
        self.lines: list = []

    def line_of(self, index) -> int:
        return self.lines[index] if 0 <= index < len(self.lines) else self.line


def _build(node):
    if isinstance(node, yaml.MappingNode):
        out = Mapping()
        out.line = node.start_mark.line + 1
        for key_node, value_node in node.value:
            key = _build(key_node)
            if isinstance(key, (dict, list)):
                raise InputError("a mapping key must be a plain value", line=out.line)
            out[key] = _build(value_node)
            out.lines[key] = key_node.start_mark.line + 1
        return out
    if isinstance(node, yaml.SequenceNode):
        out = Sequence(_build(item) for item in node.value)
        out.line = node.start_mark.line + 1
        out.lines = [item.start_mark.line + 1 for item in node.value]
        return out
    return _scalar(node)


def _scalar(node):
    loader = yaml.SafeLoader("")
    try:
        return loader.construct_object(node, deep=True)
    finally:
        loader.dispose()


def load(path) -> object:
    """Parse a YAML file; malformed YAML raises ``InputError`` with the file and line."""
    source = str(path)
    try:
        with open(path, encoding="utf-8") as handle:
            node = yaml.compose(handle, Loader=yaml.SafeLoader)
    except FileNotFoundError:
        raise InputError("no such file", source=source) from None
    except UnicodeDecodeError as error:
        raise InputError(f"not UTF-8 text ({error.reason})", source=source) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise InputError(f"malformed YAML: {problem}", source=source,
                         line=mark.line + 1 if mark else None) from None
    if node is None:
        raise InputError("the file is empty", source=source, line=1)
    try:
        return _build(node)
    except InputError as error:
        raise InputError(error.detail, source=source, line=error.line) from None
