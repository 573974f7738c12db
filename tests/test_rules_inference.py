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


def test_rule_strengths_are_what_aggregation_clips_at():
    rules = load_rules(RULES / "liver.yaml")
    strengths = rules.rule_strengths([rules.tissues["liver"], {"consistency": "soft"}])
    assert strengths.shape == (len(rules.rules), 2)
    assert np.all((strengths >= 0) & (strengths <= 1))
    firm = next(i for i, r in enumerate(rules.rules) if r.text == "if consistency is firm then "
                "youngs_modulus is firm")
    assert strengths[firm, 0] == pytest.approx(1.0)
    assert strengths[firm, 1] < strengths[0, 1] == pytest.approx(1.0)     # rule 0: soft
    # the aggregated set of the output never rises above the strongest rule concluding on it
    aggregated = rules.tissue_sets("liver")["youngs_modulus"]
    on_modulus = [i for i, r in enumerate(rules.rules)
                  if any(c.variable == "youngs_modulus" for c in r.consequents)]
    assert aggregated.max() <= strengths[on_modulus, 0].max() + 1e-12
