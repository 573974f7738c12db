"""The rule studio's document: edits that keep every other byte of the file, checks with the
lines of `rules check`, undo, and saves that are atomic, valid and only where allowed."""

import difflib
import shutil
from pathlib import Path

import pytest
from helpers import cli

from neurofuzzy.errors import InputError
from neurofuzzy.rules import load_rules
from neurofuzzy.rulestudio.document import RuleDocument, inside
from neurofuzzy.rulestudio.edits import EditError
from neurofuzzy.rulestudio.yamltext import YamlText, flow, format_number

RULES = Path(__file__).resolve().parents[1] / "rules"


@pytest.fixture
def liver(tmp_path):
    for name in ("liver.yaml", "soft_tissue.yaml"):
        shutil.copy(RULES / name, tmp_path / name)
    return tmp_path / "liver.yaml"


@pytest.fixture
def soft(tmp_path):
    shutil.copy(RULES / "soft_tissue.yaml", tmp_path / "soft_tissue.yaml")
    return tmp_path / "soft_tissue.yaml"


def changed_lines(before: str, after: str):
    """(removed, added) lines of a diff."""
    diff = list(difflib.ndiff(before.splitlines(), after.splitlines()))
    return ([line[2:] for line in diff if line.startswith("- ")],
            [line[2:] for line in diff if line.startswith("+ ")])


@pytest.mark.parametrize("value, text", [(0, "0"), (2.5, "2.5"), (15000.0, "15000"),
                                         (1e-5, "1.0e-5"), (3e20, "3.0e+20"), (-2, "-2"),
                                         (1 / 3, "0.333333")])
def test_numbers_read_back_as_the_same_number(value, text):
    import yaml

    assert format_number(value) == text
    assert yaml.safe_load(f"x: {text}")["x"] == pytest.approx(value, rel=1e-6)


def test_words_that_yaml_would_read_otherwise_are_quoted():
    assert flow("very soft") == "very soft"
    assert flow("yes") == '"yes"' and flow("a: b") == '"a: b"' and flow("x, y") == '"x, y"'
    assert flow({"trimf": [1, 2.5, 3]}) == "{trimf: [1, 2.5, 3]}"


def test_changing_one_breakpoint_changes_one_number_and_keeps_the_alignment(soft):
    document = RuleDocument(soft)
    original = document.text
    document.apply({"op": "set_term", "role": "input", "variable": "consistency",
                    "term": "firm", "kind": "trimf", "params": [2, 4, 7]})
    removed, added = changed_lines(original, document.text)
    assert removed == ["      firm:  {trimf: [2, 4.5, 7]}"]
    assert added == ["      firm:  {trimf: [2, 4, 7]}"]
    assert document.check().rules.inputs["consistency"].terms["firm"].params == [2, 4, 7]


def test_an_inherited_variable_is_copied_in_with_its_comments(liver):
    document = RuleDocument(liver)
    original = document.text
    document.apply({"op": "set_term", "role": "output", "variable": "youngs_modulus",
                    "term": "firm", "kind": "trimf", "params": [1500, 4000, 15000]})
    removed, added = changed_lines(original, document.text)
    assert removed == []
    assert added[0] == "outputs:" and added[1] == "  youngs_modulus:"
    assert any("Yin et al. 2007" in line and "[1500, 4000, 15000]" in line for line in added)
    rules = document.check().rules
    assert rules.outputs["youngs_modulus"].terms["firm"].params == [1500, 4000, 15000]
    assert rules.tissue("liver")["youngs_modulus"] < load_rules(liver).tissue(
        "liver")["youngs_modulus"]
    # the file extended is never touched
    assert (liver.parent / "soft_tissue.yaml").read_text() == (RULES / "soft_tissue.yaml") \
        .read_text()


def test_problems_carry_the_line_they_will_have_in_the_file(liver):
    document = RuleDocument(liver)
    document.apply({"op": "set_tissue", "tissue": "fibrotic_liver", "variable": "consistency",
                    "words": "very hrad"})
    (problem,) = document.check().problems
    line = document.text.splitlines()[problem["line"] - 1]
    assert "very hrad" in line and line.lstrip().startswith("fibrotic_liver:")
    liver.write_text(document.text)                     # the same message as rules check
    result = cli("rules", "check", liver)
    assert result.returncode == 2 and problem["text"] in result.stderr


def test_rules_as_sentences_with_weights_and_their_errors(soft):
    document = RuleDocument(soft)
    document.apply({"op": "add_rule", "text": "if consistency is very soft then "
                    "youngs_modulus is very_soft", "weight": 0.5})
    rules = document.check().rules
    assert rules.rules[-1].text == ("if consistency is very soft then youngs_modulus is "
                                    "very_soft") and rules.rules[-1].weight == 0.5
    index = len(rules.rules) - 1
    document.apply({"op": "set_rule", "index": index, "text": "if consistency is sofft then "
                    "youngs_modulus is very_soft", "weight": None})
    (problem,) = document.check().problems
    assert "did you mean 'soft'" in problem["message"]
    assert document.text.splitlines()[problem["line"] - 1].strip() == \
        "- if: consistency is sofft"
    assert "weight" not in document.text.split("sofft")[1]
    with pytest.raises(EditError, match="if CONDITION then CONCLUSION") as error:
        document.apply({"op": "set_rule", "index": index, "text": "consistency is soft"})
    assert error.value.line == problem["line"]
    document.apply({"op": "delete_rule", "index": index})
    assert document.check().problems == [] and document.text == soft.read_text()


def test_terms_are_added_renamed_with_their_rules_and_deleted(soft):
    document = RuleDocument(soft)
    document.apply({"op": "rename_term", "role": "input", "variable": "consistency",
                    "term": "firm", "new": "solid"})
    rules = document.check().rules
    assert "solid" in rules.inputs["consistency"].terms
    assert "if consistency is solid then youngs_modulus is firm" in [r.text for r in rules.rules]
    document.apply({"op": "add_term", "role": "input", "variable": "consistency",
                    "term": "mushy", "kind": "gaussmf", "params": [1, 0.5]})
    assert document.check().rules.inputs["consistency"].terms["mushy"].kind == "gaussmf"
    document.apply({"op": "delete_term", "role": "input", "variable": "consistency",
                    "term": "mushy"})
    for bad in ("two words", "very", "firm;rm -rf", ""):
        with pytest.raises(EditError, match="one word"):
            document.apply({"op": "add_term", "role": "input", "variable": "consistency",
                            "term": bad, "kind": "trimf", "params": [1, 2, 3]})
    with pytest.raises(EditError, match="exists already"):
        document.apply({"op": "add_term", "role": "input", "variable": "consistency",
                        "term": "soft", "kind": "trimf", "params": [1, 2, 3]})
    with pytest.raises(EditError, match="unknown edit"):
        document.apply({"op": "__import__('os').system('true')"})
    with pytest.raises(EditError, match="unexpected keyword"):
        document.apply({"op": "delete_term", "role": "input", "variable": "consistency",
                        "term": "soft", "code": "print(1)"})


def test_tissues_are_added_renamed_and_deleted(liver):
    document = RuleDocument(liver)
    document.apply({"op": "add_tissue", "tissue": "cirrhotic_liver",
                    "words": {"consistency": "very hard", "elasticity": "elastic"}})
    document.apply({"op": "rename_tissue", "tissue": "cirrhotic_liver", "new": "cirrhosis"})
    rules = document.check().rules
    assert str(rules.tissues["cirrhosis"]["consistency"]) == "very hard"
    document.apply({"op": "delete_tissue", "tissue": "cirrhosis"})
    assert document.text == liver.read_text()


def test_undo_and_redo_and_merged_drags(soft):
    document = RuleDocument(soft)
    original = document.text
    for peak in (4.4, 4.3, 4.2):               # a drag: one undo step
        document.apply({"op": "set_term", "role": "input", "variable": "consistency",
                        "term": "firm", "kind": "trimf", "params": [2, peak, 7]})
    document.apply({"op": "set_setting", "key": "defuzzification", "value": "bisector"})
    assert document.undo() and "4.2" in document.text and "bisector" not in document.text
    assert document.undo() and document.text == original and not document.undo()
    assert document.redo() and "[2, 4.2, 7]" in document.text


def test_save_round_trip_keeps_everything_but_the_change(liver):
    document = RuleDocument(liver)
    original = liver.read_text()
    document.apply({"op": "set_tissue", "tissue": "liver", "variable": "consistency",
                    "words": "somewhat firm"})
    document.save()
    saved = liver.read_text()
    removed, added = changed_lines(original, saved)
    assert len(removed) == len(added) == 1
    assert added[0] == removed[0].replace("{consistency: firm,", "{consistency: somewhat firm,")
    assert cli("rules", "check", liver).returncode == 0
    assert not document.dirty


def test_an_invalid_rule_base_is_never_written(liver):
    original = liver.read_text()
    document = RuleDocument(liver)
    document.apply({"op": "set_tissue", "tissue": "liver", "variable": "consistency",
                    "words": "frim"})
    with pytest.raises(EditError, match="not saved.*did you mean 'firm'"):
        document.save()
    with pytest.raises(EditError, match="not saved"):
        document.save("other.yaml")
    assert liver.read_text() == original and not (liver.parent / "other.yaml").exists()


def test_save_as_writes_only_a_new_file_in_the_folder(liver, tmp_path):
    document = RuleDocument(liver)
    for name in ("../outside.yaml", "/tmp/elsewhere.yaml", "sub/../../x.yaml"):
        with pytest.raises(InputError, match="refused|letters"):
            document.save(name)
    with pytest.raises(EditError, match="exists already"):
        document.save("soft_tissue.yaml")
    document.apply({"op": "set_tissue", "tissue": "liver", "variable": "heaviness",
                    "words": "heavy"})
    target = document.save("liver_heavy")
    assert target == tmp_path / "liver_heavy.yaml" and document.path == target
    assert "heaviness: heavy" in target.read_text()
    assert "heaviness: normal, compressibility: incompressible}         # shear 2.2" in \
        liver.read_text()


def test_a_file_changed_on_disk_is_not_overwritten(liver):
    document = RuleDocument(liver)
    document.apply({"op": "set_tissue", "tissue": "liver", "variable": "heaviness",
                    "words": "heavy"})
    liver.write_text(liver.read_text() + "# edited elsewhere\n")
    with pytest.raises(EditError, match="changed on disk"):
        document.save()
    assert liver.read_text().endswith("# edited elsewhere\n")


def test_paths_outside_the_folder_are_refused(tmp_path):
    (tmp_path / "sub").mkdir()
    assert inside(tmp_path, "sub/a.json") == tmp_path / "sub" / "a.json"
    (tmp_path / "link").symlink_to("/etc")
    for name in ("../x", "/etc/passwd", "link/passwd"):
        with pytest.raises(InputError, match="refused"):
            inside(tmp_path, name)


def test_unreadable_files_are_refused_with_their_line(tmp_path):
    path = tmp_path / "r.yaml"
    path.write_text("inputs:\n  a: [1, 2\n")
    with pytest.raises(InputError, match=r"r.yaml:\d+: malformed YAML"):
        RuleDocument(path)
    path.write_text("a: &x 1\nb: *x\n")
    with pytest.raises(InputError, match="anchors"):
        RuleDocument(path)


def test_every_shipped_file_survives_parse_and_unchanged_save(tmp_path):
    for source in RULES.glob("*.yaml"):
        shutil.copy(source, tmp_path / source.name)
    for source in RULES.glob("*.yaml"):
        text = source.read_text()
        assert YamlText(text).text == text
        document = RuleDocument(tmp_path / source.name)
        assert document.check().problems == [] and not document.dirty


@pytest.mark.parametrize("section", ["rules:\n", "rules: []\n", "rules: ~\n", ""])
def test_a_first_rule_goes_into_an_empty_or_missing_section(tmp_path, section):
    shutil.copy(RULES / "soft_tissue.yaml", tmp_path / "soft_tissue.yaml")
    path = tmp_path / "mine.yaml"
    path.write_text("extends: soft_tissue.yaml  # the shared words\nname: mine\n" + section +
                    "tissues:\n  jelly: {consistency: very soft}\n")
    document = RuleDocument(path)
    document.apply({"op": "add_rule", "text": "if consistency is very soft then "
                    "youngs_modulus is very_soft"})
    rules = document.check().rules
    assert rules.rules[-1].text.startswith("if consistency is very soft")
    assert document.text.startswith("extends: soft_tissue.yaml  # the shared words\n")


def test_a_second_inherited_variable_joins_the_first_in_the_file(liver):
    document = RuleDocument(liver)
    for variable, term, params in (("youngs_modulus", "firm", [1500, 4000, 15000]),
                                   ("viscosity", "medium", [0.4, 3, 8])):
        document.apply({"op": "set_term", "role": "output", "variable": variable,
                        "term": term, "kind": "trimf", "params": params})
    document.apply({"op": "set_term", "role": "input", "variable": "consistency",
                    "term": "firm", "kind": "gaussmf", "params": [4.5, 1.2]})
    rules = document.check().rules
    assert document.text.count("outputs:") == 1 and document.text.count("inputs:") == 1
    assert rules.outputs["viscosity"].terms["medium"].params == [0.4, 3, 8]
    assert rules.inputs["consistency"].terms["firm"].kind == "gaussmf"
    assert document.text.startswith((RULES / "liver.yaml").read_text())
