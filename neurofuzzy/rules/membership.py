"""Membership functions (scikit-fuzzy) and linguistic hedges.

A term is written as one membership function by its scikit-fuzzy name and parameters::

    soft: {trimf: [0, 2.5, 5]}
    firm: {gaussmf: [5, 1.2]}              # mean, sigma
    hard: {trapmf: [5, 7.5, 10, 10]}
    wet:  {gbellmf: [2, 4, 5]}             # width a, slope b, centre c
    tall: {sigmf: [6, 2]}                  # centre b, slope c
    odd:  {points: [[0, 0], [2, 1], [4, 0]]}   # piecewise linear (x, membership)

On a logarithmic universe, positions are given in the variable's physical units and evaluated
on ``log10`` of the value; widths (``gaussmf`` sigma, ``gbellmf`` a) and ``sigmf`` slopes are per
decade.

Hedges modify a term: ``very`` (μ², concentration), ``extremely`` (μ³), ``somewhat`` and
``more or less`` (μ^½, dilation), ``not`` (1 - μ). They may be stacked ("not very soft").
"""

from __future__ import annotations

import numpy as np
import skfuzzy as fuzz

__all__ = ["MEMBERSHIP_FUNCTIONS", "HEDGES", "evaluate", "check_parameters", "apply_hedges"]

#: name → (number of parameters or None for points, positional parameter indices, meaning)
MEMBERSHIP_FUNCTIONS = {
    "trimf": (3, (0, 1, 2), "a <= b <= c (feet and peak)"),
    "trapmf": (4, (0, 1, 2, 3), "a <= b <= c <= d (feet and shoulders)"),
    "gaussmf": (2, (0,), "mean, sigma > 0"),
    "gbellmf": (3, (2,), "width a > 0, slope b > 0, centre c"),
    "sigmf": (2, (0,), "centre b, slope c != 0"),
    "points": (None, (), "[[x, membership], ...] with increasing x and memberships in [0, 1]"),
}

HEDGES = {
    "very": lambda mu: mu**2,
    "extremely": lambda mu: mu**3,
    "somewhat": np.sqrt,
    "more_or_less": np.sqrt,
    "not": lambda mu: 1.0 - mu,
}


def check_parameters(kind: str, params) -> str | None:
    """Why ``params`` are impossible for membership function ``kind`` (None when fine)."""
    if kind not in MEMBERSHIP_FUNCTIONS:
        return None
    count, _, meaning = MEMBERSHIP_FUNCTIONS[kind]
    if kind == "points":
        try:
            points = np.asarray(params, dtype=float)
        except (TypeError, ValueError):
            return f"points must be [[x, membership], ...]; {meaning}"
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
            return f"points must be at least two [x, membership] pairs; {meaning}"
        if np.any(np.diff(points[:, 0]) <= 0) or np.any((points[:, 1] < 0) | (points[:, 1] > 1)):
            return f"bad points {points.tolist()}: {meaning}"
        return None
    try:
        values = np.asarray(params, dtype=float).ravel()
    except (TypeError, ValueError):
        return f"{kind} takes {count} numbers ({meaning}), got {params!r}"
    if values.size != count or not np.all(np.isfinite(values)):
        return f"{kind} takes {count} finite numbers ({meaning}), got {params!r}"
    if kind in ("trimf", "trapmf") and np.any(np.diff(values) < 0):
        return f"{kind} needs {meaning}; got {values.tolist()}"
    if kind == "gaussmf" and values[1] <= 0:
        return f"gaussmf needs sigma > 0; got {values[1]}"
    if kind == "gbellmf" and (values[0] <= 0 or values[1] <= 0):
        return f"gbellmf needs a > 0 and b > 0; got {values.tolist()}"
    if kind == "sigmf" and values[1] == 0:
        return "sigmf needs a slope c != 0"
    return None


def evaluate(kind: str, params, grid: np.ndarray, transform) -> np.ndarray:
    """Membership of every grid point (in internal coordinates); ``transform`` maps physical
    positions to internal coordinates (identity or log10)."""
    if kind == "points":
        points = np.asarray(params, dtype=float)
        return np.interp(grid, transform(points[:, 0]), points[:, 1])
    values = np.asarray(params, dtype=float).ravel().copy()
    positions = list(MEMBERSHIP_FUNCTIONS[kind][1])
    values[positions] = transform(values[positions])
    if kind == "trimf":
        return _trimf(grid, values)
    if kind == "trapmf":
        return _trapmf(grid, values)
    return np.asarray(getattr(fuzz, kind)(grid, *values), dtype=float)


def _trimf(grid, abc):
    """skfuzzy.trimf, tolerant of a == b or b == c (shoulders at the universe's end)."""
    a, b, c = abc
    if a < b < c:
        return np.asarray(fuzz.trimf(grid, [a, b, c]), dtype=float)
    return _trapmf(grid, [a, b, b, c])


def _trapmf(grid, abcd):
    a, b, c, d = abcd
    rising = np.where(grid < b, (grid - a) / (b - a) if b > a else 1.0, 1.0)
    falling = np.where(grid > c, (d - grid) / (d - c) if d > c else 1.0, 1.0)
    return np.clip(np.minimum(rising, falling), 0.0, 1.0) * ((grid >= a) & (grid <= d))


def apply_hedges(mu: np.ndarray, hedges) -> np.ndarray:
    """Apply hedges, innermost (closest to the term) first."""
    for hedge in reversed(list(hedges)):
        mu = HEDGES[hedge](mu)
    return mu
