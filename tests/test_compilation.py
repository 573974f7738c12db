"""The first run explains its wait: the kernels' one-time compilation is said on stderr and
left out of the timings a fit reports (issue 50)."""

import json
import os
import subprocess
import sys
import time

import numba
import pytest

from neurofuzzy import progress
from neurofuzzy.progress import COMPILING, Progress, Stopwatch, announced, compile_seconds


@pytest.fixture
def fresh(monkeypatch):
    """This process has not yet said that it compiles (other tests may have)."""
    monkeypatch.setattr(progress._COMPILATIONS, "announced", False)


def _new_function():
    """A numba function never compiled (no cache): each call with new types compiles."""
    def add(x, y):
        total = x
        for _ in range(3):
            total = total + y
        return total
    return numba.njit(add)


def test_a_compilation_is_said_once_and_left_out_of_the_time(fresh, capsys):
    kernel = _new_function()
    before = compile_seconds()
    with announced(True):
        watch = Stopwatch()
        began = time.perf_counter()
        assert kernel(1, 2) == 7
        assert kernel(1.0, 2.0) == 7.0          # a second specialisation: said no more
        wall = time.perf_counter() - began
    assert capsys.readouterr().err == COMPILING + "\n"
    assert compile_seconds() - before == pytest.approx(watch.compiling)
    assert 0 < watch.compiling <= wall
    assert watch.seconds == pytest.approx(wall - watch.compiling, abs=0.05)
    assert watch.seconds < 0.5 * wall           # compiling is most of it
    kernel(3, 4)                                # compiled: nothing to leave out
    assert compile_seconds() - before == pytest.approx(watch.compiling)


def test_nothing_is_said_without_progress_or_when_nothing_compiles(fresh, capsys):
    kernel = _new_function()
    with announced(False):
        kernel(1, 2)
    with announced(True):
        kernel(5, 6)                            # cached in the process: no compilation
    assert capsys.readouterr().err == ""
    with announced(True):
        kernel(1j, 2j)
    assert capsys.readouterr().err == COMPILING + "\n"


def test_progress_lines_leave_the_compilation_out(fresh, capsys):
    kernel = _new_function()
    counter = Progress("work", 1, enabled=True)
    kernel(1.0, 2)
    counter.update(1)
    seconds = float(capsys.readouterr().err.strip().rsplit("(", 1)[1].split()[0])
    assert seconds < 0.1


@pytest.mark.slow
def test_a_cold_cache_is_announced_and_a_warm_one_is_silent(tmp_path, cube_experiment):
    """With numba's cache in an empty folder: the first simulation says it compiles, the
    second does not; a fit's reported time leaves its compilation out."""
    from neurofuzzy.io import save_experiment

    data = save_experiment(cube_experiment, tmp_path / "cube.npz")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))

    def run(*args):
        began = time.perf_counter()
        result = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                                capture_output=True, text=True, env=env, timeout=900)
        assert result.returncode == 0, result.stderr
        return result, time.perf_counter() - began

    cold, _ = run("simulate", "cube", "--out", tmp_path / "a.npz")
    assert cold.stderr.count(COMPILING) == 1
    warm, _ = run("simulate", "cube", "--out", tmp_path / "b.npz")
    assert COMPILING not in warm.stderr
    fitted, wall = run("fit", data, "--tie", "global", "--json")
    assert fitted.stderr.count(COMPILING) == 1
    assert json.loads(fitted.stdout)["seconds"] < 0.5 * wall
