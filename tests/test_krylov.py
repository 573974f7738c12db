"""GMRES of the corrected solves (:mod:`neurofuzzy.simulation.krylov`) against a direct solve."""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from neurofuzzy.simulation.krylov import gmres


def _system(size=200, seed=0):
    """A sparse, nonsymmetric, well-conditioned matrix (a shifted convection-diffusion
    stencil) and a right side."""
    rng = np.random.default_rng(seed)
    matrix = sp.diags([-1.3 * np.ones(size - 1), 4.0 * np.ones(size), -0.7 * np.ones(size - 1)],
                      [-1, 0, 1], format="csc")
    matrix = matrix + sp.random(size, size, density=0.01, random_state=seed, format="csc")
    return matrix, rng.normal(size=size)


def test_it_solves_a_nonsymmetric_system_to_its_tolerance():
    matrix, right = _system()
    exact = spla.spsolve(matrix, right)
    goal = 1e-10 * np.linalg.norm(right)
    solved = gmres(matrix.dot, right, goal, restart=40, cycles=10)
    assert solved.converged
    assert np.linalg.norm(right - matrix @ solved.x) <= 1.001 * goal
    assert np.abs(solved.x - exact).max() < 1e-8 * np.abs(exact).max()
    assert 1 < solved.iterations <= 400


def test_a_good_preconditioner_on_the_right_needs_few_iterations_and_an_exact_one_one():
    matrix, right = _system(seed=1)
    goal = 1e-10 * np.linalg.norm(right)
    plain = gmres(matrix.dot, right, goal, restart=60, cycles=10)
    nearby = spla.splu((matrix + 0.05 * sp.identity(matrix.shape[0])).tocsc())
    kept = gmres(matrix.dot, right, goal, precondition=nearby.solve, restart=60)
    exact = gmres(matrix.dot, right, goal, precondition=spla.splu(matrix).solve)
    assert kept.converged and exact.converged
    assert kept.iterations < plain.iterations / 2
    assert exact.iterations == 1
    # preconditioned on the right, the tolerance is the system's own residual
    assert np.linalg.norm(right - matrix @ kept.x) <= 1.001 * goal


def test_a_start_that_already_solves_the_system_costs_one_product():
    matrix, right = _system(seed=2)
    x = spla.spsolve(matrix, right)
    calls = []

    def apply(u):
        calls.append(1)
        return matrix @ u

    solved = gmres(apply, right, 1e-8 * np.linalg.norm(right), start=x)
    assert solved.converged and solved.iterations == 0 and len(calls) == 1
    assert np.array_equal(solved.x, x)


def test_too_few_iterations_report_no_convergence_with_the_best_of_the_cycle():
    matrix, right = _system(size=300, seed=3)
    goal = 1e-12 * np.linalg.norm(right)
    short = gmres(matrix.dot, right, goal, restart=5, cycles=1)
    assert not short.converged and short.iterations == 5
    # still a GMRES iterate: the residual fell from the right side's
    assert np.linalg.norm(right - matrix @ short.x) < 0.5 * np.linalg.norm(right)
    longer = gmres(matrix.dot, right, goal, restart=5, cycles=3)
    assert (np.linalg.norm(right - matrix @ longer.x)
            < np.linalg.norm(right - matrix @ short.x))


def test_a_singular_direction_ends_without_convergence():
    matrix = sp.diags([1.0, 2.0, 0.0]).tocsc()
    solved = gmres(matrix.dot, np.array([0.0, 0.0, 1.0]), 1e-12)
    assert not solved.converged
    assert np.all(np.isfinite(solved.x))
