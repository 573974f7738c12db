"""Numbers back to words: the label of a value (:func:`describe`) and the input words that
best reproduce a set of values (:func:`explain`)."""

from __future__ import annotations

import itertools

import numpy as np

from ..errors import InputError
from .inference import infer
from .terms import Label, Phrase

__all__ = ["describe", "explain", "HEDGE_GAIN"]


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


#: a hedge is suggested only when it brings the outputs this much closer (relative to the
#: plain words' distance): "very hard" at 19.1 kPa is not a better word than "hard" at
#: 19.4 kPa for 10.6 kPa, though 2 % closer
HEDGE_GAIN = 0.1


def explain(rules, values: dict[str, float], *, hedges=("very", "somewhat")) -> dict:
    """The combination of input words whose inferred outputs come closest to ``values``.

    Only the inputs that decide one of the outputs in ``values`` are explained (the others
    say nothing about them, and are left out of ``words``). Every combination of their plain
    terms is inferred at once (vectorised); the best one is then refined by trying the
    hedges on one input at a time, a hedge kept only when it brings the outputs at least
    :data:`HEDGE_GAIN` of the way closer. Distances are measured in internal coordinates
    (decades on log universes), relative to each universe's span.

    Returns ``{"words": {input: phrase}, "outputs": {output: value}, "distance": float}``,
    ``outputs`` the inferred values of the outputs in ``values``.
    """
    wanted = {k: v for k, v in values.items() if k in rules.outputs}
    if not wanted:
        raise InputError("no output values to explain", source=rules.source)
    deciding = rules.deciding(wanted)
    names = [name for name in rules.inputs if name in deciding]

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
        if scores[index] < (1.0 - HEDGE_GAIN) * best_score:
            best, best_score, improved = trials[index], float(scores[index]), True
    outputs = {k: float(v[0]) for k, v in infer(rules, [best]).items() if k in wanted}
    return {"words": {k: str(v) for k, v in best.items()}, "outputs": outputs,
            "distance": best_score}
