"""explain() agrees with the labels (issue 50: a fit labelled "hard 0.54" at 10.6 kPa was
explained as "consistency very hard", 19.1 kPa, and every input got a word, "relaxation
holds" for a fit that said nothing of relaxation)."""

import pytest

from neurofuzzy.rules import load_rules, shipped
from neurofuzzy.rules.words import HEDGE_GAIN


@pytest.fixture(scope="module")
def liver():
    return load_rules(shipped("liver"))


def test_a_hedge_only_when_it_is_materially_closer(liver):
    """Between firm (5.1 kPa) and hard (19.4 kPa), 'very hard' (19.1 kPa) is 2 % closer to
    10.6 kPa than 'hard': no reason to say 'very'. Far below 'soft' the hedge does help."""
    hard = liver.explain({"youngs_modulus": 10600.0})
    assert hard["words"] == {"consistency": "hard"}
    assert liver.describe({"youngs_modulus": 10600.0})["youngs_modulus"].term == "hard"
    very = liver.infer([{"consistency": "very hard"}])["youngs_modulus"][0]
    plain = hard["outputs"]["youngs_modulus"]
    assert abs(very - 10600.0) < abs(plain - 10600.0)       # closer, but not by HEDGE_GAIN
    soft = liver.explain({"youngs_modulus": 700.0})
    assert soft["words"]["consistency"].endswith("soft")
    assert 0 < HEDGE_GAIN < 0.5


def test_only_the_inputs_that_decide_the_values_get_words(liver):
    explained = liver.explain({"youngs_modulus": 5000.0, "viscosity": 2.0})
    assert set(explained["words"]) == {"consistency", "elasticity"}
    assert set(explained["outputs"]) == {"youngs_modulus", "viscosity"}
    assert explained["words"]["consistency"] == "firm"
