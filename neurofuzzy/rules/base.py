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
      stiffness:                       # Young's modulus
        quantity: youngs_modulus       # youngs_modulus | stiffness | viscosity | damping |
        universe: {min: 100, max: 1e6, scale: log, unit: Pa}      # density | node_mass
        terms: {soft: {trimf: [300, 1000, 3000]}}
    rules:
      - if: consistency is very soft and elasticity is elastic
        then: stiffness is soft
        weight: 0.8                    # optional
    tissues:
      white_matter: {consistency: soft, elasticity: elastic}

A file may start with ``extends: other.yaml`` to take variables, rules and tissues from another
file and add or replace its own.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import skfuzzy as fuzz

from ..errors import InputError, closest_name
from . import _yaml
from .membership import (HEDGES, MEMBERSHIP_FUNCTIONS, apply_hedges, check_parameters,
                         evaluate)

__all__ = ["RuleBase", "RuleBaseError", "load_rules", "QUANTITIES", "Label"]

#: Physical quantities an output variable may stand for.
QUANTITIES = ("youngs_modulus", "stiffness", "viscosity", "damping", "density", "node_mass")
DEFUZZIFICATION = ("centroid", "bisector", "mom", "som", "lom")
GRID_POINTS = 401
TOP_KEYS = ("name", "description", "extends", "defuzzification", "and", "or", "inputs",
            "outputs", "rules", "tissues")
VARIABLE_KEYS = ("universe", "terms", "quantity", "description", "unit")


class RuleBaseError(InputError):
    """One or more problems in a rule file; ``problems`` lists them all (``FILE:LINE: …``)."""

    def __init__(self, problems: list[InputError]):
        self.problems = problems
        super().__init__("\n".join(str(p) for p in problems))
        self.args = ("\n".join(str(p) for p in problems),)

    def __str__(self):
        return self.args[0]


@dataclass
class Term:
    name: str
    kind: str
    params: object
    values: np.ndarray            # membership on the variable's grid
    line: int


@dataclass
class Variable:
    """A linguistic variable on a universe (linear or logarithmic)."""

    name: str
    role: str                     # "input" or "output"
    low: float
    high: float
    scale: str                    # "linear" or "log"
    unit: str
    quantity: str | None
    terms: dict = field(default_factory=dict)
    line: int = 0

    def to_internal(self, x):
        x = np.asarray(x, dtype=float)
        return np.log10(x) if self.scale == "log" else x

    def to_physical(self, u):
        u = np.asarray(u, dtype=float)
        return 10.0**u if self.scale == "log" else u

    @property
    def grid(self) -> np.ndarray:
        """(GRID_POINTS,) internal coordinates of the universe."""
        return np.linspace(self.to_internal(self.low), self.to_internal(self.high), GRID_POINTS)

    def membership(self, term: str, value) -> np.ndarray:
        """Degree of membership of a physical value in a term."""
        return np.interp(self.to_internal(value), self.grid, self.terms[term].values)


@dataclass
class Phrase:
    """``[hedges] term`` (e.g. "not very soft") or a crisp number."""

    hedges: tuple
    term: str | None
    value: float | None = None

    def __str__(self):
        if self.term is None:
            return f"{self.value:g}"
        return " ".join([h.replace("_", " ") for h in self.hedges] + [self.term])


@dataclass
class Clause:
    variable: str
    phrase: Phrase


@dataclass
class Rule:
    antecedent: list              # list of AND-groups (lists of Clause), joined by OR
    consequents: list             # list of Clause
    weight: float
    line: int
    text: str


@dataclass
class Label:
    """A number described in words: the best term, its degree and all degrees."""

    quantity: str
    value: float
    term: str
    degree: float
    degrees: dict

    def __str__(self):
        others = ", ".join(f"{t} {d:.2f}" for t, d in sorted(self.degrees.items(),
                                                              key=lambda kv: -kv[1]) if d > 0)
        return f"{self.quantity}: {others or self.term + ' 0.00'}"


class RuleBase:
    """A parsed, validated rule base (use :func:`load_rules`)."""

    def __init__(self, *, name, source, inputs, outputs, rules, tissues, defuzzification,
                 and_method, or_method):
        self.name = name
        self.source = source
        self.inputs: dict[str, Variable] = inputs
        self.outputs: dict[str, Variable] = outputs
        self.rules: list[Rule] = rules
        self.tissues: dict[str, dict[str, Phrase]] = tissues
        self.defuzzification = defuzzification
        self.and_method = and_method
        self.or_method = or_method

    @property
    def variables(self) -> dict[str, Variable]:
        return {**self.inputs, **self.outputs}

    # -- inference ---------------------------------------------------------------------------
    def infer(self, descriptions: list[dict]) -> dict[str, np.ndarray]:
        """Output values for many descriptions at once (vectorised over descriptions).

        Parameters
        ----------
        descriptions : list of dict
            Each maps input variable names to words ("very soft"), :class:`Phrase` objects or
            crisp numbers; inputs left out do not constrain the rules that use them (their
            clauses count as fully true).

        Returns
        -------
        dict of output name → (n_descriptions,) float, in physical units.
        """
        n = len(descriptions)
        sets = {}
        for name, variable in self.inputs.items():
            phrases = [self._phrase(d.get(name), variable) for d in descriptions]
            sets[name] = self._input_sets(variable, phrases)          # (n, G) or None
        strengths = []
        for rule in self.rules:
            groups = []
            for group in rule.antecedent:
                degrees = [self._possibility(sets[c.variable], self.inputs[c.variable], c.phrase, n)
                           for c in group]
                groups.append(_combine(degrees, self.and_method))
            strengths.append(_combine(groups, self.or_method, is_or=True) * rule.weight)
        results = {}
        for name, variable in self.outputs.items():
            aggregated = np.zeros((n, GRID_POINTS))
            for rule, strength in zip(self.rules, strengths):
                for clause in rule.consequents:
                    if clause.variable != name:
                        continue
                    shape = apply_hedges(variable.terms[clause.phrase.term].values,
                                         clause.phrase.hedges)
                    aggregated = np.maximum(aggregated,
                                            np.minimum(strength[:, None], shape[None, :]))
            results[name] = variable.to_physical(self._defuzzify(variable, aggregated))
        return results

    def _phrase(self, value, variable: Variable) -> Phrase | None:
        if value is None or isinstance(value, Phrase):
            return value
        if isinstance(value, (int, float, np.floating, np.integer)):
            return Phrase((), None, float(value))
        phrase, problem = parse_phrase(str(value), variable)
        if problem:
            raise InputError(problem, source=self.source, key=variable.name)
        return phrase

    def _input_sets(self, variable, phrases):
        """``(sets (n, G) or None, crisp (n,) internal values, NaN where fuzzy)``."""
        crisp = np.full(len(phrases), np.nan)
        if all(p is None for p in phrases):
            return None, crisp
        out = np.ones((len(phrases), GRID_POINTS))
        for i, phrase in enumerate(phrases):
            if phrase is None:
                continue
            if phrase.term is None:
                crisp[i] = variable.to_internal(phrase.value)
            else:
                out[i] = apply_hedges(variable.terms[phrase.term].values, phrase.hedges)
        return out, crisp

    @staticmethod
    def _possibility(inputs, variable, phrase, n):
        """Degree to which the input matches the clause.

        A described (fuzzy) input matches by the similarity of the two fuzzy sets,
        ``Σ min(A, B) / Σ max(A, B)`` (Jaccard): 1 when they coincide, so "very soft" fires
        the rule on "very soft" fully and the rule on "soft" partly, and the other way round
        (sup-min possibility would give 1 to both and lose the order of the hedges). A crisp
        input matches by the clause's membership at that value.
        """
        sets, crisp = inputs
        clause = apply_hedges(variable.terms[phrase.term].values, phrase.hedges)
        if sets is None:
            return np.ones(n)
        union = np.maximum(sets, clause[None, :]).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            degree = np.where(union > 0, np.minimum(sets, clause[None, :]).sum(axis=1) / union,
                              0.0)
        is_crisp = np.isfinite(crisp)
        if is_crisp.any():
            degree[is_crisp] = np.interp(crisp[is_crisp], variable.grid, clause)
        return degree

    def _defuzzify(self, variable, aggregated):
        grid = variable.grid
        total = aggregated.sum(axis=1)
        if np.any(total <= 0):     # no rule fired: NaN for those rows
            return np.where(total > 0, _centroid(grid, aggregated), np.nan)
        if self.defuzzification == "centroid":
            return _centroid(grid, aggregated)
        return np.array([fuzz.defuzz(grid, row, self.defuzzification) for row in aggregated])

    def tissue(self, name: str) -> dict[str, float]:
        """Inferred output values (physical units) of a tissue of the rule base."""
        if name not in self.tissues:
            hint = closest_name(name, self.tissues)
            raise InputError(f"no tissue {name!r}" + (f"; did you mean {hint!r}?" if hint else
                                                      f"; tissues: {sorted(self.tissues)}"),
                             source=self.source, key="tissue")
        values = self.infer([self.tissues[name]])
        missing = [k for k, v in values.items() if not np.isfinite(v[0])]
        if missing:
            raise InputError(f"no rule fires for tissue {name!r} on {missing}; add a rule",
                             source=self.source, key="tissues")
        return {k: float(v[0]) for k, v in values.items()}

    # -- back to words -----------------------------------------------------------------------
    def describe(self, values: dict[str, float]) -> dict[str, Label]:
        """For every output value: the term with the highest membership and all degrees."""
        labels = {}
        for name, value in values.items():
            if name not in self.outputs:
                raise InputError(f"no output variable {name!r}; outputs are "
                                 f"{sorted(self.outputs)}", source=self.source)
            variable = self.outputs[name]
            degrees = {t: float(variable.membership(t, value)) for t in variable.terms}
            best = max(degrees, key=degrees.get)
            labels[name] = Label(name, float(value), best, degrees[best], degrees)
        return labels

    def explain(self, values: dict[str, float], *, hedges=("very", "somewhat")) -> dict:
        """The combination of input words whose inferred outputs come closest to ``values``.

        Every combination of plain input terms is inferred at once (vectorised); the best one
        is then refined by trying the hedges on one input at a time. Distances are measured in
        internal coordinates (decades on log universes), relative to each universe's span.

        Returns ``{"words": {input: phrase}, "outputs": {...}, "distance": float}``.
        """
        names = list(self.inputs)
        wanted = {k: v for k, v in values.items() if k in self.outputs}
        if not wanted:
            raise InputError("no output values to explain", source=self.source)

        def distance(results):
            total = 0.0
            for key, value in wanted.items():
                variable = self.outputs[key]
                span = variable.to_internal(variable.high) - variable.to_internal(variable.low)
                diff = (variable.to_internal(results[key]) - variable.to_internal(value)) / span
                total = total + np.nan_to_num(diff, nan=10.0) ** 2
            return np.sqrt(total)

        combos = list(itertools.product(*[list(self.inputs[n].terms) for n in names]))
        descriptions = [dict(zip(names, combo)) for combo in combos]
        scores = distance(self.infer(descriptions))
        best = dict(zip(names, (Phrase((), t) for t in combos[int(np.argmin(scores))])))
        best_score = float(np.min(scores))
        improved = True
        while improved:
            improved = False
            trials = []
            for name in names:
                for hedge in hedges:
                    if hedge in best[name].hedges:
                        continue
                    trial = dict(best)
                    trial[name] = Phrase((hedge,) + best[name].hedges, best[name].term)
                    trials.append(trial)
            if not trials:
                break
            scores = distance(self.infer(trials))
            index = int(np.argmin(scores))
            if scores[index] < best_score - 1e-9:
                best, best_score, improved = trials[index], float(scores[index]), True
        outputs = {k: float(v[0]) for k, v in self.infer([best]).items()}
        return {"words": {k: str(v) for k, v in best.items()}, "outputs": outputs,
                "distance": best_score}

    def summary(self) -> str:
        lines = [f"rule base {self.name!r} ({self.source})"]
        for role, variables in (("input", self.inputs), ("output", self.outputs)):
            for v in variables.values():
                unit = f" {v.unit}" if v.unit else ""
                quantity = f" = {v.quantity}" if v.quantity else ""
                lines.append(f"  {role} {v.name}{quantity}: {v.low:g}..{v.high:g}{unit} "
                             f"({v.scale}); terms: {', '.join(v.terms)}")
        lines.append(f"  {len(self.rules)} rules; defuzzification {self.defuzzification}, "
                     f"and={self.and_method}, or={self.or_method}")
        lines.append(f"  tissues: {', '.join(self.tissues) or '(none)'}")
        return "\n".join(lines)


def _combine(degrees, method, is_or=False):
    out = degrees[0]
    for d in degrees[1:]:
        if is_or:
            out = np.maximum(out, d) if method == "max" else out + d - out * d
        else:
            out = np.minimum(out, d) if method == "min" else out * d
    return out


def _centroid(grid, aggregated):
    """Centroid of piecewise-linear membership functions (exact per segment, as skfuzzy)."""
    x0, x1 = grid[:-1], grid[1:]
    m0, m1 = aggregated[:, :-1], aggregated[:, 1:]
    width = x1 - x0
    area = ((m0 + m1) * width).sum(axis=1) / 2
    moment = (width * (x0 * (2 * m0 + m1) + x1 * (m0 + 2 * m1))).sum(axis=1) / 6
    with np.errstate(invalid="ignore", divide="ignore"):
        return moment / area


# -- parsing -------------------------------------------------------------------------------------
_HEDGE_WORDS = {"very", "extremely", "somewhat", "not", "more_or_less"}


def parse_phrase(text: str, variable: Variable) -> tuple[Phrase | None, str | None]:
    """``"not very soft"`` → Phrase; or ``(None, problem)`` with a "did you mean" hint."""
    words = re.sub(r"\bmore\s+or\s+less\b", "more_or_less", text.strip()).split()
    if not words:
        return None, f"empty description for {variable.name}"
    *hedges, term = words
    for hedge in hedges:
        if hedge not in _HEDGE_WORDS:
            hint = closest_name(hedge, sorted(_HEDGE_WORDS) + list(variable.terms))
            return None, (f"unknown hedge {hedge!r}" + (f"; did you mean {hint!r}?" if hint
                                                         else f"; hedges are {sorted(HEDGES)}"))
    if term not in variable.terms:
        hint = closest_name(term, variable.terms)
        return None, (f"{variable.name} has no term {term!r}" +
                      (f"; did you mean {hint!r}?" if hint else
                       f"; its terms are {list(variable.terms)}"))
    return Phrase(tuple(hedges), term), None


def load_rules(path) -> RuleBase:
    """Read, validate and build a rule base; all problems are reported together.

    Raises
    ------
    RuleBaseError
        With one ``FILE:LINE: message`` per problem.
    """
    return _Builder().build(Path(path))


class _Builder:
    def __init__(self):
        self.problems: list[InputError] = []

    def problem(self, source, line, message):
        self.problems.append(InputError(message, source=str(source), line=line))

    def build(self, path: Path, seen=()) -> RuleBase:
        data = _yaml.load(path)
        source = str(path)
        if not isinstance(data, dict):
            raise RuleBaseError([InputError("a rule base is a mapping (name:, inputs:, …)",
                                            source=source, line=getattr(data, "line", 1))])
        base = None
        if "extends" in data:
            parent = (path.parent / str(data["extends"])).resolve()
            if parent in seen or parent == path.resolve():
                self.problem(source, data.line_of("extends"), "extends itself (a cycle)")
            elif not parent.exists():
                self.problem(source, data.line_of("extends"), f"extends {parent.name}, "
                             "which does not exist")
            else:
                base = _Builder().build(parent, seen + (path.resolve(),))
        for key in data:
            if key not in TOP_KEYS:
                hint = closest_name(str(key), TOP_KEYS)
                self.problem(source, data.line_of(key), f"unknown key {key!r}" +
                             (f"; did you mean {hint!r}?" if hint else ""))
        inputs = dict(base.inputs) if base else {}
        outputs = dict(base.outputs) if base else {}
        for role, store in (("input", inputs), ("output", outputs)):
            section = data.get(role + "s") or {}
            if not isinstance(section, dict):
                self.problem(source, data.line_of(role + "s"), f"{role}s must be a mapping")
                continue
            for name, spec in section.items():
                variable = self.variable(source, role, str(name), spec, section.line_of(name))
                if variable is not None:
                    store[str(name)] = variable
        if not inputs:
            self.problem(source, data.line, "no input variables ('inputs:')")
        if not outputs:
            self.problem(source, data.line, "no output variables ('outputs:')")
        rules = list(base.rules) if base else []
        for index, spec in enumerate(data.get("rules") or []):
            rule = self.rule(source, spec, data["rules"].line_of(index), inputs, outputs)
            if rule is not None:
                rules.append(rule)
        if not rules:
            self.problem(source, data.line, "no rules ('rules:')")
        tissues = dict(base.tissues) if base else {}
        section = data.get("tissues") or {}
        for name, spec in section.items():
            tissue = self.tissue(source, str(name), spec, section.line_of(name), inputs)
            if tissue is not None:
                tissues[str(name)] = tissue
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
        if self.problems:
            raise RuleBaseError(self.problems)
        return RuleBase(name=str(data.get("name", path.stem)), source=source, inputs=inputs,
                        outputs=outputs, rules=rules, tissues=tissues,
                        defuzzification=settings["defuzzification"],
                        and_method=settings["and"], or_method=settings["or"])

    def variable(self, source, role, name, spec, line):
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
        variable = Variable(name, role, low, high, scale, unit, quantity, line=line)
        terms = spec.get("terms")
        if not isinstance(terms, dict) or not terms:
            self.problem(source, spec.line_of("terms"), f"{name}: needs at least one term")
            return variable
        for term, definition in terms.items():
            self.term(source, variable, str(term), definition, terms.line_of(term))
        return variable

    def term(self, source, variable, name, definition, line):
        if name in HEDGES or name in ("and", "or", "is", "more", "less"):
            self.problem(source, line, f"{variable.name}: {name!r} is a reserved word, not a term")
            return
        if not isinstance(definition, dict) or len(definition) != 1:
            self.problem(source, line, f"{variable.name}.{name}: write one membership function, "
                         f"e.g. {{trimf: [a, b, c]}}; known: {list(MEMBERSHIP_FUNCTIONS)}")
            return
        (kind, params), = definition.items()
        if kind not in MEMBERSHIP_FUNCTIONS:
            hint = closest_name(str(kind), MEMBERSHIP_FUNCTIONS)
            self.problem(source, line, f"{variable.name}.{name}: unknown membership function "
                         f"{kind!r}" + (f"; did you mean {hint!r}?" if hint else
                                        f"; known: {list(MEMBERSHIP_FUNCTIONS)}"))
            return
        why = check_parameters(kind, params)
        if why is None and variable.scale == "log":
            positions = [params[i] for i in MEMBERSHIP_FUNCTIONS[kind][1]] if kind != "points" \
                else [p[0] for p in params]
            if any(float(p) <= 0 for p in positions):
                why = "positions on a log universe must be > 0"
        if why:
            self.problem(source, line, f"{variable.name}.{name}: {why}")
            return
        values = evaluate(kind, params, variable.grid, variable.to_internal)
        if not np.all(np.isfinite(values)) or values.max() <= 1e-9:
            self.problem(source, line, f"{variable.name}.{name}: the term is zero over the whole "
                         f"universe [{variable.low:g}, {variable.high:g}]; move it inside")
            return
        variable.terms[name] = Term(name, kind, params, values, line)

    def clause(self, source, text, line, variables, role):
        match = re.fullmatch(r"\s*(\w+)\s+is\s+(.+?)\s*", text)
        if not match:
            self.problem(source, line, f"cannot read {text!r}; write 'VARIABLE is [hedges] TERM'")
            return None
        name, phrase_text = match.groups()
        if name not in variables:
            hint = closest_name(name, variables)
            self.problem(source, line, f"rule names undefined {role} variable {name!r}" +
                         (f"; did you mean {hint!r}?" if hint else
                          f"; {role}s are {list(variables)}"))
            return None
        phrase, problem = parse_phrase(phrase_text, variables[name])
        if problem:
            self.problem(source, line, problem)
            return None
        return Clause(name, phrase)

    def rule(self, source, spec, line, inputs, outputs):
        if not isinstance(spec, dict) or "if" not in spec or "then" not in spec:
            self.problem(source, line, "a rule needs 'if:' and 'then:'")
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
            return None
        if any(c is None for g in groups for c in g) or any(c is None for c in consequents):
            return None
        return Rule(groups, consequents, weight, line, f"if {spec['if']} then {spec['then']}")

    def tissue(self, source, name, spec, line, inputs):
        if not isinstance(spec, dict):
            self.problem(source, line, f"tissue {name!r}: describe it as {{variable: words}}")
            return None
        described = {}
        for variable, words in spec.items():
            at = spec.line_of(variable)
            if variable not in inputs:
                hint = closest_name(str(variable), inputs)
                self.problem(source, at, f"tissue {name!r}: unknown input {variable!r}" +
                             (f"; did you mean {hint!r}?" if hint else
                              f"; inputs are {list(inputs)}"))
                continue
            if isinstance(words, (int, float)) and not isinstance(words, bool):
                described[variable] = Phrase((), None, float(words))
                continue
            phrase, problem = parse_phrase(str(words), inputs[variable])
            if problem:
                self.problem(source, at, f"tissue {name!r}: {problem}")
                continue
            described[variable] = phrase
        return described
