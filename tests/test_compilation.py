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


def test_a_fit_leaves_a_compilation_during_it_out_of_its_time(fresh, capsys, monkeypatch,
                                                            cube_model, cube_experiment):
    """The wiring of the learner: a kernel compiled in the middle of a fit (here a new one,
    three times over, before the fit's assessment) is said once and is not in ``seconds_``."""
    from neurofuzzy.learn import GradientLearner, gradient

    kernel, assess = _new_function(), gradient.assess

    def compiling_assess(*args, **kwargs):
        kernel(1, 2), kernel(1.0, 2.0), kernel(1j, 2j)
        return assess(*args, **kwargs)

    monkeypatch.setattr(gradient, "assess", compiling_assess)
    before, began = compile_seconds(), time.perf_counter()
    with announced(True):                                    # as the commands do
        fitted = GradientLearner().fit(cube_model.tied("global"), cube_experiment)
    wall, compiled = time.perf_counter() - began, compile_seconds() - before
    assert capsys.readouterr().err.count(COMPILING) == 1
    assert compiled > 0.05
    assert fitted.seconds_ <= wall - 0.9 * compiled


@pytest.mark.slow
def test_a_cold_cache_is_announced_and_a_warm_one_is_silent(tmp_path):
    """With numba's cache in an empty folder: the first simulation says it compiles, the
    second does not. (A cold fit compiles longer; the fit's wiring is the test above.)"""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))

    def run(*args):
        result = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                                capture_output=True, text=True, env=env, timeout=900)
        assert result.returncode == 0, result.stderr
        return result

    cold = run("simulate", "cube", "--out", tmp_path / "a.npz")
    assert cold.stderr.count(COMPILING) == 1
    warm = run("simulate", "cube", "--out", tmp_path / "b.npz")
    assert COMPILING not in warm.stderr


_SPRINGS_ONLY = """
import json
from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model
from neurofuzzy.kernels import (adjoint, element_forces, element_jvp, element_vjp, sensitivity,
                               stepper)
from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.warmup import Parameterization, Sensitivity

model = paper_cube_model()
data = paper_cube_experiment(model, n_frames=8)
GradientLearner(method="lbfgs", max_iterations=1).fit(model.tied("global"), data)
parameters = Parameterization(model.tied("global"))
Sensitivity(parameters, model.length_unit).run(parameters.initial(), data, tangents=True)
kernels = {"frames": stepper.frames, "forward": sensitivity.forward,
           "pull_back": adjoint.pull_back, "element_forces": element_forces.element_forces,
           "element_jvp": element_jvp.element_jvp,
           "element_vjp": element_vjp.element_vjp}
print(json.dumps({name: [[str(t) for t in s] for s in kernel.signatures]
                  for name, kernel in kernels.items()}))
"""


@pytest.mark.slow
def test_a_spring_model_compiles_no_element_code(tmp_path):
    """A model without elements passes ``tets`` (the learners' ``elements``) None, and numba
    prunes the element branch of the stepper, the sensitivities and the adjoint: from an
    empty cache a fit of the cube compiles those three, and none of the element loops
    (together a minute and a half of compilation, for nothing)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    result = subprocess.run([sys.executable, "-c", _SPRINGS_ONLY], capture_output=True,
                            text=True, env=env, timeout=900)
    assert result.returncode == 0, result.stderr
    signatures = json.loads(result.stdout.strip().splitlines()[-1])
    assert signatures["frames"] and all(s[2] == "none" for s in signatures["frames"])
    assert signatures["forward"] and all(s[2] == "none" for s in signatures["forward"])
    assert signatures["pull_back"] and all(s[1] == "none" for s in signatures["pull_back"])
    for loop in ("element_forces", "element_jvp", "element_vjp"):
        assert signatures[loop] == [], loop
