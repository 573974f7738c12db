"""Newton's method of the solver's steps: modified (old LU factors), Anderson-accelerated,
halving a step that would turn an element inside out."""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from ...errors import InputError


class Inverted(Exception):
    """sfepy met an element with negative volume."""


class ModifiedNewton:
    """Newton's method for ``f_int(x) + A x = b`` (A: the step's inertia matrix or None)
    with old LU factors of its matrix, accelerated (Anderson mixing of the last ``memory``
    corrections, a multisecant quasi-Newton update: Walker & Ni 2011, *SIAM J. Numer.
    Anal.* 49:1715), refactorised when the iterations stop contracting fast (a factorisation
    costs as much as some forty residuals on the recordings' mesh). A step that would turn
    an element inside out is halved."""

    def __init__(self, solver, inertia_matrix, tolerance: float,
                 slow: float = 0.5, most: int = 15, memory: int = 6):
        self.solver, self.inertia_matrix, self.tolerance = solver, inertia_matrix, tolerance
        self.slow, self.most, self.memory = slow, most, memory
        self.lu, self.stale = None, True
        self.iterations = self.factorisations = 0

    def _residual(self, x, rhs):
        residual = self.solver._internal(x) - rhs
        if self.inertia_matrix is not None:
            residual = residual + self.inertia_matrix @ x
        return residual

    def _factorise(self, x):
        matrix = self.solver._tangent(x)
        if self.inertia_matrix is not None:
            matrix = matrix + self.inertia_matrix
        self.lu = spla.splu(matrix.tocsc())
        self.factorisations += 1
        self.stale = False

    def solve(self, x, rhs, frame: int, what: str = "frame"):
        count, previous = 0, None
        xs, fs = [], []                                  # iterates and their corrections
        try:
            residual = self._residual(x, rhs)
            while True:
                if self.lu is None or self.stale:
                    self._factorise(x)
                    previous, xs, fs = None, [], []
                correction = -self.lu.solve(residual)
                size = np.abs(correction).max()
                if size <= self.tolerance * max(np.abs(x).max(), 1e-12):
                    x = x + correction
                    break
                step = correction
                if fs:                                   # Anderson mixing
                    d_f = np.stack([correction - f for f in fs], axis=1)
                    d_x = np.stack([x - xi for xi in xs], axis=1)
                    gamma = np.linalg.lstsq(d_f, correction, rcond=None)[0]
                    step = correction - (d_x + d_f) @ gamma
                xs, fs = (xs + [x])[-self.memory:], (fs + [correction])[-self.memory:]
                for _ in range(30):                      # back off inverted elements
                    try:
                        residual = self._residual(x + step, rhs)
                        break
                    except Inverted:
                        step = 0.5 * step
                        xs, fs = [], []
                else:
                    raise Inverted()
                x = x + step
                count += 1
                if previous is not None and (size > self.slow * previous or count >= self.most):
                    self.stale = True                    # too slow: fresh factors
                previous = size
                if count > 100:
                    raise InputError(f"Newton's method did not converge at {what} {frame}; "
                                     "take smaller steps", key="substeps")
        except Inverted:
            raise InputError(f"an element turned inside out at {what} {frame}; lower the "
                             "load or refine the mesh", key="load") from None
        self.iterations += count + 1
        return x
