"""The rule file a user edited is the one used: a bare name (``--rules liver``) is
``./rules/liver.yaml``, then ``./liver.yaml``, then the shipped copy; every command says which
file it read and records its path and sha256 (issue 50)."""

import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from neurofuzzy.cli import main
from neurofuzzy.errors import InputError
from neurofuzzy.io import load_fit_record, save_experiment
from neurofuzzy.rules import locate, resolve, shipped

SHIPPED = Path(shipped("liver")).parent


def _edited_copy(folder: Path) -> Path:
    """``folder/rules/`` as a clone's, with healthy liver described as hard (the studio's
    edit of issue 50); returns the edited file."""
    shutil.copytree(SHIPPED, folder / "rules")
    liver = folder / "rules" / "liver.yaml"
    text = liver.read_text()
    line = next(line for line in text.splitlines() if line.lstrip().startswith("liver:"))
    assert "consistency: firm" in line
    liver.write_text(text.replace(line, line.replace("consistency: firm", "consistency: hard")))
    return liver


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_bare_name_is_the_users_copy_before_the_shipped_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert locate("liver") == shipped("liver")
    shutil.copy(shipped("liver"), tmp_path / "liver.yaml")
    assert locate("liver") == Path("liver.yaml")
    (tmp_path / "rules").mkdir()
    shutil.copy(shipped("liver"), tmp_path / "rules" / "liver.yaml")
    assert locate("liver") == Path("rules") / "liver.yaml"
    assert locate("liver", folder=tmp_path / "elsewhere") == shipped("liver")
    assert locate("rules/liver.yaml") == Path("rules/liver.yaml")      # a path is itself
    with pytest.raises(InputError, match="no shipped rule base 'livr'"):
        locate("livr")


def test_a_rule_base_knows_its_file_and_checksum(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    edited = _edited_copy(tmp_path)
    rules = resolve("liver")
    assert rules.source == str(Path("rules") / "liver.yaml")
    assert rules.sha256 == _sha256(edited) != _sha256(shipped("liver"))
    assert rules.origin == f"rules/liver.yaml (sha256 {_sha256(edited)[:8]}…)"
    record = rules.provenance()
    assert record["path"] == str(edited.resolve()) and record["sha256"] == _sha256(edited)
    parent = tmp_path / "rules" / "soft_tissue.yaml"          # liver extends it
    assert record["extends"] == [{"path": str(parent.resolve()), "sha256": _sha256(parent)}]
    assert rules.summary().splitlines()[0] == f"rule base 'liver' ({rules.origin})"
    assert resolve(shipped("liver")).tissue("liver")["youngs_modulus"] < \
        0.5 * rules.tissue("liver")["youngs_modulus"]           # the edit: firm -> hard


def test_rules_show_reads_the_edited_copy_and_names_it(tmp_path):
    edited = _edited_copy(tmp_path)
    command = [sys.executable, "-m", "neurofuzzy.cli", "rules", "show", "liver", "--tissue",
               "liver"]
    shown = subprocess.run(command + ["--json"], capture_output=True, text=True, cwd=tmp_path,
                           timeout=300)
    assert shown.returncode == 0, shown.stderr
    data = json.loads(shown.stdout)
    assert data["rules"]["path"] == str(edited.resolve())
    assert data["rules"]["sha256"] == _sha256(edited)
    assert data["words"]["consistency"] == "hard"
    assert data["labels"]["youngs_modulus"]["term"] == "hard"
    text = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    first = text.stdout.splitlines()[0]
    assert first == f"rules: rules/liver.yaml (sha256 {_sha256(edited)[:8]}…)"
    assert "consistency is hard" in text.stdout


def test_fit_with_a_bare_name_starts_from_the_edited_copy(cube_experiment, tmp_path,
                                                         monkeypatch, capsys):
    data = save_experiment(cube_experiment, tmp_path / "cube.npz")
    monkeypatch.chdir(tmp_path)
    edited = _edited_copy(tmp_path)
    assert main(["fit", str(data), "--rules", "liver", "--tissue", "liver", "--elements",
                 "springs", "--tie", "global", "--cycles", "2", "--substeps", "1", "--json",
                 "--out", "fitted.yaml", "--report", "fit.html"]) == 0
    captured = capsys.readouterr()
    said = [line for line in captured.err.splitlines() if line.startswith("rules: ")]
    assert said == [f"rules: rules/liver.yaml (sha256 {_sha256(edited)[:8]}…)"]
    result = json.loads(captured.out)
    record = {"path": str(edited.resolve()), "sha256": _sha256(edited)}
    assert {k: result["rules"][k] for k in record} == record
    assert {k: load_fit_record("fitted.yaml")["rules"][k] for k in record} == record
    report = json.loads(Path("fit.json").read_text())
    assert {k: report["rules"][k] for k in record} == record
    (start,) = [q for q in report["regions"][0]["quantities"] if q["quantity"] == "youngs_modulus"]
    expected = resolve(edited).tissue("liver")["youngs_modulus"]
    assert start["label_before"] == "hard"          # the edit, not the shipped "firm"
    assert start["before"] == pytest.approx(expected, rel=0.05)
    assert _sha256(edited)[:8] in Path("fit.html").read_text()

    assert main(["fit", str(data), "--rules", "liver", "--tissue", "liver", "--out",
                 "rules/liver.yaml"]) == 2                # the file --rules liver reads
    assert "never writes over its input" in capsys.readouterr().err
    assert _sha256(edited) == record["sha256"]


def test_mesh_records_the_rule_file_in_the_model(tmp_path, monkeypatch, capsys):
    import trimesh

    monkeypatch.chdir(tmp_path)
    edited = _edited_copy(tmp_path)
    trimesh.creation.box(extents=(0.04, 0.04, 0.02)).export("box.stl")
    assert main(["mesh", "box.stl", "--pitch", "0.01", "--fix-bottom", "--rules", "liver",
                 "--tissue", "liver", "--out", "box.yaml"]) == 0
    assert f"rules: rules/liver.yaml (sha256 {_sha256(edited)[:8]}…)" in capsys.readouterr().err
    from neurofuzzy.io import safe_yaml

    saved = safe_yaml.load("box.yaml", max_bytes=2**24, kind="model file")["rules"]
    assert saved["path"] == str(edited.resolve()) and saved["sha256"] == _sha256(edited)
