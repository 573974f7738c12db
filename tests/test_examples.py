"""Every example runs (quick mode where it has one)."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow
def test_paper_cube_example_runs(tmp_path):
    result = subprocess.run([sys.executable, str(EXAMPLES / "paper_cube.py"), str(tmp_path),
                             "--quick"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "gradient" in result.stdout
    assert (tmp_path / "error_per_cycle.png").stat().st_size > 10_000


@pytest.mark.slow
def test_find_missing_effect_example_runs(tmp_path):
    result = subprocess.run([sys.executable, str(EXAMPLES / "find_missing_effect.py"),
                             str(tmp_path), "--quick"], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert "stiff_inclusion" in result.stdout
    assert "14 of the 14 true springs found, 0 others" in result.stdout
    assert (tmp_path / "diagnosis.html").stat().st_size > 10_000
    assert (tmp_path / "diagnosis.json").exists()


@pytest.mark.slow
@pytest.mark.parametrize("method", ["voxel", "tetra"])
def test_organ_surface_markers_example_and_the_readme_commands(tmp_path, method):
    """The example recovers the hidden tissue from surface markers; on its files, the README's
    three commands (mesh -> import -> fit) do the same."""
    import re

    import numpy as np

    from neurofuzzy.io import load_model

    flags = ["--quick"] + (["--tetra"] if method == "tetra" else [])
    result = subprocess.run([sys.executable, str(EXAMPLES / "organ_surface_markers.py"),
                             str(tmp_path), *flags], capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    rows = re.findall(r"^(stiffness|viscosity) (\w+)\s+\S+\s+(\S+)\s+(\S+)\s+(\S+)%$",
                      result.stdout, flags=re.M)
    assert len(rows) == (4 if method == "voxel" else 2)
    # quick mode: 150 frames of 20 µm noise determine stiffness to < 0.1 %, viscosity (a
    # weaker effect in this load case) to a few per cent (full mode: < 1 %)
    for quantity, _, fitted, truth, error in rows:
        assert float(error) < (0.1 if quantity == "stiffness" else 10.0)
    for name in ("report.html", "report.json", "fitted.yaml", "paraview/organ.pvd",
                 "paraview/organ.xdmf"):
        assert (tmp_path / name).exists(), name
    if method == "tetra":
        return

    def run(*args):
        done = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                              capture_output=True, text=True, cwd=tmp_path, timeout=600)
        assert done.returncode == 0, done.stderr
        return done

    run("mesh", "organ.stl", "--pitch", "0.014", "--fix-bottom", "--rules", "liver",
        "--tissue", "liver", "--out", "organ.yaml")
    run("import", "markers.csv", "--topology", "organ.yaml", "--forces", "forces.csv",
        "--out", "trial.npz")
    run("fit", "trial.npz", "--rules", "liver", "--tissue", "liver", "--out", "cli.yaml",
        "--report", "fit.html", "--export", "cli-paraview", "--quiet")
    by_cli, by_api = load_model(tmp_path / "cli.yaml"), load_model(tmp_path / "fitted.yaml")
    assert np.allclose(by_cli.spring_stiffness, by_api.spring_stiffness, rtol=1e-3)
    assert "hard" in (tmp_path / "fit.html").read_text()
    assert (tmp_path / "cli-paraview" / "trial.pvd").exists()
