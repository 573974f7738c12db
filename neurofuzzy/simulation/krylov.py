"""GMRES for the solves corrected from a kept factorisation: the implicit step's
(:mod:`.step_solve`) and its derivatives' (:mod:`.implicit_derivatives`).

Each of those solves starts from a factorisation of a nearby matrix and needs a handful of
iterations on systems of a few hundred to a few thousand unknowns, tens of thousands of
times in a fit. There SciPy's ``scipy.sparse.linalg.gmres`` spent more time in its own
Python than in the products and triangular solves it called: profiled on the plate ramp's
implicit fit (384 tetrahedra graded toward the plates, 225 unknowns), 270 of 864 seconds
were its body (8.4 ms a call, 32,160 calls) and more its ``LinearOperator`` wrappers,
against 136 s in SuperLU's solves and 70 s in the compiled force. :func:`gmres` is the
same method (restarted GMRES, Saad and Schultz 1986, preconditioned on the right so that
the residual it minimises is the system's own) on preallocated arrays, orthogonalised by
classical Gram–Schmidt applied twice (two matrix–vector products with the basis instead
of a Python loop over it; as stable as the modified form, Giraud, Langou and Rozložník
2005).

The static solve (:func:`.static._solve`) keeps SciPy's, preconditioned on the left. Its
Newton iterations with a tool in contact meet tangents that turn indefinite, and decide
whether to cut an increment by the sign of ``r·δ``. Preconditioned on the right, GMRES met
the tolerance from the kept factorisation where SciPy's had not (23 new factorisations
instead of 76 on ``tests/test_contact.py``'s press of 20 % in one increment), so Newton took
other steps and converged on another equilibrium (a contact force 5 % lower) than the one
eight increments find. The implicit step's matrix ``M + hC + h²K`` keeps its mass on the
diagonal, and its solves showed no such difference.
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np
from scipy.linalg import solve_triangular

__all__ = ["gmres", "Solved"]


class Solved(NamedTuple):
    """What :func:`gmres` found."""

    x: np.ndarray         # the solution
    iterations: int       # Krylov iterations, one product each (the residuals of a given
                          # start and of a restart not counted)
    converged: bool       # the residual is within the tolerance


def gmres(apply: Callable[[np.ndarray], np.ndarray], right: np.ndarray, tolerance: float, *,
          precondition: Callable[[np.ndarray], np.ndarray] | None = None,
          start: np.ndarray | None = None, restart: int = 30, cycles: int = 1) -> Solved:
    """Solve ``A x = right`` to ``‖right - A x‖ ≤ tolerance`` (the 2-norm, absolute).

    Parameters
    ----------
    apply : callable
        ``apply(u)`` is ``A u``.
    right : (n,) float
    tolerance : float
        The residual's norm to reach.
    precondition : callable, optional
        ``precondition(u)`` approximates ``A⁻¹ u`` (a kept factorisation's solve), applied
        on the right: the iterations minimise the true residual.
    start : (n,) float, optional
        The first guess (zero by default; a given one costs one product for its residual).
    restart : int
        Iterations a cycle (the Krylov basis kept).
    cycles : int
        Cycles before giving up.

    Returns
    -------
    Solved
        ``(x, iterations, converged)``; not converged: the best ``x`` of the last cycle.
    """
    size = right.shape[0]
    x = np.zeros(size) if start is None else np.array(start, float)
    residual = right if start is None else right - apply(x)
    beta = float(np.linalg.norm(residual))
    if beta <= tolerance:
        return Solved(x, 0, True)
    basis = np.empty((restart + 1, size))
    directions = np.empty((restart, size))
    hessenberg = np.zeros((restart + 1, restart))
    cosines, sines = np.zeros(restart), np.zeros(restart)
    iterations = 0
    for cycle in range(cycles):
        basis[0] = residual / beta
        g = np.zeros(restart + 1)        # the rotated right side; |g[j + 1]| the residual
        g[0] = beta
        for j in range(restart):
            directions[j] = basis[j] if precondition is None else precondition(basis[j])
            w = apply(directions[j])
            kept = basis[:j + 1]
            h = kept @ w
            w = w - h @ kept
            again = kept @ w             # the second pass of classical Gram-Schmidt
            w -= again @ kept
            h += again
            norm = float(np.linalg.norm(w))
            column = hessenberg[:, j]
            column[:j + 1] = h
            for i in range(j):           # the earlier rotations, on the new column
                a, b = column[i], column[i + 1]
                column[i] = cosines[i] * a + sines[i] * b
                column[i + 1] = cosines[i] * b - sines[i] * a
            radius = math.hypot(column[j], norm)
            if radius == 0.0:            # A maps the new direction to zero: singular
                return Solved(x, iterations, False)
            cosines[j], sines[j] = column[j] / radius, norm / radius
            column[j], column[j + 1] = radius, 0.0
            g[j + 1] = -sines[j] * g[j]
            g[j] *= cosines[j]
            iterations += 1
            if abs(g[j + 1]) <= tolerance or norm == 0.0:
                break
            basis[j + 1] = w / norm
        k = j + 1
        y = solve_triangular(hessenberg[:k, :k], g[:k])
        x += y @ directions[:k]
        if abs(g[k]) <= tolerance:
            return Solved(x, iterations, True)
        if cycle + 1 < cycles:
            residual = right - apply(x)
            beta = float(np.linalg.norm(residual))
            if beta <= tolerance:
                return Solved(x, iterations, True)
    return Solved(x, iterations, False)
