"""A mistyped option: "unknown option --rulse; did you mean --rules?", exit status 2, one line,
nothing written (issue 50)."""

import subprocess
import sys

import pytest

from neurofuzzy.cli import main


@pytest.mark.parametrize("argv, message", [
    (["fit", "x.npz", "--rulse", "liver", "--tissue", "liver"],
     "unknown option --rulse; did you mean --rules?"),
    # argparse alone would report the required --rules as missing
    (["mesh", "box.stl", "--rulse", "liver", "--tissue", "liver", "--out", "m.yaml"],
     "unknown option --rulse; did you mean --rules?"),
    (["rules", "show", "liver", "--tisue", "liver"],
     "unknown option --tisue; did you mean --tissue?"),
    (["diagnose", "x.npz", "--max-efects=2"],
     "unknown option --max-efects; did you mean --max-effects?"),
    (["--verison"], "unknown option --verison; did you mean --version?"),
    (["fit", "x.npz", "--zzzzzz"], "unknown option --zzzzzz (neurofuzzy fit --help lists the "
                                   "options)"),
])
def test_a_mistyped_option_gets_did_you_mean(argv, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err == f"neurofuzzy: error: {message}\n" and captured.out == ""
    assert list(tmp_path.iterdir()) == []


def test_known_options_abbreviations_and_values_pass(tmp_path, capsys):
    assert main(["rules", "show", "liver", "--tis", "liver", "--json"]) == 0
    assert '"tissue": "liver"' in capsys.readouterr().out
    out = tmp_path / "y.npz"
    assert main(["simulate", "cube", "--out", str(out), "--force", "13", "0", "0", "-0.2",
                 "--frames=3"]) == 0
    assert out.exists()


def test_the_command_line_says_it_too():
    result = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", "fit", "x.npz", "--rulse",
                             "liver"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 2
    assert result.stderr == ("neurofuzzy: error: unknown option --rulse; did you mean "
                             "--rules?\n")
