"""Rule bases: linguistic variables, rules, tissues; inference and the way back to words.

The file format is documented in ``rules/README.md``. In short::

    name: soft tissue
    defuzzification: centroid          # or bisector, mom, som, lom
    and: min                           # or product;   or: max | probor
    inputs:
      consistency:
        universe: [0, 10]
        terms: {soft: {trimf: [0, 2.5, 5]}, firm: {trimf: [2.5, 5, 7.5]}}
    outputs:
      youngs_modulus:                  # named after its quantity: youngs_modulus | stiffness |
        universe: {min: 100, max: 1e6, scale: log, unit: Pa}   # viscosity | damping | density
        terms: {soft: {trimf: [300, 1000, 3000]}}               # | node_mass
    rules:
      - if: consistency is very soft and elasticity is elastic
        then: youngs_modulus is soft
        weight: 0.8                    # optional
    tissues:
      white_matter: {consistency: soft, elasticity: elastic}

A file may start with ``extends: other.yaml`` to take variables, rules and tissues from another
file and add or replace its own.

Every problem is reported at once with its FILE:LINE and a "did you mean" hint. An output named
after another quantity than the one it stands for (the old ``stiffness:`` with
``quantity: youngs_modulus``, where ``stiffness`` means a spring constant in N/m) still loads:
it is renamed to its quantity (rules that name it follow), with a
:class:`~neurofuzzy.errors.RuleFileDeprecationWarning` naming FILE:LINE.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError, RuleFileDeprecationWarning, closest_name
from ..io.safe_yaml import kind_of
from . import files as rule_files
from .limits import (defuzzification_problems, shared_quantities, term_problem,
                     tissue_problems, universe_problems)
from .membership import HEDGES, MEMBERSHIP_FUNCTIONS, check_parameters, evaluate
from .rulebase import RuleBase
from .terms import (DEFUZZIFICATION, QUANTITIES, TOP_KEYS, VARIABLE_KEYS, Clause, Phrase, Rule,
                    RuleBaseError, Term, Variable, input_default, parse_phrase)

__all__ = ["load_rules"]


def load_rules(path, *, text: str | None = None) -> RuleBase:
    """Read, validate and build a rule base; all problems are reported together.

    Parameters
    ----------
    path : str or path
        The rule file.
    text : str, optional
        The file's content as it would be written to ``path`` (an editor's unsaved text):
        read instead of the file, with ``path`` naming it in messages and anchoring
        ``extends:`` (the files it extends are read from disk).

    Raises
    ------
    RuleBaseError
        With one ``FILE:LINE: message`` per problem.
    """
    return _Builder().build(Path(path), text=text)


class _Builder:
    def __init__(self):
        self.problems: list[InputError] = []
        self.renamed: dict[str, str] = {}       # deprecated output names → quantity names
        # what failed to build, already reported: later mentions are knock-on effects, not
        # reported again (one root error each)
        self.broken: set[tuple[str, str]] = set()           # (role, variable)
        self.broken_terms: set[tuple[str, str]] = set()     # (variable, term)
        self.dropped_rules = 0

    def problem(self, source, line, message):
        self.problems.append(InputError(message, source=str(source), line=line))

    def build(self, path: Path, seen=(), text: str | None = None) -> RuleBase:
        data = rule_files.load(path) if text is None else rule_files.loads(text, str(path))
        source = str(path)
        if not isinstance(data, dict):
            raise RuleBaseError([InputError("a rule base is a mapping (name:, inputs:, …)",
                                            source=source, line=getattr(data, "line", 1))])
        base = None
        if "extends" in data:
            extends = data["extends"]
            parent = (path.parent / str(extends)).resolve()
            if not isinstance(extends, str) or not extends.strip():
                self.problem(source, data.line_of("extends"), f"extends must name a rule file "
                             f"(e.g. extends: soft_tissue.yaml), got {extends!r}")
            elif parent in seen or parent == path.resolve():
                self.problem(source, data.line_of("extends"), "extends itself (a cycle)")
            elif not parent.exists():
                self.problem(source, data.line_of("extends"), f"extends {parent.name}, "
                             "which does not exist")
            elif not parent.is_file():
                self.problem(source, data.line_of("extends"), f"extends {extends!r}, which is "
                             f"a directory ({parent}), not a rule file")
            else:
                base = _Builder().build(parent, seen + (path.resolve(),))
        for key in ("rules", "tissues"):
            expected = list if key == "rules" else dict
            if data.get(key) is not None and not isinstance(data[key], expected):
                self.problem(source, data.line_of(key), f"{key} must be a " + (
                    "list of rules (- if: ... then: ...)" if key == "rules" else
                    "mapping of tissue names to descriptions (NAME: {variable: words})") +
                    f", got {kind_of(data[key])}")
        for key in data:
            if key not in TOP_KEYS:
                hint = closest_name(str(key), TOP_KEYS)
                self.problem(source, data.line_of(key), f"unknown key {key!r}" +
                             (f"; did you mean {hint!r}?" if hint else ""))
        inputs = dict(base.inputs) if base else {}
        outputs = dict(base.outputs) if base else {}
        self.renamed.update(base.renamed if base else {})
        for role, store in (("input", inputs), ("output", outputs)):
            section = data.get(role + "s") or {}
            if not isinstance(section, dict):
                self.problem(source, data.line_of(role + "s"), f"{role}s must be a mapping")
                continue
            for name, spec in section.items():
                variable = self.variable(source, role, str(name), spec, section.line_of(name),
                                         section)
                if variable is not None:
                    store[variable.name] = variable
                else:
                    self.broken.add((role, str(name)))
        self.one_per_quantity(source, outputs)
        broken_base = "extends" in data and base is None    # already reported; the rest
        if not inputs and not broken_base and not self.any_broken("input"):  # would follow
            self.problem(source, data.line, "no input variables ('inputs:')")
        if not outputs and not broken_base and not self.any_broken("output"):
            self.problem(source, data.line, "no output variables ('outputs:')")
        rules = list(base.rules) if base else []
        for index, spec in enumerate(data["rules"] if isinstance(data.get("rules"), list)
                                     else []):
            rule = self.rule(source, spec, data["rules"].line_of(index), inputs, outputs)
            if rule is not None:
                rules.append(rule)
        if not rules and not broken_base and not self.dropped_rules:
            self.problem(source, data.line, "no rules ('rules:')")
        tissues = dict(base.tissues) if base else {}
        tissue_lines = dict(base.tissue_lines) if base else {}
        section = data["tissues"] if isinstance(data.get("tissues"), dict) else {}
        for name, spec in section.items():
            tissue = self.tissue(source, str(name), spec, section.line_of(name), inputs)
            if tissue is not None:
                tissues[str(name)] = tissue
                tissue_lines[str(name)] = (source, section.line_of(name))
        settings = {}
        for key, default, allowed in (("defuzzification", "centroid", DEFUZZIFICATION),
                                      ("and", "min", ("min", "product")),
                                      ("or", "max", ("max", "probor"))):
            value = data.get(key, getattr(base, {"and": "and_method", "or": "or_method"}
                                          .get(key, key), default) if base else default)
            if value not in allowed:
                hint = closest_name(str(value), allowed)
                self.problem(source, data.line_of(key), f"{key}: {value!r} is not one of "
                             f"{list(allowed)}" + (f"; did you mean {hint!r}?" if hint else ""))
            settings[key] = value
        if not self.problems:
            for line, message in defuzzification_problems(outputs, rules,
                                                          settings["defuzzification"]):
                self.problem(source, data.line_of("defuzzification") or line, message)
        if self.problems:
            raise RuleBaseError(self.problems)
        rule_base = RuleBase(name=str(data.get("name", path.stem)), source=source,
                             inputs=inputs, outputs=outputs, rules=rules, tissues=tissues,
                             defuzzification=settings["defuzzification"],
                             and_method=settings["and"], or_method=settings["or"],
                             renamed=self.renamed, tissue_lines=tissue_lines, files=[
                                 rule_files.fingerprint(path, text), *getattr(base, "files", [])])
        self.check_tissue_values(rule_base)
        if self.problems:
            raise RuleBaseError(self.problems)
        return rule_base

    def any_broken(self, role: str) -> bool:
        return any(r == role for r, _ in self.broken)

    def one_per_quantity(self, source, outputs) -> None:
        """Two outputs that stand for one quantity are refused (:func:`.limits.shared_quantities`);
        neither is reported again where it is used."""
        for line, message, names in shared_quantities(outputs, source):
            self.problem(source, line, message)
            self.broken.update(("output", name) for name in names)

    def check_tissue_values(self, rule_base) -> None:
        """Every tissue's inferred values must be physically possible."""
        self.problems += tissue_problems(rule_base)

    def variable(self, source, role, name, spec, line, siblings=None):
        if not isinstance(spec, dict):
            self.problem(source, line, f"{role} {name!r} needs 'universe' and 'terms'")
            return None
        for key in spec:
            if key not in VARIABLE_KEYS:
                hint = closest_name(str(key), VARIABLE_KEYS)
                self.problem(source, spec.line_of(key), f"{name}: unknown key {key!r}" +
                             (f"; did you mean {hint!r}?" if hint else ""))
        universe = spec.get("universe")
        scale, unit = "linear", str(spec.get("unit", ""))
        if isinstance(universe, dict):
            low, high = universe.get("min"), universe.get("max")
            scale = str(universe.get("scale", "linear"))
            unit = str(universe.get("unit", unit))
        elif isinstance(universe, list) and len(universe) == 2:
            low, high = universe
        else:
            self.problem(source, spec.line_of("universe"), f"{name}: universe must be "
                         "[low, high] or {min:, max:, scale: linear|log, unit:}")
            return None
        try:
            low, high = float(low), float(high)
        except (TypeError, ValueError):
            self.problem(source, spec.line_of("universe"), f"{name}: universe bounds must be "
                         f"numbers, got {low!r} and {high!r}")
            return None
        if scale not in ("linear", "log"):
            self.problem(source, spec.line_of("universe"), f"{name}: scale must be 'linear' or "
                         f"'log', got {scale!r}")
            return None
        if not (np.isfinite(low) and np.isfinite(high)):
            self.problem(source, spec.line_of("universe"), f"{name}: universe bounds must be "
                         f"finite numbers, got [{low:g}, {high:g}]")
            return None
        if not low < high or (scale == "log" and low <= 0):
            self.problem(source, spec.line_of("universe"), f"{name}: universe needs low < high"
                         + (" and low > 0 on a log scale" if scale == "log" else "") +
                         f", got [{low:g}, {high:g}]")
            return None
        quantity = spec.get("quantity", name if name in QUANTITIES else None)
        if role == "output" and quantity is not None and quantity not in QUANTITIES:
            hint = closest_name(str(quantity), QUANTITIES)
            self.problem(source, spec.line_of("quantity"), f"{name}: unknown quantity "
                         f"{quantity!r}" + (f"; did you mean {hint!r}?" if hint else
                                             f"; quantities are {list(QUANTITIES)}"))
            return None
        if role == "output":
            limits = universe_problems(name, quantity, low, high, unit)
            for message in limits:
                self.problem(source, spec.line_of("universe"), message)
            if limits:
                return None
        if role == "output" and name in QUANTITIES and quantity in QUANTITIES \
                and quantity != name:
            if siblings is not None and quantity in siblings:
                self.problem(source, line, f"output {name!r} stands for {quantity} (its old "
                             f"name), and output {quantity!r} (line "
                             f"{siblings.line_of(quantity)}) is {quantity} too: the old name "
                             f"would replace it; remove {name!r} (or rename it and the rules "
                             f"that name it to {quantity!r} and remove the other)")
                self.broken.add(("output", quantity))
                return None
            warnings.warn(RuleFileDeprecationWarning(
                f"{source}:{line}: output {name!r} stands for {quantity}; in neurofuzzy "
                f"{name!r} means another quantity, so the output is read as {quantity!r} — "
                f"rename it (and the rules that name it) to {quantity!r}"), stacklevel=4)
            self.renamed[name] = quantity
            name = quantity
        variable = Variable(name, role, low, high, scale, unit, quantity, line=line,
                            source=source)
        terms = spec.get("terms")
        if not isinstance(terms, dict) or not terms:
            self.problem(source, spec.line_of("terms"), f"{name}: needs at least one term")
            self.broken.add((role, name))
            return None
        for term, definition in terms.items():
            self.term(source, variable, str(term), definition, terms.line_of(term))
        if "default" in spec:
            variable.default, problem = input_default(variable, spec["default"])
            if problem:
                self.problem(source, spec.line_of("default"), problem)
        return variable

    def term(self, source, variable, name, definition, line):
        if name in HEDGES or name in ("and", "or", "is", "more", "less"):
            self.problem(source, line, f"{variable.name}: {name!r} is a reserved word, not a term")
            self.broken_terms.add((variable.name, name))
            return
        if not isinstance(definition, dict) or len(definition) != 1:
            self.problem(source, line, f"{variable.name}.{name}: write one membership function, "
                         f"e.g. {{trimf: [a, b, c]}}; known: {list(MEMBERSHIP_FUNCTIONS)}")
            self.broken_terms.add((variable.name, name))
            return
        (kind, params), = definition.items()
        if kind not in MEMBERSHIP_FUNCTIONS:
            hint = closest_name(str(kind), MEMBERSHIP_FUNCTIONS)
            self.problem(source, line, f"{variable.name}.{name}: unknown membership function "
                         f"{kind!r}" + (f"; did you mean {hint!r}?" if hint else
                                        f"; known: {list(MEMBERSHIP_FUNCTIONS)}"))
            self.broken_terms.add((variable.name, name))
            return
        why = check_parameters(kind, params)
        if why is None and variable.scale == "log":
            positions = [params[i] for i in MEMBERSHIP_FUNCTIONS[kind][1]] if kind != "points" \
                else [p[0] for p in params]
            if any(float(p) <= 0 for p in positions):
                why = "positions on a log universe must be > 0"
        if why is None and variable.role == "output":
            why = term_problem(variable, kind, params)
        if why:
            self.problem(source, line, f"{variable.name}.{name}: {why}")
            self.broken_terms.add((variable.name, name))
            return
        values = evaluate(kind, params, variable.grid, variable.to_internal)
        if not np.all(np.isfinite(values)) or values.max() <= 1e-9:
            self.problem(source, line, f"{variable.name}.{name}: the term is zero over the whole "
                         f"universe [{variable.low:g}, {variable.high:g}]; move it inside")
            self.broken_terms.add((variable.name, name))
            return
        variable.terms[name] = Term(name, kind, params, values, line)

    def clause(self, source, text, line, variables, role):
        match = re.fullmatch(r"\s*(\w+)\s+is\s+(.+?)\s*", text)
        if not match:
            self.problem(source, line, f"cannot read {text!r}; write 'VARIABLE is [hedges] TERM'")
            return None
        name, phrase_text = match.groups()
        if role == "output":
            name = self.renamed.get(name, name)
        if name not in variables and (role, name) in self.broken:
            return None                             # its definition's error is reported
        if name not in variables:
            hint = closest_name(name, variables)
            self.problem(source, line, f"rule names undefined {role} variable {name!r}" +
                         (f"; did you mean {hint!r}?" if hint else
                          f"; {role}s are {list(variables)}"))
            return None
        phrase, problem = parse_phrase(phrase_text, variables[name])
        if problem and not self.knock_on(name, phrase_text):
            self.problem(source, line, problem)
        if problem:
            return None
        return Clause(name, phrase)

    def knock_on(self, variable: str, phrase_text: str) -> bool:
        """Does ``phrase_text`` name a term whose definition failed (already reported)?"""
        words = phrase_text.split()
        return bool(words) and (variable, words[-1]) in self.broken_terms

    def rule(self, source, spec, line, inputs, outputs):
        if not isinstance(spec, dict) or "if" not in spec or "then" not in spec:
            self.problem(source, line, "a rule needs 'if:' and 'then:'")
            self.dropped_rules += 1
            return None
        for key in spec:
            if key not in ("if", "then", "weight"):
                hint = closest_name(str(key), ("if", "then", "weight"))
                self.problem(source, spec.line_of(key), f"unknown rule key {key!r}" +
                             (f"; did you mean {hint!r}?" if hint else ""))
        text = re.sub(r"\bmore\s+or\s+less\b", "more_or_less", str(spec["if"]))
        groups = []
        for part in re.split(r"\s+or\s+", text):
            clauses = [self.clause(source, c, spec.line_of("if"), inputs, "input")
                       for c in re.split(r"\s+and\s+", part)]
            groups.append(clauses)
        consequents = [self.clause(source, c, spec.line_of("then"), outputs, "output")
                       for c in re.split(r"\s+and\s+", str(spec["then"]))]
        weight = spec.get("weight", 1.0)
        try:
            weight = float(weight)
            if not 0 <= weight <= 1:
                raise ValueError
        except (TypeError, ValueError):
            self.problem(source, spec.line_of("weight"), f"weight must be in [0, 1], got "
                         f"{spec.get('weight')!r}")
            self.dropped_rules += 1
            return None
        if any(c is None for g in groups for c in g) or any(c is None for c in consequents):
            self.dropped_rules += 1
            return None
        return Rule(groups, consequents, weight, line, f"if {spec['if']} then {spec['then']}",
                    source=source)

    def tissue(self, source, name, spec, line, inputs):
        if not isinstance(spec, dict):
            self.problem(source, line, f"tissue {name!r}: describe it as {{variable: words}}")
            return None
        described = {}
        for variable, words in spec.items():
            at = spec.line_of(variable)
            if variable not in inputs and ("input", str(variable)) in self.broken:
                continue                            # its definition's error is reported
            if variable not in inputs:
                hint = closest_name(str(variable), inputs)
                self.problem(source, at, f"tissue {name!r}: unknown input {variable!r}" +
                             (f"; did you mean {hint!r}?" if hint else
                              f"; inputs are {list(inputs)}"))
                continue
            if isinstance(words, (int, float)) and not isinstance(words, bool):
                low, high = inputs[variable].low, inputs[variable].high
                if not low <= words <= high:         # also NaN; never clamped
                    self.problem(source, at, f"tissue {name!r}: {variable} = {words:g} is "
                                 f"outside its universe [{low:g}, {high:g}]; give a value in "
                                 "it, or words")
                    continue
                described[variable] = Phrase((), None, float(words))
                continue
            phrase, problem = parse_phrase(str(words), inputs[variable])
            if problem:
                if not self.knock_on(variable, str(words)):
                    self.problem(source, at, f"tissue {name!r}: {problem}")
                continue
            described[variable] = phrase
        return described
