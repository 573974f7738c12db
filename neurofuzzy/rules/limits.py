"""What each material quantity can physically be, checked where a rule base states it.

Every output variable of a rule base that stands for a quantity (:data:`QUANTITY_LIMITS`)
is held to that quantity's physics: its universe must lie within what the quantity can be
(a Young's modulus is positive, a Poisson's ratio of an isotropic solid lies strictly between
0 and 0.5), its membership functions may not be placed beyond it, its unit must be the one
neurofuzzy reads it in (a ``kPa`` universe would be read as pascals), and its
defuzzification must not be able to land on an impossible bound (``lom`` on a term that
reaches ν = 0.5 gives exactly 0.5). The values a tissue infers are checked too
(:func:`check_inferred`), naming the rule file, the tissue's line and the quantity in words.

The parser (:mod:`.parser`) calls these checks and reports every problem at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, closest_name
from .membership import MEMBERSHIP_FUNCTIONS, apply_hedges

__all__ = ["QuantityLimit", "QUANTITY_LIMITS", "universe_problems", "term_problem",
           "defuzzification_problems", "shared_quantities", "check_inferred", "tissue_problems",
           "words_of", "unknown_tissue"]


@dataclass(frozen=True)
class QuantityLimit:
    """What one quantity can be.

    Attributes
    ----------
    words : str
        The quantity as a user says it ("Young's modulus").
    unit : str
        The unit neurofuzzy reads it in ("" for ratios).
    low, high : float
        Physical bounds, both excluded (``high`` may be ``inf``).
    units : tuple of str
        Spellings of ``unit`` accepted in a rule file.
    why : str
        Why the bounds hold, for messages.
    other_units : dict of str → float
        Units a user may write by mistake and their factor to ``unit`` (for the fix).
    """

    words: str
    unit: str
    low: float
    high: float
    units: tuple[str, ...]
    why: str
    other_units: tuple[tuple[str, float], ...] = ()

    def contains(self, value: float) -> bool:
        """Is ``value`` physically possible (strictly inside the bounds)?"""
        return bool(self.low < value < self.high)


_PA = (("kPa", 1e3), ("MPa", 1e6), ("GPa", 1e9), ("mPa", 1e-3))
QUANTITY_LIMITS = {
    "youngs_modulus": QuantityLimit("Young's modulus", "Pa", 0.0, math.inf, ("Pa",),
                                    "a solid's stiffness is positive", _PA),
    "poisson_ratio": QuantityLimit("Poisson's ratio", "", 0.0, 0.5,
                                   ("", "1", "-", "dimensionless", "none"),
                                   "that of an isotropic solid; 0.5 would be perfectly "
                                   "incompressible, which elements cannot represent"),
    "viscosity": QuantityLimit("viscosity", "Pa s", 0.0, math.inf,
                               ("Pa s", "Pa·s", "Pa*s", "Pa.s", "Pas"),
                               "a material's viscosity is positive",
                               (("mPa s", 1e-3), ("mPa·s", 1e-3), ("cP", 1e-3),
                                ("kPa s", 1e3), ("P", 0.1))),
    "density": QuantityLimit("density", "kg/m^3", 0.0, math.inf,
                             ("kg/m^3", "kg/m3", "kg/m³", "kg m^-3", "kg*m^-3"),
                             "a mass density is positive",
                             (("g/cm^3", 1e3), ("g/cm3", 1e3), ("g/cm³", 1e3), ("g/ml", 1e3),
                              ("g/mL", 1e3), ("kg/l", 1e3), ("kg/L", 1e3))),
    "stiffness": QuantityLimit("spring stiffness", "N/m", 0.0, math.inf, ("N/m",),
                               "a spring's stiffness is positive", (("N/mm", 1e3),
                                                                     ("kN/m", 1e3))),
    "damping": QuantityLimit("spring damping", "N s/m", 0.0, math.inf,
                             ("N s/m", "N·s/m", "Ns/m", "N*s/m"),
                             "a spring's damping is positive", (("N s/mm", 1e3),)),
    "node_mass": QuantityLimit("node mass", "kg", 0.0, math.inf, ("kg",),
                               "a mass is positive", (("g", 1e-3), ("mg", 1e-6))),
    # Prony relaxation of elements (neurofuzzy.forces.relaxation): Σ g, of the long-term
    # modulus, and the relaxation time
    "relaxation_modulus": QuantityLimit("relaxation modulus", "", 0.0, math.inf,
                                        ("", "1", "-", "dimensionless", "none"),
                                        "the share of stiffness that relaxes away is not "
                                        "negative (of the long-term modulus)"),
    "relaxation_time": QuantityLimit("relaxation time", "s", 0.0, math.inf, ("s",),
                                     "a relaxation time is positive",
                                     (("ms", 1e-3), ("min", 60.0))),
    # Yeoh's C20/C10 of elements (neurofuzzy.forces.laws): how much the tissue stiffens
    "strain_stiffening": QuantityLimit("strain stiffening", "", 0.0, math.inf,
                                       ("", "1", "-", "dimensionless", "none"),
                                       "Yeoh's C20/C10 is not negative (a negative one "
                                       "softens with strain and loses stability)"),
}
#: a density universe that lies wholly below this is lighter than any tissue (kg/m³): the
#: values are in g/cm³, most likely
LIGHTEST_TISSUE = 100.0


def words_of(quantity: str | None) -> str:
    """A quantity in the user's words ("Young's modulus"), or the key itself."""
    limit = QUANTITY_LIMITS.get(quantity or "")
    return limit.words if limit else str(quantity)


def universe_problems(name: str, quantity: str | None, low: float, high: float,
                      unit: str) -> list[str]:
    """Why the universe ``[low, high]`` (in ``unit``) of output ``name`` cannot hold its
    quantity; empty when it can."""
    limit = QUANTITY_LIMITS.get(quantity or "")
    if limit is None:
        return []
    problems = []
    unit = unit.strip()
    if unit and unit not in limit.units:
        factor = dict(limit.other_units).get(unit)
        fix = (f"; write the universe and the terms in {limit.unit} (1 {unit} = {factor:g} "
               f"{limit.unit})" if factor is not None else
               f"; neurofuzzy reads {limit.words} in {limit.unit or 'no unit (a ratio)'}")
        problems.append(f"{name}: unit {unit!r} is not the unit of {limit.words}"
                        f" ({limit.unit or 'a ratio, no unit'}){fix}")
    if low < limit.low or high > limit.high:
        span = ("positive values" if math.isinf(limit.high)
                else f"{limit.low:g} to {limit.high:g}")
        problems.append(f"{name}: the universe [{low:g}, {high:g}] goes beyond what "
                        f"{limit.words} can be ({span}: {limit.why})")
    elif quantity == "density" and high < LIGHTEST_TISSUE:
        problems.append(f"{name}: a density universe of [{low:g}, {high:g}] kg/m^3 is lighter "
                        "than air-filled lung; were the values written in g/cm^3? Write them "
                        "in kg/m^3 (1 g/cm^3 = 1000 kg/m^3)")
    return problems


def _range(limit: QuantityLimit) -> str:
    if math.isinf(limit.high):
        return f"above {limit.low:g}" + (f" {limit.unit}" if limit.unit else "")
    return f"strictly between {limit.low:g} and {limit.high:g}"


def term_problem(variable, kind: str, params) -> str | None:
    """Why a membership function of an output is placed where its quantity cannot be."""
    limit = QUANTITY_LIMITS.get(variable.quantity or "")
    if limit is None or kind not in MEMBERSHIP_FUNCTIONS:
        return None
    indices = MEMBERSHIP_FUNCTIONS[kind][1]
    try:
        positions = ([float(p[0]) for p in params] if kind == "points"
                     else [float(params[i]) for i in indices])
    except (TypeError, ValueError, IndexError, KeyError):
        return None                       # the parameter check reports the form
    outside = [p for p in positions if p < limit.low or p > limit.high]
    if outside:
        return (f"{limit.words} at {outside[0]:g} is impossible: it must lie "
                f"{_range(limit)} ({limit.why})")
    return None


def defuzzification_problems(rules_outputs: dict, rules: list, method: str) -> list[tuple]:
    """``(line, message)`` for each rule whose consequent lets ``method`` defuzzify an output
    onto a bound its quantity excludes (ν = 0.5 or 0, E = 0, …).

    ``som`` / ``lom`` return the smallest / largest point where the aggregated set is
    highest: a consequent that is positive at the universe's bound can put that bound there.
    ``mom`` returns the middle of the highest points: a consequent whose only maximum is at
    the bound can. Centroid and bisector stay inside (a set of positive area).
    """
    if method not in ("som", "lom", "mom"):
        return []
    problems, seen = [], set()
    for rule in rules:
        for clause in rule.consequents:
            variable = rules_outputs.get(clause.variable)
            if variable is None or variable.quantity not in QUANTITY_LIMITS:
                continue
            limit = QUANTITY_LIMITS[variable.quantity]
            term = variable.terms.get(clause.phrase.term)
            if term is None:
                continue
            shape = apply_hedges(term.values, clause.phrase.hedges)
            peak = shape.max()
            for index, bound in ((0, variable.low), (-1, variable.high)):
                if limit.contains(bound) or (clause.variable, bound) in seen:
                    continue
                at_bound = shape[index] > 1e-9
                reaches = ((method == "lom" and index == -1 and at_bound)
                           or (method == "som" and index == 0 and at_bound)
                           or (method == "mom" and np.all(
                               np.flatnonzero(shape >= peak - 1e-12) == (
                                   len(shape) - 1 if index == -1 else 0))))
                if reaches:
                    seen.add((clause.variable, bound))
                    problems.append((rule.line, (
                        f"defuzzification {method} can give {limit.words} = {bound:g} "
                        f"exactly where '{clause.variable} is {clause.phrase}' decides "
                        f"(its term {clause.phrase.term!r}, {variable.source}:{term.line}, "
                        f"reaches the universe's bound {bound:g}); {limit.words} must lie "
                        f"{_range(limit)}: use defuzzification centroid or bisector, or "
                        "end the term before the bound")))
    return problems


def shared_quantities(outputs: dict, source: str) -> list[tuple[int, str, list[str]]]:
    """``(line, message, names)`` for each quantity two outputs stand for (which one sets it
    would be arbitrary), reported at the output the file ``source`` defines."""
    by_quantity: dict[str, list] = {}
    for variable in outputs.values():
        if variable.quantity is not None:
            by_quantity.setdefault(variable.quantity, []).append(variable)
    problems = []
    for quantity, variables in by_quantity.items():
        if len(variables) < 2:
            continue
        mine = [v for v in variables if v.source == source] or variables
        first = [v for v in variables if v is not mine[-1]][0]
        where = (f"line {first.line}" if first.source == source
                 else f"{first.source}:{first.line}")
        hint = (f" (name it {first.name!r} to replace the one of {first.source})"
                if first.source != source else "")
        problems.append((mine[-1].line, f"outputs {first.name!r} ({where}) and "
                         f"{mine[-1].name!r} both stand for {quantity} ({words_of(quantity)}): "
                         f"which one sets it would be arbitrary; keep one{hint}",
                         [v.name for v in variables]))
    return problems


def tissue_problems(rules) -> list[InputError]:
    """One problem for every tissue whose inferred values its quantities exclude (at the
    tissue's FILE:LINE); tissues no rule fires for are left to their use."""
    names = list(rules.tissues)
    if not names:
        return []
    values = rules.infer([rules.tissues[name] for name in names])
    problems = []
    for index, name in enumerate(names):
        try:
            check_inferred(rules, name, {output: float(column[index])
                                         for output, column in values.items()
                                         if np.isfinite(column[index])})
        except InputError as problem:
            problems.append(problem)
    return problems


def check_inferred(rules, tissue: str, values: dict) -> None:
    """Refuse a tissue whose inferred values its quantities exclude (naming the rule file,
    the tissue's line and the quantity in words)."""
    for name, value in values.items():
        variable = rules.outputs.get(name)
        limit = QUANTITY_LIMITS.get(getattr(variable, "quantity", None) or "")
        if limit is None or limit.contains(value):
            continue
        unit = f" {limit.unit}" if limit.unit else ""
        source, line = getattr(rules, "tissue_lines", {}).get(tissue, (rules.source, None))
        raise InputError(f"tissue {tissue!r}: its words give {limit.words} = {value:g}{unit} "
                         f"(output {name!r}), which is impossible: it must lie "
                         f"{_range(limit)} ({limit.why}); change the output's terms or the "
                         "defuzzification", source=source, line=line)


def unknown_tissue(rules, tissue: str) -> InputError:
    """The error for a tissue the rule base lacks, with a "did you mean"."""
    hint = closest_name(tissue, rules.tissues)
    return InputError(f"no tissue {tissue!r}" + (f"; did you mean {hint!r}?" if hint else
                                                 f"; tissues: {sorted(rules.tissues)}"),
                      source=rules.source, key="tissue")
