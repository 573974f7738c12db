"""Numbers back to words: the label of a value (:func:`describe`) and the input words that
best reproduce a set of values (:func:`explain`)."""

from __future__ import annotations

import itertools

import numpy as np

from ..errors import InputError
from .inference import infer
from .terms import Label, Phrase

__all__ = ["describe", "explain"]


def describe(rules, values: dict[str, float]) -> dict[str, Label]:
    """For every output value: the term with the highest membership and all degrees."""
    labels = {}
    for name, value in values.items():
        if name not in rules.outputs:
            raise InputError(f"no output variable {name!r}; outputs are "
                             f"{sorted(rules.outputs)}", source=rules.source)
        variable = rules.outputs[name]
        degrees = {t: float(variable.membership(t, value)) for t in variable.terms}
        best = max(degrees, key=degrees.get)
        labels[name] = Label(name, float(value), best, degrees[best], degrees)
    return labels


def explain(rules, values: dict[str, float], *, hedges=("very", "somewhat")) -> dict:
    """The combination of input words whose inferred outputs come closest to ``values``.

    Every combination of plain input terms is inferred at once (vectorised); the best one
    is then refined by trying the hedges on one input at a time. Distances are measured in
    internal coordinates (decades on log universes), relative to each universe's span.

    Returns ``{"words": {input: phrase}, "outputs": {...}, "distance": float}``.
    """
    names = list(rules.inputs)
    wanted = {k: v for k, v in values.items() if k in rules.outputs}
    if not wanted:
        raise InputError("no output values to explain", source=rules.source)

    def distance(results):
        total = 0.0
        for key, value in wanted.items():
            variable = rules.outputs[key]
            span = variable.to_internal(variable.high) - variable.to_internal(variable.low)
            diff = (variable.to_internal(results[key]) - variable.to_internal(value)) / span
            total = total + np.nan_to_num(diff, nan=10.0) ** 2
        return np.sqrt(total)

    combos = list(itertools.product(*[list(rules.inputs[n].terms) for n in names]))
    descriptions = [dict(zip(names, combo)) for combo in combos]
    scores = distance(infer(rules, descriptions))
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
        scores = distance(infer(rules, trials))
        index = int(np.argmin(scores))
        if scores[index] < best_score - 1e-9:
            best, best_score, improved = trials[index], float(scores[index]), True
    outputs = {k: float(v[0]) for k, v in infer(rules, [best]).items()}
    return {"words": {k: str(v) for k, v in best.items()}, "outputs": outputs,
            "distance": best_score}
