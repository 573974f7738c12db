"""The gradient of a pass in the compiled kernels (:mod:`neurofuzzy.kernels.adjoint`): the
forward sweep keeps every substep's state, the backward sweep sums the parameters'
cotangents; :meth:`~._sensitivity.Sensitivity.gradient` calls it when the model allows."""

from __future__ import annotations

import numpy as np

from ..effects.compiled import CUBIC
from ..forces.relaxation import decay
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
    a, b, stiffness, damping, rest, cubic, pointer, column, basis, factor = compiled.springs
    drag, drag_column, direction, _, spans = compiled.effects
    elements = compiled.elements[:13]       # the elements and their constants
    kappa, kappa_column = compiled.elements[-3:-1]      # their strain stiffening
    n_frames, observation = experiment.n_frames, experiment.observation
    states = {t: sensitivity._window_state(experiment, t)
              for t in set(int(t) for t in starts) | {0}}
    start_index = _windows(n_frames, states)[0]
    # the forward sweep (simulate's driver), keeping every substep's state
    positions, (states_p, states_v, states_r, states_f) = compiled.frames(
        experiment, states, substeps=substeps, keep=True)
    h = experiment.dt / substeps
    weight = np.ascontiguousarray(compiled.weight, dtype=float)
    relax_g, times, relax_column = compiled.relaxation
    relax_decay = decay(times, h)
    mass_column, unit_mass_force = compiled.masses
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
    d_springs = np.zeros((3 if np.any(basis == CUBIC) else 2, len(a)))
    n_elements, nodal = relax_g.shape[0], elements[9]
    per_volumetric = sensitivity.n_nodes if nodal else n_elements   # λ, λβ: per node or element
    d_elements = (np.zeros(n_elements), np.zeros(n_elements), np.zeros(per_volumetric),
                  np.zeros(per_volumetric), np.zeros(n_elements))
    g_relax = np.zeros(relax_column.shape)
    g_mass = np.zeros(sensitivity.n_nodes)
    # the learned constant forces' and drag's cotangents (Σ λ_F per node; -Σ λ_F · v) and
    # the elements' strain stiffening's
    learned_effects = drag_column >= 0 or bool(spans)
    g_load = np.zeros((sensitivity.n_nodes if learned_effects else 0, 3))
    g_terms = np.zeros(2)
    pull_back(a, b, stiffness, damping, rest, cubic, None if elements[0] is None else elements,
              kappa, relax_g, relax_decay, drag, weight, h, n_frames, int(substeps),
              start_index, states_p, states_v, states_r, states_f, unit_mass_force,
              frame_adjoint, d_springs, d_elements, g_relax, g_mass, g_load, g_terms,
              element_threads(compiled.n_elements))
    for span in spans:
        grad[span] += np.einsum("nk,nkp->p", g_load, direction[:, :, span])
    if drag_column >= 0:
        grad[drag_column] += g_terms[0]
    if kappa_column >= 0:
        grad[kappa_column] += g_terms[1]
    learned = mass_column >= 0                          # each free node's log m
    grad += np.bincount(mass_column[learned], g_mass[learned], param.size)
    # the springs' parameters (log s, log c, the spring effects' coefficients), as in the
    # forward kernel
    spring = np.repeat(np.arange(len(a)), np.diff(pointer))
    grad += np.bincount(column, factor * d_springs[basis, spring], param.size)
    if n_elements:
        # the constants' derivatives by the parameters, as in the forward kernel
        (pointer, column, d_shear, d_shear_rate, d_lam, d_lam_rate, d_node_lam,
         d_node_lam_rate) = compiled.elements[13:21]
        element = np.repeat(np.arange(n_elements), np.diff(pointer))
        g_shear, g_shear_rate, g_lam, g_lam_rate, g_stiffening = d_elements
        weights = d_shear * g_shear[element] + d_shear_rate * g_shear_rate[element]
        if nodal:
            grad += d_node_lam.T @ g_lam + d_node_lam_rate.T @ g_lam_rate
        else:
            weights = weights + d_lam * g_lam[element] + d_lam_rate * g_lam_rate[element]
        grad += np.bincount(column, weights, param.size)
        learned = relax_column >= 0                    # log g, log τ of each element's terms
        grad += np.bincount(relax_column[learned], g_relax[learned], param.size)
        # the Yeoh elements' log c: dc/d log c = c
        stiffening, stiffening_column = elements[4], compiled.elements[-1]
        learned = stiffening_column >= 0
        grad += np.bincount(stiffening_column[learned],
                            stiffening[learned] * g_stiffening[learned], param.size)
    return loss, grad, run
