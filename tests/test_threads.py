"""The element passes on both cores (the stepper's, the forward sensitivities' and the element
stiffness): the same numbers as on one, for large models run from the main thread only
(:mod:`neurofuzzy.simulation.threads`)."""

import re
import threading

import numba
import numpy as np
import pytest

from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.simulation import tangents
from neurofuzzy.simulation.steppers import NumbaStepper
from neurofuzzy.simulation.threads import PARALLEL_FROM, element_buffers, element_threads

two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2,
                                 reason="numba has one thread here")


def _block(cells=8, law="neo-hookean", relaxing=False):
    """A Kuhn block of 6 cells³ tetrahedra (8³: 3,072, above PARALLEL_FROM), bottom fixed,
    the nodal volumetric form at ν 0.49."""
    points, tets = kuhn_block((cells,) * 3, 0.02 / cells)
    mesh = from_tetra(points, tets).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.49, viscosity=2.0,
                            density=1000.0, law=law)
    if relaxing:
        model = model.with_elements(relaxation_moduli=[[0.3]] * mesh.n_tetrahedra,
                                    relaxation_times=[[0.01]] * mesh.n_tetrahedra)
    return model


def _disturbed(model, seed=0):
    rng = np.random.default_rng(seed)
    p = model.mesh.rest_positions.copy()
    moving = p[:, 2] > 1e-9
    p[moving] += 2e-4 * rng.normal(size=(moving.sum(), 3))
    return p


@pytest.fixture
def threads():
    """Sets numba's thread count for one test, and restores it."""
    before = numba.get_num_threads()
    yield numba.set_num_threads
    numba.set_num_threads(before)


def test_small_models_and_worker_threads_stay_on_one_thread():
    assert element_threads(PARALLEL_FROM - 1) == 1
    assert element_buffers(10, 5) is None
    seen = []
    worker = threading.Thread(target=lambda: seen.append(element_threads(10 * PARALLEL_FROM)))
    worker.start()
    worker.join()
    assert seen == [1]
    assert 1 <= element_threads(10 * PARALLEL_FROM) <= numba.get_num_threads()


@two_threads
@pytest.mark.slow       # the parallel passes compile for about a minute on a fresh cache
@pytest.mark.parametrize("law, relaxing", [("st-venant-kirchhoff", False),
                                           ("neo-hookean", True)])
def test_steps_on_two_threads_equal_one(threads, law, relaxing):
    """St. Venant–Kirchhoff alone takes the specialised passes, neo-Hookean with a Prony term
    the general ones with internal variables: both the same on two threads as on one."""
    model = _block(law=law, relaxing=relaxing)
    assert model.mesh.n_tetrahedra >= PARALLEL_FROM
    runs = []
    for count in (1, 2):
        threads(count)
        stepper = NumbaStepper(model, 2e-5)
        assert (stepper.scratch()[2] is None) == (count == 1)
        p, v = _disturbed(model), np.zeros((model.n_nodes, 3))
        stepper.advance(p, v, None, 40)
        positions, velocities, history = stepper.trajectory(p, v, None, 3, 5,
                                                             stepper.history.copy())
        runs.append((p, v, positions, velocities, history))
    assert np.abs(runs[0][2][-1] - model.mesh.rest_positions).max() > 1e-5
    for one, two in zip(*runs):      # the sums in another order: equal to round-off
        assert np.all(np.isfinite(two))
        assert np.abs(two - one).max(initial=0.0) <= 1e-10 * np.abs(one).max(initial=0.0)


@two_threads
@pytest.mark.slow       # the tangents' parallel passes compile with the learner's kernels
@pytest.mark.parametrize("law, relaxing", [("st-venant-kirchhoff", False),
                                           ("neo-hookean", True)])
def test_derivatives_on_two_threads_equal_one(threads, monkeypatch, law, relaxing):
    """The forward sensitivities and the adjoint of a large model split its elements over the
    threads (every column in one run; :mod:`neurofuzzy.kernels.element_jvp` and
    :mod:`~neurofuzzy.kernels.element_vjp`): the same Jacobian and gradient as on one thread,
    for the specialised passes and the general ones with internal variables."""
    from neurofuzzy.experiment import Experiment
    from neurofuzzy.learn import Parameterization, _compiled_gradient, auto_substeps
    from neurofuzzy.learn._compiled import CompiledModel
    from neurofuzzy.learn._sensitivity import Sensitivity

    model = _block(law=law, relaxing=relaxing)
    rest = model.mesh.rest_positions
    push = np.zeros((model.n_nodes, 3))
    push[rest[:, 2] > rest[:, 2].max() - 1e-9] = (1e-3, 0.0, -3e-3)
    data = Experiment(model.mesh, 1e-3, np.repeat(rest[None], 4, axis=0),
                      external_forces=push)
    parameters = Parameterization(model.tied("global"))
    sensitivity = Sensitivity(parameters, model.length_unit)
    chunks, adjoint_chunks = [], []
    run = CompiledModel.run
    monkeypatch.setattr(CompiledModel, "run", lambda self, *a, **k: (
        chunks.append(k.get("chunks")), run(self, *a, **k))[1])
    monkeypatch.setattr(_compiled_gradient, "element_threads", lambda n: (
        adjoint_chunks.append(element_threads(n)), adjoint_chunks[-1])[1])
    results, gradients = [], []
    substeps = auto_substeps(model, 1e-3)
    for count in (1, 2):
        threads(count)
        results.append(sensitivity.run(parameters.initial(), data, tangents=True,
                                       substeps=substeps, threads=count))
        gradients.append(sensitivity.gradient(parameters.initial(), data,
                                              substeps=substeps)[1])
    assert chunks == [1, 2] and adjoint_chunks == [1, 2]
    one, two = results
    assert np.abs(one.jacobian).max() > 0.0 and np.all(np.isfinite(two.jacobian))
    np.testing.assert_allclose(two.residuals, one.residuals, rtol=0, atol=1e-12)
    assert np.abs(two.jacobian - one.jacobian).max() <= 1e-10 * np.abs(one.jacobian).max()
    # the gradient is Jᵀ r (the adjoint and the tangents agree), on either count
    expected = one.jacobian.reshape(-1, parameters.size).T @ one.residuals.ravel()
    np.testing.assert_allclose(gradients[0], expected, rtol=1e-8)
    assert np.abs(gradients[1] - gradients[0]).max() <= 1e-10 * np.abs(gradients[0]).max()


@two_threads
def test_stiffness_on_two_threads_equals_one(threads):
    model = _block(cells=8)
    p = _disturbed(model, seed=1)
    results = []
    for count in (1, 2):
        threads(count)
        assert element_threads(model.mesh.n_tetrahedra) == count
        results.append(tangents(model, p, long_time=True))
    one, two = results
    np.testing.assert_allclose(two.force, one.force, rtol=1e-12, atol=1e-14)
    difference = abs(two.stiffness - one.stiffness).max()
    assert difference <= 1e-12 * abs(one.stiffness).max()


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS >= 2, reason="they run in this process")
def test_the_two_thread_checks_in_a_process_of_two_threads():
    """Where numba has one thread (the test workers of ``-n 2`` on two cores keep one each,
    tests/conftest.py) the checks above skip: they run here, in a process with two."""
    import os
    import subprocess
    import sys

    result = subprocess.run(
        [sys.executable, "-m", "pytest", __file__, "-m", "slow or not slow", "-k",
         "two_threads_equal", "-p", "no:xdist", "-p", "no:cacheprovider", "-q"],
        env={**os.environ, "NUMBA_NUM_THREADS": "2"}, capture_output=True, text=True,
        check=False, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert re.search(r"\b5 passed\b", result.stdout) and "skipped" not in result.stdout
