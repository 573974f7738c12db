"""The documentation site builds from docs/ with warnings as errors, and the help texts and the
README say where the file formats are documented."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_site_builds_strictly_with_the_api_reference(tmp_path):
    site = tmp_path / "site"
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
                             "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(site)],
                            capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    api = (site / "api" / "index.html").read_text()
    for name in ("GradientLearner", "FuzzyPrior", "initialize", "diagnose"):
        assert name in api, name
    assert "discrepancy principle" in api                  # a docstring, rendered
    assert "rest_positions" in (site / "formats" / "index.html").read_text()


def test_the_format_the_help_points_to_is_documented():
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Experiment files", 1)[1].split("\n## ", 1)[0]
    for key in ("rest_positions", "springs", "dt", "positions", "fixed", "external_forces",
                "observed", "masses", "tetrahedra"):
        assert f"`{key}`" in section, key
    assert "DESIGN.md" not in section


def _blocks(readme: str, section: str) -> list[tuple[str, str]]:
    """(language, code) of every fenced block of a README section (## level)."""
    import re

    body = readme.split(f"\n## {section}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```(\w*)\n(.*?)```", body, flags=re.S)


#: the sections whose commands and snippets run in order, in one fresh folder
WALKTHROUGHS = ("Words in, numbers out, words back", "Command line",
                "The rule base as a prior: where the tissue differs from its description",
                "Finding the missing effect", "Many specimens: fit-many on Dask")


@pytest.mark.slow
def test_the_readme_walkthroughs_run_as_written(tmp_path):
    """Every bash block and Python snippet of these README sections, copy-pasted in order into
    a shell in a fresh folder holding what a clone holds (rules/, examples/)."""
    import os
    import shutil

    readme = (ROOT / "README.md").read_text()
    for folder in ("rules", "examples"):
        shutil.copytree(ROOT / folder, tmp_path / folder)
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    ran = 0
    for section in WALKTHROUGHS:
        for language, code in _blocks(readme, section):
            if language == "bash":
                command = ["bash", "-euo", "pipefail", "-c", code]
            elif language == "python":
                command = [sys.executable, "-c", code]
            else:
                continue
            result = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path,
                                    env=env, timeout=900)
            assert result.returncode == 0, f"{section}:\n{code}\n{result.stderr[-2000:]}"
            ran += 1
    assert ran >= 5
    assert (tmp_path / "fitted.yaml").exists() and (tmp_path / "prior" / "fit.html").exists()
    assert (tmp_path / "results" / "results.csv").exists()


@pytest.mark.slow
def test_the_readme_quotes_the_demo_as_it_prints(tmp_path):
    """The demo's table (the paper learner's rows to every digit shown, the gradient row but
    for its machine-precision columns) and its words are the README's, as the README says."""
    import re

    readme = (ROOT / "README.md").read_text()
    result = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", "demo", "--out",
                             str(tmp_path / "demo"), "--quiet"], capture_output=True, text=True,
                            timeout=900)
    assert result.returncode == 0, result.stderr

    def without_time(line):
        return re.sub(r"\s+\S+s$", "", line.rstrip())

    table = [line for line in result.stdout.splitlines() if re.match(r"\s+[123]\s+paper", line)]
    assert len(table) == 3
    quoted = {without_time(line) for line in readme.splitlines()}
    for line in table:
        assert without_time(line) in quoted, line
    gradient = next(line for line in result.stdout.splitlines() if "gradient" in line).split()
    assert gradient[:2] == ["3", "gradient"] and gradient[5:8] == ["0.00%"] * 3
    for line in result.stdout.splitlines():
        if line.startswith(("words:", "  youngs_modulus", "  viscosity", "  density",
                            "  in the expert's words")):
            assert line in readme, line
