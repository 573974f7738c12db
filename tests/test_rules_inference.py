"""Inference: words in, values out (vectorised, as skfuzzy.control), membership functions."""

from pathlib import Path

import numpy as np
import pytest

from neurofuzzy.rules import load_rules
from neurofuzzy.rules.membership import HEDGES, apply_hedges, evaluate

ROOT = Path(__file__).resolve().parents[1]
RULES = ROOT / "rules"
SHIPPED = sorted(RULES.glob("*.yaml"))


def test_words_are_ordered_in_stiffness():
    rules = load_rules(RULES / "soft_tissue.yaml")
    words = ["very soft", "soft", "firm", "hard", "stony"]
    stiffness = rules.infer([{"consistency": w} for w in words])["youngs_modulus"]
    assert np.all(np.diff(stiffness) > 0), dict(zip(words, stiffness))
    soft, not_soft = rules.infer([{"consistency": "soft"}, {"consistency": "not soft"}])["youngs_modulus"]
    assert not_soft > soft


def test_vectorised_inference_matches_skfuzzy_control():
    pytest.importorskip("networkx")
    from neurofuzzy.rules.skfuzzy_control import control_infer

    rules = load_rules(RULES / "soft_tissue.yaml")
    rng = np.random.default_rng(0)
    inputs = [dict(zip(rules.inputs, x)) for x in rng.uniform(0.5, 9.5, (40, len(rules.inputs)))]
    ours = rules.infer(inputs)
    theirs = control_infer(rules, inputs)
    for name in rules.outputs:
        assert np.allclose(ours[name], theirs[name], rtol=1e-3), name


def test_membership_functions_and_hedges_stay_in_unit_interval(rng):
    grid = np.linspace(-5, 15, 801)
    specs = [("trimf", [0, 3, 7]), ("trapmf", [1, 2, 4, 9]), ("gaussmf", [4, 1.5]),
             ("gbellmf", [2, 3, 5]), ("sigmf", [5, -2]), ("points", [[0, 0], [2, 1], [9, 0.3]])]
    for kind, params in specs:
        mu = evaluate(kind, params, grid, lambda x: np.asarray(x, float))
        assert mu.min() >= 0 and mu.max() <= 1 and mu.max() > 0.5, kind
        for hedges in (["very"], ["not"], ["somewhat", "very"], list(HEDGES)):
            hedged = apply_hedges(mu, hedges)
            assert hedged.min() >= 0 and hedged.max() <= 1
        assert np.all(apply_hedges(mu, ["very"]) <= mu + 1e-15)
        assert np.all(apply_hedges(mu, ["somewhat"]) >= mu - 1e-15)
