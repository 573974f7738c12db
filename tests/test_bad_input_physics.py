"""The bad-input corpus, second round (issue 28): inputs that are well formed but physically
absurd. Each goes through the command line in-process and must exit 2 with one line naming
the file and line (or the option), with the fix, leaving nothing behind (``refused``); a value
that is possible but unusual is a warning on stderr and the command goes on."""

import re

import numpy as np
import pytest
from test_bad_input import refused

from neurofuzzy.cli import main
from neurofuzzy.errors import InputError
from neurofuzzy.rules import load_rules, shipped

SOFT = shipped("soft_tissue").read_text()
E_OUTPUT = "  youngs_modulus:\n    quantity: youngs_modulus\n"
EXTRA_E = ("  {name}:\n    quantity: youngs_modulus\n"
           "    universe: {{min: 100, max: 300000, scale: log, unit: Pa}}\n"
           "    terms: {{soft: {{trimf: [400, 1500, 4000]}}}}\n")


def _line_of(text, needle):
    return text[:text.index(needle)].count("\n") + 1


def _soft(old, new):
    assert old in SOFT
    return SOFT.replace(old, new)


# -- rule files: physical limits per quantity --------------------------------------------------
RULE_FILES = [
    ("poisson universe to 0.7", _soft("universe: [0, 0.5]", "universe: [0, 0.7]"),
     "universe: [0, 0.7]", "poisson_ratio: the universe [0, 0.7] goes beyond what Poisson's "
                           "ratio can be (0 to 0.5"),
    ("negative Young's modulus", _soft("universe: {min: 100, max: 300000, scale: log, unit: Pa}",
                                       "universe: [-1000, 300000]"),
     "universe: [-1000", "youngs_modulus: the universe [-1000, 300000] goes beyond what Young's "
                         "modulus can be (positive values"),
    ("lom reaches nu = 0.5", _soft("defuzzification: centroid", "defuzzification: lom"),
     "defuzzification: lom", "defuzzification lom can give Poisson's ratio = 0.5 exactly"),
    ("som reaches nu = 0", _soft("defuzzification: centroid", "defuzzification: som"),
     "defuzzification: som", "defuzzification som can give Poisson's ratio = 0 exactly"),
    ("a term beyond 0.5", _soft("[0.42, 0.47, 0.5, 0.5]", "[0.42, 0.47, 0.5, 0.6]"),
     "[0.42, 0.47, 0.5, 0.6]", "Poisson's ratio at 0.6 is impossible"),
    ("kPa read as Pa", _soft("max: 300000, scale: log, unit: Pa}", "max: 300000, scale: log, "
                                                                   "unit: kPa}"),
     "unit: kPa", "unit 'kPa' is not the unit of Young's modulus (Pa); write the universe and "
                  "the terms in Pa (1 kPa = 1000 Pa)"),
    ("density in g/cm3", _soft("universe: [850, 1200]", "universe: [0.85, 1.2]")
     .replace("[850, 850, 910, 1000]", "[0.85, 0.85, 0.91, 1]")
     .replace("[980, 1045, 1100]", "[0.98, 1.045, 1.1]")
     .replace("[1060, 1120, 1200, 1200]", "[1.06, 1.12, 1.2, 1.2]"),
     "universe: [0.85", "were the values written in g/cm^3?"),
    ("deprecated name beside the current one",
     _soft("  viscosity:\n    quantity: viscosity", EXTRA_E.format(name="stiffness")
           + "  viscosity:\n    quantity: viscosity"),
     "  stiffness:", "output 'stiffness' stands for youngs_modulus (its old name), and output "
                     "'youngs_modulus' (line"),
    ("two outputs of one quantity",
     _soft("  viscosity:\n    quantity: viscosity", EXTRA_E.format(name="E")
           + "  viscosity:\n    quantity: viscosity"),
     "  E:", "outputs 'youngs_modulus' (line"),
    ("unknown quantity", _soft("    quantity: density", "    quantity: densty"),
     "quantity: densty", "density: unknown quantity 'densty'; did you mean 'density'?"),
]


@pytest.mark.parametrize("text, at, words", [case[1:] for case in RULE_FILES],
                         ids=[case[0] for case in RULE_FILES])
def test_rule_files_beyond_physics_are_refused_with_one_root_error(tmp_path, capsys, text, at,
                                                                   words):
    path = tmp_path / "r.yaml"
    path.write_text(text)
    line = _line_of(text, at)
    message = refused(capsys, ["rules", "check", path], names=[f"{path}:{line}:", words],
                      folder=tmp_path, seconds=5)
    assert message.count("neurofuzzy: error") == 1


def test_a_broken_definition_is_reported_once_not_at_every_use(tmp_path):
    """An input whose universe is impossible is used by rules and every tissue: only its
    definition is reported; likewise a broken term."""
    for old, new, line in (("  consistency:                 # how hard it feels when pressed "
                            "(palpation), 0 = fluid, 10 = bone\n    universe: [0, 10]",
                            "  consistency:\n    universe: [10, 0]", "universe: [10, 0]"),
                           ("firm:  {trimf: [2, 4.5, 7]}", "firm:  {trimf: [7, 4.5, 2]}",
                            "firm:  {trimf: [7"),
                           ("[0.42, 0.47, 0.5, 0.5]", "[0.42, 0.47, 0.5, 0.9]", "0.5, 0.9]")):
        text = _soft(old, new)
        path = tmp_path / "r.yaml"
        path.write_text(text)
        with pytest.raises(InputError) as caught:
            load_rules(path)
        lines = str(caught.value).splitlines()
        assert lines == [lines[0]] and lines[0].startswith(f"{path}:{_line_of(text, line)}:"), \
            lines


def test_the_shipped_rule_bases_are_within_physics():
    for name in ("soft_tissue", "liver", "brain", "kidney", "muscle", "fat"):
        rules = load_rules(shipped(name))
        for tissue in rules.tissues:
            values = rules.tissue(tissue)
            assert 0 < values["poisson_ratio"] < 0.5 and values["youngs_modulus"] > 0


def test_an_impossible_inferred_value_names_the_file_the_tissue_and_its_line(tmp_path):
    """The safety net behind the file checks: a rule base whose tissue infers an impossible
    value (here by changing the defuzzification after loading) is refused at use, naming
    FILE:LINE of the tissue and the quantity in words."""
    rules = load_rules(shipped("liver"))
    rules.defuzzification = "lom"
    line = _line_of(shipped("liver").read_text(), "  liver: ")
    with pytest.raises(InputError, match=re.escape(f"{shipped('liver')}:{line}: tissue 'liver': "
                                                   "its words give Poisson's ratio = 0.5")):
        rules.tissue("liver")
