"""The value objects of a rule base: linguistic variables and their terms, phrases ("not very
soft"), clauses, rules and labels (numbers in words), and the constants of the format."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, closest_name
from .membership import HEDGES

__all__ = ["QUANTITIES", "Term", "Variable", "Phrase", "Clause", "Rule", "Label",
           "RuleBaseError", "parse_phrase", "input_default"]

#: Physical quantities an output variable may stand for.
QUANTITIES = ("youngs_modulus", "poisson_ratio", "stiffness", "viscosity", "damping",
              "density", "node_mass", "relaxation_modulus", "relaxation_time",
              "strain_stiffening")
DEFUZZIFICATION = ("centroid", "bisector", "mom", "som", "lom")
GRID_POINTS = 401
TOP_KEYS = ("name", "description", "extends", "defuzzification", "and", "or", "inputs",
            "outputs", "rules", "tissues")
VARIABLE_KEYS = ("universe", "terms", "quantity", "description", "unit", "default")


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
    source: str = ""              # the rule file that defines it (for messages)
    #: an input's words for a tissue that does not describe it (None: its rules do not fire)
    default: Phrase | None = None

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
    source: str = ""              # the rule file that holds it (for messages)


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


def input_default(variable: Variable, value) -> tuple[Phrase | None, str | None]:
    """An input's ``default:`` as a :class:`Phrase`, or ``(None, problem)``: the words a
    tissue takes for an input it does not describe (without one, the rules about the input
    do not fire for that tissue)."""
    if variable.role != "input":
        return None, (f"{variable.name}: only an input takes a default (the words of a tissue "
                      "that does not describe it)")
    phrase, problem = parse_phrase(str(value), variable)
    return (None, f"{variable.name}: default: {problem}") if problem else (phrase, None)
