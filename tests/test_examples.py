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
