"""Reading rule files: the shipped ones pass, bad ones name FILE:LINE, old names still load."""

import re
import warnings
from pathlib import Path

import pytest
from helpers import cli

from neurofuzzy.rules import RuleBaseError, RuleFileDeprecationWarning, load_rules

ROOT = Path(__file__).resolve().parents[1]
RULES = ROOT / "rules"
SHIPPED = sorted(RULES.glob("*.yaml"))
DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_rule_base_passes_check(path):
    result = cli("rules", "check", path)
    assert result.returncode == 0, result.stderr
    assert "rules" in result.stdout and "tissues" in result.stdout


def test_shipped_rule_bases_cover_the_organs():
    tissues = {name for path in SHIPPED for name in load_rules(path).tissues}
    assert {"grey_matter", "white_matter", "ventricle_wall", "liver", "kidney", "muscle", "fat",
            "tumour"} <= tissues


def test_outputs_named_after_another_quantity_load_with_a_deprecation_note():
    old = DATA / "old_style_outputs.yaml"
    with pytest.warns(RuleFileDeprecationWarning,
                      match=re.escape(str(old)) + r":11: output 'stiffness' stands for "
                                                  r"youngs_modulus.*rename it"):
        rules = load_rules(old)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                        # the new form warns nothing
        new = load_rules(DATA / "new_style_outputs.yaml")
    assert list(rules.outputs) == list(new.outputs) == ["youngs_modulus"]
    for tissue in ("jelly", "gel"):
        assert rules.tissue(tissue) == pytest.approx(new.tissue(tissue), rel=1e-12)
    value = rules.tissue("gel")["youngs_modulus"]
    assert rules.describe({"stiffness": value}) == new.describe({"youngs_modulus": value})
    result = cli("rules", "check", old)
    assert result.returncode == 0 and "youngs_modulus" in result.stdout
    assert result.stderr.startswith(f"neurofuzzy: deprecated: {old}:11: output 'stiffness'")


# -- bad input: FILE:LINE: message, exit 2, all problems at once -------------------------------
BASE = """\
name: test
inputs:
  consistency:
    universe: [0, 10]
    terms:
      soft: {trimf: [0, 0, 5]}
      firm: {trimf: [2, 5, 8]}
outputs:
  youngs_modulus:
    quantity: youngs_modulus
    universe: {min: 100, max: 100000, scale: log, unit: Pa}
    terms:
      soft: {trimf: [100, 1000, 5000]}
      firm: {trimf: [1000, 5000, 20000]}
rules:
  - if: consistency is soft
    then: youngs_modulus is soft
  - if: consistency is firm
    then: youngs_modulus is firm
tissues:
  jelly: {consistency: very soft}
"""

BAD = [
    ("malformed YAML", ("      firm: {trimf: [2, 5, 8]}", "      firm: {trimf: [2, 5, 8]"),
     r":8: malformed YAML"),
    ("unknown term in a tissue", ("{consistency: very soft}", "{consistency: very sotf}"),
     r":21: tissue 'jelly': consistency has no term 'sotf'; did you mean 'soft'\?"),
    ("unknown variable in a tissue", ("{consistency: very soft}", "{consistancy: soft}"),
     r":21: tissue 'jelly': unknown input 'consistancy'; did you mean 'consistency'\?"),
    ("misspelt hedge", ("if: consistency is soft", "if: consistency is vrey soft"),
     r":16: unknown hedge 'vrey'; did you mean 'very'\?"),
    ("impossible parameters", ("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [5, 2, 8]}"),
     r":7: consistency.firm: trimf needs a <= b <= c"),
    ("zero over the universe", ("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [20, 25, 30]}"),
     r":7: consistency.firm: the term is zero over the whole universe"),
    ("undefined variable in a rule", ("if: consistency is firm", "if: hardness is firm"),
     r":18: rule names undefined input variable 'hardness'"),
    ("unknown membership function", ("soft: {trimf: [0, 0, 5]}", "soft: {trimff: [0, 0, 5]}"),
     r":6: consistency.soft: unknown membership function 'trimff'; did you mean 'trimf'\?"),
]


@pytest.mark.parametrize("what, change, message", BAD, ids=[b[0] for b in BAD])
def test_bad_rule_files_name_file_and_line(tmp_path, what, change, message):
    path = tmp_path / "bad.yaml"
    text = BASE.replace(*change)
    assert text != BASE
    path.write_text(text)
    with pytest.raises(Exception) as caught:
        load_rules(path)
    assert caught.type.__name__ in ("RuleBaseError", "InputError")
    assert re.search(re.escape(str(path)) + message, str(caught.value)), str(caught.value)
    result = cli("rules", "check", path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert re.search(message, result.stderr)
    assert path.read_text() == text                       # never written over


def test_all_problems_are_reported_at_once(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(BASE.replace("if: consistency is soft", "if: consistency is vrey soft")
                    .replace("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [5, 2, 8]}")
                    .replace("{consistency: very soft}", "{consistency: very sotf}"))
    with pytest.raises(RuleBaseError) as caught:
        load_rules(path)
    lines = [str(p) for p in caught.value.problems]
    assert len(lines) >= 3
    assert any(":7:" in l for l in lines) and any(":16:" in l for l in lines) \
        and any(":21:" in l for l in lines)


def test_unsaved_text_is_read_in_place_of_the_file(tmp_path):
    """load_rules(path, text=...) checks an editor's text as if written to path: its lines,
    its name in messages, extends: from path's folder; the file on disk is not read."""
    (tmp_path / "soft_tissue.yaml").write_text((RULES / "soft_tissue.yaml").read_text())
    path = tmp_path / "liver.yaml"
    path.write_text("not: a rule base\n")
    text = (RULES / "liver.yaml").read_text()
    assert set(load_rules(path, text=text).tissues) == {"liver", "fibrotic_liver", "tumour"}
    broken = text.replace("consistency: hard", "consistency: hrad")
    with pytest.raises(RuleBaseError) as error:
        load_rules(path, text=broken)
    (problem,) = error.value.problems
    assert problem.source == str(path) and problem.line == 6
    assert "did you mean 'hard'" in str(problem)
