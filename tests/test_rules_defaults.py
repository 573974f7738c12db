"""An input a tissue does not describe takes the rule base's ``default:`` for it, or, without
one, the rules about it do not fire (issue 50: undescribed inputs fired every term at full
strength, so the liver was "holds", "relaxes" and "relaxes much" at once)."""

import json
import textwrap

import numpy as np
import pytest
from helpers import FIRM, cli, soft_tissue_rules

from neurofuzzy.errors import InputError
from neurofuzzy.rules import load_rules

SMALL = textwrap.dedent("""\
    name: small
    inputs:
      consistency:
        universe: [0, 10]
        terms: {soft: {trimf: [0, 0, 5]}, hard: {trimf: [5, 10, 10]}}
      relaxation:
        universe: [0, 10]
        {default}terms: {holds: {trimf: [0, 0, 5]}, relaxes: {trimf: [0, 5, 10]}, much: {trimf: [5, 10, 10]}}
    outputs:
      youngs_modulus:
        universe: {min: 100, max: 100000, scale: log, unit: Pa}
        terms: {soft: {trimf: [100, 1000, 10000]}, hard: {trimf: [1000, 10000, 100000]}}
      relaxation_modulus:
        universe: {min: 0.01, max: 5, scale: log}
        terms: {little: {trimf: [0.01, 0.05, 0.2]}, moderate: {trimf: [0.1, 0.5, 2]}, much: {trimf: [0.6, 2, 5]}}
    rules:
      - {if: consistency is soft, then: youngs_modulus is soft}
      - {if: consistency is hard, then: youngs_modulus is hard}
      - {if: relaxation is holds, then: relaxation_modulus is little}
      - {if: relaxation is relaxes, then: relaxation_modulus is moderate}
      - {if: relaxation is much, then: relaxation_modulus is much}
    tissues:
      plain: {consistency: soft}
      said: {consistency: soft, relaxation: relaxes}
    """)


def small(tmp_path, default=""):
    path = tmp_path / "small.yaml"
    path.write_text(SMALL.replace("{default}", f"default: {default}\n    " if default else ""))
    return path


def test_an_undescribed_input_takes_its_default(tmp_path):
    rules = load_rules(small(tmp_path, "relaxes"))
    assert str(rules.inputs["relaxation"].default) == "relaxes"
    assert rules.tissue("plain") == rules.tissue("said")
    strengths = dict(zip((r.text for r in rules.rules),
                         rules.rule_strengths([rules.tissues["plain"]])[:, 0]))
    assert strengths["if relaxation is relaxes then relaxation_modulus is moderate"] == 1.0
    assert strengths["if relaxation is holds then relaxation_modulus is little"] < 0.5
    assert {k: str(v) for k, v in rules.defaults_taken(rules.tissues["plain"]).items()} == \
        {"relaxation": "relaxes"}
    assert rules.defaults_taken(rules.tissues["said"]) == {}


def test_without_a_default_its_rules_do_not_fire(tmp_path):
    """Not every term at once: the rules about the left-out input stay silent, an output only
    they decide is NaN in infer, and the tissue is refused with the input named."""
    rules = load_rules(small(tmp_path))
    assert rules.inputs["relaxation"].default is None
    strengths = rules.rule_strengths([rules.tissues["plain"]])[:, 0]
    assert list(strengths[2:]) == [0.0, 0.0, 0.0] and strengths[0] == 1.0
    values = rules.infer([rules.tissues["plain"]])
    assert np.isnan(values["relaxation_modulus"][0]) and values["youngs_modulus"][0] > 0
    with pytest.raises(InputError, match="it does not describe relaxation, which has no "
                                         "default; describe it .* or give the input a default"):
        rules.tissue("plain")
    assert rules.tissue("said")["relaxation_modulus"] > 0
    shown = cli("rules", "show", tmp_path / "small.yaml", "--tissue", "plain")
    assert shown.returncode == 2 and "does not describe relaxation" in shown.stderr
    assert "Traceback" not in shown.stderr


@pytest.mark.parametrize("default, problem", [
    ("relaxs", "relaxation: default: relaxation has no term 'relaxs'; did you mean "
               "'relaxes'?"),
    ("vrey much", "unknown hedge 'vrey'; did you mean 'very'?")])
def test_a_wrong_default_names_its_line(tmp_path, default, problem):
    path = small(tmp_path, default)
    line = 1 + path.read_text().splitlines().index(f"    default: {default}")
    with pytest.raises(InputError) as raised:
        load_rules(path)
    assert f"small.yaml:{line}:" in str(raised.value) and problem in str(raised.value)


def test_only_an_input_takes_a_default(tmp_path):
    path = small(tmp_path)
    text = path.read_text()
    path.write_text(text.replace("  relaxation_modulus:\n",
                                 "  relaxation_modulus:\n    default: little\n"))
    assert path.read_text() != text
    with pytest.raises(InputError, match="relaxation_modulus: only an input takes a default"):
        load_rules(path)


def test_the_shipped_liver_names_the_defaults_it_takes(tmp_path):
    """The liver describes four inputs; relaxation, its speed and stiffening are the shared
    vocabulary's defaults, which rules show prints and records."""
    shown = cli("rules", "show", "liver", "--tissue", "liver")
    assert shown.returncode == 0
    assert ("not described, so the rule base's defaults: relaxation is relaxes, "
            "relaxation_speed is moderately, stiffening is moderately") in shown.stdout
    record = json.loads(cli("rules", "show", "liver", "--tissue", "liver", "--json").stdout)
    assert record["defaults"] == {"relaxation": "relaxes", "relaxation_speed": "moderately",
                                  "stiffening": "moderately"}
    assert record["labels"]["relaxation_modulus"]["term"] == "moderate"


def test_a_tissue_silent_on_compressibility_starts_incompressible(tmp_path):
    """The default 'incompressible' decides ν, as the words would (ν >= 0.45 for elements)."""
    import neurofuzzy as nf
    from neurofuzzy.mesh import from_tetra, kuhn_block

    rules = soft_tissue_rules(tmp_path / "r.yaml", "r", {
        "silent": "consistency: firm", "said": FIRM})
    mesh = from_tetra(*kuhn_block((1, 1, 1), 0.01))
    nu = [nf.initialize(rules, mesh, tissue=t, elements=True).elements.poisson_ratio[0]
          for t in ("silent", "said")]
    assert nu[0] == pytest.approx(nu[1]) and nu[0] >= 0.45
