"""Fuzzy inference, vectorised over many descriptions: words in, output values out."""

from __future__ import annotations

import numpy as np
import skfuzzy as fuzz

from ..errors import InputError, closest_name
from .limits import check_inferred
from .membership import apply_hedges
from .terms import GRID_POINTS, Phrase, Variable, parse_phrase

__all__ = ["infer", "aggregate", "rule_strengths", "tissue_values", "tissue_sets",
           "undescribed"]


def infer(rules, descriptions: list[dict]) -> dict[str, np.ndarray]:
    """Output values for many descriptions at once (vectorised over descriptions).

    Parameters
    ----------
    descriptions : list of dict
        Each maps input variable names to words ("very soft"), :class:`Phrase` objects or
        crisp numbers. An input left out takes the rule base's ``default:`` for it; without
        one, the rules that use it do not fire (its clauses count as false), and an output
        that only such rules decide is NaN.

    Returns
    -------
    dict of output name → (n_descriptions,) float, in physical units.
    """
    return {name: rules.outputs[name].to_physical(
                _defuzzify(rules, rules.outputs[name], aggregated))
            for name, aggregated in aggregate(rules, descriptions).items()}


def aggregate(rules, descriptions: list[dict]) -> dict[str, np.ndarray]:
    """The inferred output fuzzy sets before defuzzification: for every output, the
    (n_descriptions, GRID_POINTS) maximum of every rule's consequent clipped at the rule's
    strength, on the output's grid (internal coordinates, :attr:`Variable.grid`)."""
    n = len(descriptions)
    strengths = rule_strengths(rules, descriptions)
    results = {}
    for name, variable in rules.outputs.items():
        aggregated = np.zeros((n, GRID_POINTS))
        for rule, strength in zip(rules.rules, strengths):
            for clause in rule.consequents:
                if clause.variable != name:
                    continue
                shape = apply_hedges(variable.terms[clause.phrase.term].values,
                                     clause.phrase.hedges)
                aggregated = np.maximum(aggregated,
                                        np.minimum(strength[:, None], shape[None, :]))
        results[name] = aggregated
    return results

def rule_strengths(rules, descriptions: list[dict]) -> np.ndarray:
    """How strongly every rule fires for every description.

    Parameters
    ----------
    descriptions : list of dict
        As :func:`infer`.

    Returns
    -------
    (n_rules, n_descriptions) float
        Each rule's firing strength in [0, 1], its weight included, in the order of
        ``rules.rules``: its clauses' degrees (:func:`_possibility`) combined by the rule
        base's ``and`` within a group and ``or`` between groups.
    """
    n = len(descriptions)
    sets = {}
    for name, variable in rules.inputs.items():
        phrases = [_phrase(rules, d.get(name), variable) for d in descriptions]
        sets[name] = _input_sets(variable, phrases)          # (n, G), (n,)
    strengths = np.zeros((len(rules.rules), n))
    for index, rule in enumerate(rules.rules):
        groups = []
        for group in rule.antecedent:
            degrees = [_possibility(sets[c.variable], rules.inputs[c.variable], c.phrase, n)
                       for c in group]
            groups.append(_combine(degrees, rules.and_method))
        strengths[index] = _combine(groups, rules.or_method, is_or=True) * rule.weight
    return strengths


def _phrase(rules, value, variable: Variable) -> Phrase | None:
    if value is None:
        return variable.default                 # None: not described, and no default
    if isinstance(value, Phrase):
        return value
    if isinstance(value, (int, float, np.floating, np.integer)):
        if not variable.low <= value <= variable.high:      # also NaN; never clamped
            raise InputError(f"{float(value):g} is outside the universe [{variable.low:g}, "
                             f"{variable.high:g}]; give a value in it, or words",
                             source=rules.source, key=variable.name)
        return Phrase((), None, float(value))
    phrase, problem = parse_phrase(str(value), variable)
    if problem:
        raise InputError(problem, source=rules.source, key=variable.name)
    return phrase

def _input_sets(variable, phrases):
    """``(sets (n, G), crisp (n,) internal values, NaN where fuzzy)``; an input that is not
    described is the empty set (no clause about it holds)."""
    crisp = np.full(len(phrases), np.nan)
    out = np.zeros((len(phrases), GRID_POINTS))
    for i, phrase in enumerate(phrases):
        if phrase is None:
            continue
        if phrase.term is None:
            crisp[i] = variable.to_internal(phrase.value)
        else:
            out[i] = apply_hedges(variable.terms[phrase.term].values, phrase.hedges)
    return out, crisp

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
    union = np.maximum(sets, clause[None, :]).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        degree = np.where(union > 0, np.minimum(sets, clause[None, :]).sum(axis=1) / union,
                          0.0)
    is_crisp = np.isfinite(crisp)
    if is_crisp.any():
        degree[is_crisp] = np.interp(crisp[is_crisp], variable.grid, clause)
    return degree

def _defuzzify(rules, variable, aggregated):
    grid = variable.grid
    total = aggregated.sum(axis=1)
    if np.any(total <= 0):     # no rule fired: NaN for those rows
        return np.where(total > 0, _centroid(grid, aggregated), np.nan)
    if rules.defuzzification == "centroid":
        return _centroid(grid, aggregated)
    return np.array([fuzz.defuzz(grid, row, rules.defuzzification) for row in aggregated])


def tissue_values(rules, name: str) -> dict[str, float]:
    """Inferred output values (physical units) of a tissue of the rule base."""
    if name not in rules.tissues:
        hint = closest_name(name, rules.tissues)
        raise InputError(f"no tissue {name!r}" + (f"; did you mean {hint!r}?" if hint else
                                                  f"; tissues: {sorted(rules.tissues)}"),
                         source=rules.source, key="tissue")
    values = infer(rules, [rules.tissues[name]])
    missing = [k for k, v in values.items() if not np.isfinite(v[0])]
    if missing:
        silent = undescribed(rules, rules.tissues[name], missing)
        raise InputError(f"no rule fires for tissue {name!r} on {missing}" + (
            f": it does not describe {' or '.join(silent)}, which has no default; describe "
            f"it (e.g. {silent[0]}: {next(iter(rules.inputs[silent[0]].terms))}) or give "
            f"the input a default (default: WORDS)" if silent else "; add a rule"),
            source=rules.source, key="tissues")
    values = {k: float(v[0]) for k, v in values.items()}
    check_inferred(rules, name, values)
    return values


def undescribed(rules, description: dict, outputs=None) -> list[str]:
    """The inputs a description leaves out that have no default (whose rules do not fire),
    among those the rules about ``outputs`` (default: every output) use."""
    used = rules.deciding(rules.outputs if outputs is None else outputs)
    return [name for name, variable in rules.inputs.items()
            if name in used and description.get(name) is None and variable.default is None]


def tissue_sets(rules, name: str) -> dict[str, np.ndarray]:
    """The inferred output fuzzy sets of a tissue (the expert's description before
    defuzzification): output name → (GRID_POINTS,) membership on the output's grid."""
    tissue_values(rules, name)             # the checks: a known tissue, rules that fire
    return {key: value[0] for key, value in aggregate(rules, [rules.tissues[name]]).items()}


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
