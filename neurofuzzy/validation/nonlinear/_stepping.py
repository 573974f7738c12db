"""The time stepping of :class:`~.solver.HyperelasticSolver`: average-acceleration Newmark
(or equilibrium at every step, without inertia), FEBio's Prony update and the Kelvin–Voigt
rate between the steps (the solver module's docstring gives the equations)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from ._newton import ModifiedNewton

__all__ = ["Trajectory", "newmark"]


@dataclass
class Trajectory:
    """A run of :meth:`HyperelasticSolver.dynamic` with what it cost.

    Attributes
    ----------
    displacement, velocity : (n_frames, n_dofs) float
        At the frames (m, m/s).
    newton_iterations : int
        Over all steps.
    factorisations : int
        Sparse LU factorisations of the step matrix (modified Newton reuses them).
    seconds : float
        Wall time.
    """

    displacement: np.ndarray
    velocity: np.ndarray
    newton_iterations: int
    factorisations: int
    seconds: float


def newmark(solver, load, *, dt: float, n_frames: int, substeps: int, tolerance: float,
            inertia: bool) -> Trajectory:
    """Run ``solver`` from rest under ``load`` ((n_dofs,) or (n_frames, n_dofs));
    :meth:`~.solver.HyperelasticSolver.trajectory` checks the arguments."""
    started = time.perf_counter()
    loads = np.broadcast_to(np.asarray(load, float), (n_frames, solver.n_dofs))[:, solver.free]
    h = dt / substeps
    solver._reset_state()
    given = solver._given
    n_terms = 0
    if solver.prony is not None:
        relative = np.asarray(solver.prony.relative_moduli)[:, None, None, None]
        decay, ramp = (x[:, None, None, None] for x in solver.prony.step_factors(h))
        n_terms = len(relative)
        solver._set_scale(1.0 + float(np.sum(relative * ramp)))
    if solver.viscosity > 0:
        given.rate_coefficient = 2.0 / h
    inertia_matrix = (4.0 / (h * h)) * solver.mass if inertia else None
    newton = ModifiedNewton(solver, inertia_matrix, tolerance)

    n = len(solver.free)
    u, v = np.zeros(n), np.zeros(n)
    a = spla.splu(solver.mass).solve(loads[0]) if inertia else np.zeros(n)
    shape = solver._gradient_shape()
    elastic_stress = np.zeros(shape[:2] + (6,))
    history = np.zeros((n_terms,) + shape[:2] + (6,))
    gradient, gradient_rate = np.zeros(shape) + np.eye(3), np.zeros(shape)
    out_u, out_v = np.zeros((n_frames, solver.n_dofs)), np.zeros((n_frames, solver.n_dofs))
    try:
        for t in range(1, n_frames):
            force = loads[t - 1]
            for _ in range(substeps):
                if n_terms:
                    given.history_stress = np.sum(
                        relative * (decay * history - ramp * elastic_stress[None]), axis=0)
                given.previous_gradient, given.rate_predictor = gradient, -gradient_rate
                if inertia:   # the residual's inertia: M (4/h² (x - u - h v) - a)
                    inertial = inertia_matrix @ (u + h * v) + solver.mass @ a
                    x = newton.solve(u + h * v + 0.25 * h * h * a, force + inertial, t)
                    a_new = 4.0 / (h * h) * (x - u - h * v) - a
                    u, v, a = x, v + 0.5 * h * (a + a_new), a_new
                else:
                    x = newton.solve(u, force, t)
                    u, v = x, 2.0 / h * (x - u) - v
                if n_terms or solver.viscosity > 0:
                    new_stress = solver._elastic_stress(u)
                    new_gradient = given.deformation_gradient
                    if n_terms:
                        history = decay * history + ramp * (new_stress - elastic_stress)
                        elastic_stress = new_stress
                    if solver.viscosity > 0:
                        gradient_rate = given.gradient_rate(new_gradient)
                    gradient = new_gradient
            out_u[t, solver.free] = u
            out_v[t, solver.free] = v
    finally:
        solver._reset_state()
    return Trajectory(out_u, out_v, newton.iterations, newton.factorisations,
                      time.perf_counter() - started)
