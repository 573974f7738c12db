"""What the page shows of a rule file: its variables, terms, rules and tissues as written (also
while the text has problems), where each comes from (the opened file or a file it extends) and
the lines each spans, so that a problem can be shown beside what it is about."""

from __future__ import annotations

from pathlib import Path

from ..io import safe_yaml
from ..errors import InputError
from ..rules.membership import HEDGES, MEMBERSHIP_FUNCTIONS
from ..rules.terms import QUANTITIES
from .yamltext import YamlText

__all__ = ["document_view", "QUANTITY_UNITS"]

#: units of the quantities, for outputs whose file gives none
QUANTITY_UNITS = {"youngs_modulus": "Pa", "poisson_ratio": "", "stiffness": "N/m",
                  "viscosity": "Pa s", "damping": "N s/m", "density": "kg/m^3",
                  "node_mass": "kg"}


def document_view(document) -> dict:
    """The JSON object of the page's state (see the module docstring)."""
    check = document.check()
    layers = [(document.path, document.doc, True)] + [
        (path, doc, False) for path, doc in document.parents()]
    variables: dict[tuple, dict] = {}
    rules, tissues = [], {}
    for path, doc, own in reversed(layers):          # the farthest parent first
        data = _data(doc.text)
        for role in ("input", "output"):
            section = data.get(role + "s")
            if not isinstance(section, dict):
                continue
            for name, spec in section.items():
                variables[(role, str(name))] = _variable(doc, path, own, role, str(name), spec)
        found = doc.find(["rules"])
        if isinstance(data.get("rules"), list) and found and found[1].kind == "sequence":
            for index, (spec, node) in enumerate(zip(data["rules"], found[1].items)):
                rules.append(_rule(path, own, index, spec, node))
        section = data.get("tissues")
        found = doc.find(["tissues"])
        if isinstance(section, dict) and found:
            for name, spec in section.items():
                key, node = found[1].get(str(name)) or (None, None)
                tissues[str(name)] = {
                    "name": str(name), "file": path.name, "own": own,
                    "line": key.line if key else None, "end_line": node.end_line if node else None,
                    "words": {str(k): _word(v) for k, v in spec.items()}
                    if isinstance(spec, dict) else {}}
    data = _data(document.text)
    settings = {}
    for key, default in (("defuzzification", "centroid"), ("and", "min"), ("or", "max")):
        value = data.get(key)
        for _, doc, _ in layers[1:]:
            if value is None:
                value = _data(doc.text).get(key)
        settings[key] = str(value if value is not None else default)
    return {
        "file": document.path.name,
        "folder": str(document.folder),
        "name": str(data.get("name", document.path.stem)),
        "chain": [path.name for path, _, _ in layers],
        "text": document.text,
        "dirty": document.dirty,
        "can_undo": bool(document.undo_stack),
        "can_redo": bool(document.redo_stack),
        "valid": check.rules is not None,
        "problems": check.problems,
        "notes": check.notes,
        "settings": settings,
        "variables": list(variables.values()),
        "rules": rules,
        "tissues": list(tissues.values()),
        "hedges": sorted(h.replace("_", " ") for h in HEDGES),
        "kinds": {kind: {"count": count, "meaning": meaning}
                  for kind, (count, _, meaning) in MEMBERSHIP_FUNCTIONS.items()},
    }


def _data(text: str) -> dict:
    try:
        data = safe_yaml.loads(text)
    except InputError:           # the check reports it
        return {}
    return data if isinstance(data, dict) else {}


def _word(value):
    return value if isinstance(value, (int, float)) and not isinstance(value, bool) \
        else str(value)


def _variable(doc: YamlText, path: Path, own: bool, role: str, name: str, spec) -> dict:
    key, node = doc.find([role + "s", name])
    out = {"name": name, "role": role, "file": path.name, "own": own, "line": key.line,
           "end_line": node.end_line, "universe": None, "terms": [], "quantity": None,
           "unit": ""}
    if not isinstance(spec, dict):
        return out
    universe = spec.get("universe")
    unit = str(spec.get("unit", ""))
    try:
        if isinstance(universe, dict):
            low, high = float(universe["min"]), float(universe["max"])
            scale = str(universe.get("scale", "linear"))
            unit = str(universe.get("unit", unit))
        else:
            low, high = (float(v) for v in universe)
            scale = "linear"
        if low < high and scale in ("linear", "log") and (scale == "linear" or low > 0):
            out["universe"] = {"low": low, "high": high, "scale": scale}
    except (TypeError, ValueError, KeyError):
        pass
    quantity = spec.get("quantity", name if name in QUANTITIES else None)
    out["quantity"] = str(quantity) if quantity is not None else None
    out["unit"] = unit or (QUANTITY_UNITS.get(str(quantity), "") if role == "output" else "")
    terms = spec.get("terms")
    terms_node = doc.find([role + "s", name, "terms"])
    if isinstance(terms, dict) and terms_node and terms_node[1].kind == "mapping":
        for term, definition in terms.items():
            pair = terms_node[1].get(str(term))
            entry = {"name": str(term), "line": pair[0].line if pair else None,
                     "kind": None, "params": None}
            if isinstance(definition, dict) and len(definition) == 1:
                (kind, params), = definition.items()
                entry.update(kind=str(kind), params=_plain(params))
            out["terms"].append(entry)
    return out


def _plain(value):
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return value
    return str(value)


def _rule(path: Path, own: bool, index: int, spec, node) -> dict:
    spec = spec if isinstance(spec, dict) else {}
    condition, conclusion = spec.get("if"), spec.get("then")
    text = (f"if {condition} then {conclusion}" if condition is not None
            and conclusion is not None else "")
    weight = spec.get("weight")
    return {"file": path.name, "own": own, "index": index, "line": node.line,
            "end_line": node.end_line, "text": text,
            "weight": weight if isinstance(weight, (int, float)) else None}
