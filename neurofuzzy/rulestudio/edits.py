"""The edits a page may ask for, as data: ``{"op": "set_term", "role": "output", …}``.

Each edit turns the opened file's text into a new text (:class:`~.yamltext.YamlText`); it never
runs anything the page sends. A variable or tissue the file takes from the file it extends is
first copied into the opened file, with its comments (a file may replace what it extends),
then changed there: the file extended is never written.

An edit whose request cannot be written at all (a rule sentence without ``then``, a name that
is not a word) raises :class:`EditError` naming the line it concerns; anything that can be
written but is wrong as a rule base (an unknown term, ``trimf`` out of order) is written and
reported by the check, as ``neurofuzzy rules check`` would report it.
"""

from __future__ import annotations

import inspect
import re

from ..errors import InputError
from .yamltext import YamlText, flow

__all__ = ["EditError", "apply_edit", "OPERATIONS", "parse_sentence", "NAME"]

#: names of new terms, tissues and variables: a word the rule sentences can name
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_RESERVED = {"very", "extremely", "somewhat", "not", "more_or_less", "and", "or", "is", "more",
             "less", "if", "then"}
_SETTINGS = {"defuzzification": ("centroid", "bisector", "mom", "som", "lom"),
             "and": ("min", "product"), "or": ("max", "probor")}
_HEDGE = r"(?:very|extremely|somewhat|not|more_or_less|more\s+or\s+less)"


class EditError(InputError):
    """An edit that cannot be written; ``line`` is the line it concerns (if any)."""


def parse_sentence(text: str, line: int | None = None) -> tuple[str, str]:
    """``"if A then B"`` → ``("A", "B")``."""
    match = re.fullmatch(r"\s*if\s+(.+?)\s+then\s+(.+?)\s*", str(text), flags=re.I | re.S)
    if not match:
        raise EditError("write the rule as 'if CONDITION then CONCLUSION', e.g. 'if "
                        "consistency is soft then youngs_modulus is soft'", line=line)
    return match.group(1).strip(), match.group(2).strip()


def _name(value, what: str, taken=()) -> str:
    value = str(value or "").strip()
    if not NAME.match(value) or value in _RESERVED:
        raise EditError(f"{what} {value!r}: a name is one word of letters, digits and _ "
                        "(not a hedge or and/or/is)")
    if value in taken:
        raise EditError(f"{what} {value!r} exists already")
    return value


def _section(role: str) -> str:
    if role not in ("input", "output"):
        raise EditError(f"role must be 'input' or 'output', got {role!r}")
    return role + "s"


# -- variables taken from the file extended are copied in first ------------------------------
def own_variable(doc: YamlText, parents: list[YamlText], role: str, name: str) -> YamlText:
    """``doc`` with variable ``name`` defined in it (copied from the nearest parent that
    defines it, comments included)."""
    section = _section(role)
    if doc.find([section, name]) is not None:
        return doc
    for parent in parents:
        found = parent.find([section])
        if found is None or found[1].kind != "mapping" or found[1].get(name) is None:
            continue
        block = parent.entry_block(found[1], name) or (
            f"{flow(name)}: {flow(_value(parent, [section, name]))}\n")
        return _insert_block(doc, section, name, block, _value(parent, [section, name]))
    raise EditError(f"no {role} variable {name!r}")


def own_tissue(doc: YamlText, parents: list[YamlText], name: str) -> YamlText:
    """``doc`` with tissue ``name`` described in it (copied from the nearest parent)."""
    if doc.find(["tissues", name]) is not None:
        return doc
    for parent in parents:
        found = parent.find(["tissues"])
        if found is None or found[1].kind != "mapping" or found[1].get(name) is None:
            continue
        block = parent.entry_block(found[1], name) or (
            f"{flow(name)}: {flow(_value(parent, ['tissues', name]))}\n")
        return _insert_block(doc, "tissues", name, block, _value(parent, ["tissues", name]))
    raise EditError(f"no tissue {name!r}")


def _value(doc: YamlText, path):
    """The plain value (dicts, lists, strings, numbers) at ``path``."""
    from ..io import safe_yaml

    value = safe_yaml.loads(doc.text)
    for step in path:
        value = value[step]
    return _plain(value)


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _insert_block(doc: YamlText, section: str, name: str, block: str, value) -> YamlText:
    found = doc.find([section])
    if found is None:
        return doc.append_section(f"{section}:\n" + "".join(
            "  " + line + "\n" if line.strip() else "\n" for line in block.rstrip("\n").split(
                "\n")))
    key, node = found
    if node.kind == "scalar" and not node.is_null:
        raise EditError(f"{section} must be a mapping", line=node.line)
    return doc.insert_entry(node, name, value, block=block, parent_key=key)


# -- the edits --------------------------------------------------------------------------------
def set_term(doc, parents, *, role, variable, term, kind, params):
    doc = own_variable(doc, parents, role, variable)
    path = [_section(role), variable, "terms", term]
    found = doc.find(path)
    if found is None:
        raise EditError(f"{variable} has no term {term!r}")
    _, node = found
    params = _params(params, f"{variable}.{term}")
    if node.kind == "mapping" and len(node.entries) == 1 and node.entries[0][0].value == kind:
        return doc.set_numbers(node.entries[0][1], params)
    return doc.replace(node, flow({str(kind): params}))


def add_term(doc, parents, *, role, variable, term, kind="trimf", params=None):
    doc = own_variable(doc, parents, role, variable)
    terms = doc.find([_section(role), variable, "terms"])
    if terms is None:
        raise EditError(f"{variable} has no 'terms:' to add to")
    taken = [k.value for k, _ in terms[1].entries] if terms[1].kind == "mapping" else []
    term = _name(term, "term", taken)
    params = _params(params, f"{variable}.{term}")
    return doc.insert_entry(terms[1], term, {str(kind): params}, parent_key=terms[0])


def delete_term(doc, parents, *, role, variable, term):
    doc = own_variable(doc, parents, role, variable)
    terms = doc.find([_section(role), variable, "terms"])
    if terms is None or terms[1].kind != "mapping" or terms[1].get(term) is None:
        raise EditError(f"{variable} has no term {term!r}")
    return doc.delete_entry(terms[1], term)


def rename_term(doc, parents, *, role, variable, term, new):
    """The term renamed, and every clause and tissue word of the opened file that names it."""
    doc = own_variable(doc, parents, role, variable)
    terms = doc.find([_section(role), variable, "terms"])
    if terms is None or terms[1].kind != "mapping" or terms[1].get(term) is None:
        raise EditError(f"{variable} has no term {term!r}")
    new = _name(new, "term", [k.value for k, _ in terms[1].entries])
    doc = doc.replace(terms[1].get(term)[0], new)
    pattern = re.compile(rf"(\b{re.escape(variable)}\s+is\s+(?:{_HEDGE}\s+)*){re.escape(term)}\b")
    rules = doc.find(["rules"])
    for index in range(len(rules[1].items) if rules and rules[1].kind == "sequence" else 0):
        for key in (("if",) if role == "input" else ("then",)):
            found = doc.find(["rules", index, key])
            if found and found[1].kind == "scalar" and pattern.search(found[1].value):
                doc = doc.replace(found[1], flow(pattern.sub(rf"\g<1>{new}", found[1].value)))
    tissues = doc.find(["tissues"])
    if role == "input" and tissues and tissues[1].kind == "mapping":
        for name in [k.value for k, _ in tissues[1].entries]:
            found = doc.find(["tissues", name, variable])
            if found and found[1].kind == "scalar" and found[1].value.split()[-1:] == [term]:
                doc = doc.replace(found[1], flow(" ".join(found[1].value.split()[:-1] + [new])))
    return doc


def set_universe(doc, parents, *, role, variable, low, high):
    doc = own_variable(doc, parents, role, variable)
    found = doc.find([_section(role), variable, "universe"])
    if found is None:
        raise EditError(f"{variable} has no 'universe:'")
    node = found[1]
    if node.kind == "sequence":
        return doc.set_numbers(node, [_number(low, "low", node.line),
                                      _number(high, "high", node.line)])
    if node.kind == "mapping":
        for key, value in (("max", high), ("min", low)):
            pair = node.get(key)
            if pair is None:
                raise EditError(f"{variable}: universe has no '{key}:'", line=node.line)
            doc = doc.set_number(pair[1], _number(value, key, node.line))
            node = doc.find([_section(role), variable, "universe"])[1]
        return doc
    raise EditError(f"{variable}: universe must be [low, high] or a mapping", line=node.line)


def _rule_node(doc, index):
    found = doc.find(["rules", int(index)])
    if found is None or found[1].kind != "mapping":
        raise EditError(f"the opened file has no rule {index}")
    return found[1]


def set_rule(doc, parents, *, index, text, weight=None):
    rule = _rule_node(doc, index)
    condition, conclusion = parse_sentence(text, rule.line)
    for key, value in (("then", conclusion), ("if", condition)):
        pair = _rule_node(doc, index).get(key)
        if pair is None:
            raise EditError(f"rule has no '{key}:'", line=rule.line)
        if pair[1].value != value:
            doc = doc.replace(pair[1], flow(value))
    rule = _rule_node(doc, index)
    pair = rule.get("weight")
    if weight is None or weight == "":
        return doc.delete_entry(rule, "weight") if pair is not None else doc
    weight = _number(weight, "weight", rule.line)
    if pair is None:
        return doc.insert_entry(rule, "weight", weight)
    return doc.set_number(pair[1], weight)


def add_rule(doc, parents, *, text, weight=None):
    condition, conclusion = parse_sentence(text)
    item = {"if": condition, "then": conclusion}
    if weight not in (None, ""):
        item["weight"] = _number(weight, "weight")
    found = doc.find(["rules"])
    if found is None:
        return doc.append_section("rules:\n" + "".join(
            ("  - " if i == 0 else "    ") + f"{k}: {flow(v)}\n"
            for i, (k, v) in enumerate(item.items())))
    key, node = found
    if node.kind == "sequence" and node.items:
        return doc.insert_item(node, item)
    if node.kind == "sequence":                       # rules: []
        return doc.replace(node, flow([item]))
    return doc.fill_null(key, node, "".join(("- " if i == 0 else "  ") + f"{k}: {flow(v)}\n"
                                            for i, (k, v) in enumerate(item.items())))


def delete_rule(doc, parents, *, index):
    _rule_node(doc, index)
    return doc.delete_item(doc.find(["rules"])[1], int(index))


def set_tissue(doc, parents, *, tissue, variable, words):
    """One input of a tissue described anew (``words`` empty: left out)."""
    doc = own_tissue(doc, parents, tissue)
    _, node = doc.find(["tissues", tissue])
    if node.kind != "mapping":
        raise EditError(f"tissue {tissue!r} must be a mapping", line=node.line)
    words = words.strip() if isinstance(words, str) else words
    pair = node.get(variable)
    if words in ("", None):
        return doc.delete_entry(node, variable) if pair is not None else doc
    value = words if isinstance(words, str) else _number(words, variable, node.line)
    if pair is None:
        return doc.insert_entry(node, variable, value)
    return doc.replace(pair[1], flow(value))


def add_tissue(doc, parents, *, tissue, words=None):
    found = doc.find(["tissues"])
    taken = [k.value for k, _ in found[1].entries] if found and found[1].kind == "mapping" else []
    tissue = _name(tissue, "tissue", taken)
    words = {str(k): v for k, v in (words or {}).items() if v not in ("", None)}
    if found is None:
        return doc.append_section(f"tissues:\n  {tissue}: {flow(words)}\n")
    return doc.insert_entry(found[1], tissue, words, parent_key=found[0])


def rename_tissue(doc, parents, *, tissue, new):
    found = doc.find(["tissues"])
    if found is None or found[1].kind != "mapping" or found[1].get(tissue) is None:
        raise EditError(f"the opened file does not describe tissue {tissue!r}")
    new = _name(new, "tissue", [k.value for k, _ in found[1].entries])
    return doc.replace(found[1].get(tissue)[0], new)


def delete_tissue(doc, parents, *, tissue):
    found = doc.find(["tissues"])
    if found is None or found[1].kind != "mapping" or found[1].get(tissue) is None:
        raise EditError(f"the opened file does not describe tissue {tissue!r}")
    return doc.delete_entry(found[1], tissue)


def set_setting(doc, parents, *, key, value):
    if key not in _SETTINGS:
        raise EditError(f"setting must be one of {list(_SETTINGS)}, got {key!r}")
    found = doc.find([key])
    if found is None:
        return doc.insert_entry(doc.root, key, str(value))
    return doc.replace(found[1], flow(str(value)))


def _params(params, what) -> list:
    """Membership parameters as sent: numbers, or [x, membership] pairs (``points``)."""
    if not isinstance(params, list) or not params or len(params) > 64:
        raise EditError(f"{what}: parameters must be a list of numbers")
    if all(isinstance(p, list) for p in params):
        return [[_number(v, what) for v in pair] for pair in params]
    return [_number(v, what) for v in params]


def _number(value, what, line=None) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise EditError(f"{what} must be a number, got {value!r}", line=line) from None
    if number != number or number in (float("inf"), float("-inf")):
        raise EditError(f"{what} must be a finite number, got {value!r}", line=line)
    return number


OPERATIONS = {f.__name__: f for f in (set_term, add_term, delete_term, rename_term,
                                      set_universe, set_rule, add_rule, delete_rule,
                                      set_tissue, add_tissue, rename_tissue, delete_tissue,
                                      set_setting)}


def apply_edit(doc: YamlText, parents: list[YamlText], edit: dict) -> YamlText:
    """The text after ``edit`` (a dict with ``"op"`` naming one of :data:`OPERATIONS`)."""
    if not isinstance(edit, dict) or edit.get("op") not in OPERATIONS:
        raise EditError(f"unknown edit {edit.get('op') if isinstance(edit, dict) else edit!r}; "
                        f"known: {sorted(OPERATIONS)}")
    operation = OPERATIONS[edit["op"]]
    arguments = {k: v for k, v in edit.items() if k != "op"}
    try:
        inspect.signature(operation).bind(doc, parents, **arguments)
    except TypeError as error:            # a missing field
        raise EditError(f"{edit['op']}: {error}") from None
    return operation(doc, parents, **arguments)
