"""The gradient of a pass in the compiled kernels (:mod:`neurofuzzy.kernels.adjoint`): the
forward sweep keeps every substep's state, the backward sweep sums the parameters'
cotangents; :meth:`~._sensitivity.Sensitivity.gradient` calls it when the model allows."""

from __future__ import annotations

import numpy as np

from ..effects.compiled import CUBIC
from ..simulation.threads import element_threads
from ._compiled import CompiledModel, _windows
from ._passes import Run

__all__ = ["compiled_gradient"]


def compiled_gradient(sensitivity, model, experiment, substeps, starts, cotangent=None):
    """:meth:`gradient` in the compiled kernels (:mod:`neurofuzzy.kernels.adjoint`) for
    models of springs and elements (relaxing or not) whose effects the kernels compute
    (:mod:`neurofuzzy.effects.compiled`), learned or not; node masses learned or fixed.
    With ``cotangent`` (shaped as the run's residuals) the backward sweep pulls it back in
    place of the residuals (its entries at gaps left out, as a residual's are): the gradient
    is then ``Jᵀ cotangent``."""
    from ..kernels.adjoint import pull_back

    param = sensitivity.parameters
    compiled = CompiledModel(param, model)
    springs, elements, effects = compiled.springs, compiled.elements, compiled.effects
    n_frames, observation = experiment.n_frames, experiment.observation
    states = {t: sensitivity._window_state(experiment, t, substeps)
              for t in set(int(t) for t in starts) | {0}}
    start_index = _windows(n_frames, states)[0]
    # the forward sweep (simulate's driver), keeping every substep's state
    positions, kept = compiled.frames(experiment, states, substeps=substeps, keep=True)
    h = experiment.dt / substeps
    relax_g, _, relax_column = compiled.relaxation
    mass_column = compiled.masses[0]
    with np.errstate(over="ignore", invalid="ignore"):
        scale = 1.0 / sensitivity.length_unit
        residuals = sensitivity._frame_residuals(observation, positions)
    run = Run(positions=positions, residuals=residuals[1:],
              n_measured=3 * int(observation.seen[1:].sum()))
    loss = 0.5 * float(np.sum(residuals[1:] ** 2))
    grad = np.zeros(param.size)
    if not np.isfinite(loss):
        return float("inf"), grad, run
    if cotangent is not None:           # as a residual: nothing where nothing was measured
        residuals = np.zeros_like(residuals)
        residuals[1:] = cotangent * observation.seen[1:, :, None]
    # ∂L/∂p(t) = Hᵀ r(t) / length_unit, every frame at once
    frame_adjoint = np.ascontiguousarray(np.moveaxis(observation.adjoint(
        np.moveaxis(residuals, 0, 1).reshape(observation.n_rows, -1)).reshape(
        sensitivity.n_nodes, n_frames, 3), 0, 1) * scale)
    # the springs' λ · ∂F by the bases of their magnitudes (x, ẋ and, when learned, x³)
    d_springs = np.zeros((3 if np.any(springs.basis == CUBIC) else 2, len(springs.a)))
    n_elements, nodal = relax_g.shape[0], elements.arrays.nodal
    per_volumetric = sensitivity.n_nodes if nodal else n_elements   # λ, λβ: per node or element
    d_elements = (np.zeros(n_elements), np.zeros(n_elements), np.zeros(per_volumetric),
                  np.zeros(per_volumetric), np.zeros(n_elements))
    g_relax = np.zeros(relax_column.shape)
    g_mass = np.zeros(sensitivity.n_nodes)
    # the learned constant forces' and drag's cotangents (Σ λ_F per node; -Σ λ_F · v) and
    # the elements' strain stiffening's
    learned_effects = effects.drag_column >= 0 or bool(effects.spans)
    g_load = np.zeros((sensitivity.n_nodes if learned_effects else 0, 3))
    g_terms = np.zeros(2)
    pull_back(*compiled.groups(h),
              (h, n_frames, int(substeps), element_threads(compiled.n_elements)), start_index,
              kept, frame_adjoint, (d_springs, d_elements, g_relax, g_mass, g_load, g_terms))
    for span in effects.spans:
        grad[span] += np.einsum("nk,nkp->p", g_load, effects.direction[:, :, span])
    if effects.drag_column >= 0:
        grad[effects.drag_column] += g_terms[0]
    if elements.kappa_column >= 0:
        grad[elements.kappa_column] += g_terms[1]
    learned = mass_column >= 0                          # each free node's log m
    grad += np.bincount(mass_column[learned], g_mass[learned], param.size)
    # the springs' parameters (log s, log c, the spring effects' coefficients), as in the
    # forward kernel
    spring = np.repeat(np.arange(len(springs.a)), np.diff(springs.pointer))
    grad += np.bincount(springs.column, springs.factor * d_springs[springs.basis, spring],
                        param.size)
    if n_elements:
        # the constants' derivatives by the parameters, as in the forward kernel
        element = np.repeat(np.arange(n_elements), np.diff(elements.pointer))
        g_shear, g_shear_rate, g_lam, g_lam_rate, g_law_constant = d_elements
        weights = (elements.d_shear * g_shear[element]
                   + elements.d_shear_rate * g_shear_rate[element])
        if nodal:
            grad += elements.d_node_lam.T @ g_lam + elements.d_node_lam_rate.T @ g_lam_rate
        else:
            weights = weights + (elements.d_lam * g_lam[element]
                                 + elements.d_lam_rate * g_lam_rate[element])
        grad += np.bincount(elements.column, weights, param.size)
        learned = relax_column >= 0                    # log g, log τ of each element's terms
        grad += np.bincount(relax_column[learned], g_relax[learned], param.size)
        # the law constants' log c: dc/d log c = c
        law_constant, column = elements.arrays.law_constant, elements.law_constant_column
        learned = column >= 0
        grad += np.bincount(column[learned], law_constant[learned] * g_law_constant[learned],
                            param.size)
    return loss, grad, run
