"""The gradient learner's two solvers over one stage: Levenberg–Marquardt on the full
Jacobian (:mod:`._lm`) and L-BFGS-B with the adjoint gradient. Each takes the learner, whose
``_residuals``, ``_jacobian`` and ``_record`` count every simulation of the data."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from ..errors import NeurofuzzyError
from . import _passes as passes
from ._lm import levenberg_marquardt
from .identifiability import cluster_meat
from .steps import stable_at_one_step

#: A Jacobian pass costing at most this many residual passes is run with the trial steps
#: after a step accepted at its first trial (:func:`._lm.levenberg_marquardt`'s ``both``): a
#: rejected trial then costs at most 3 passes more, an accepted one saves one.
SPECULATE_COST = 4
#: Jacobians in a row whose Gauss–Newton floor is above ``abandon`` that end a fit: one may
#: be the linearisation of a start far off, which promises too little.
ABANDON_AFTER = 2


def solve_lm(learner, sensitivity, experiments, theta, starts, substeps, lower, upper,
             active, tolerance, abandon=None, guard=False, last=True):
    """The parameters ``theta`` with their ``active`` entries fitted by Levenberg–Marquardt
    (the prior's terms, when the learner has one, stacked under the data's residuals);
    given up, ``learner.abandoned_`` set, once Gauss–Newton predicts at two Jacobians in a
    row that the RMS error per marker cannot come below ``abandon`` (metres). With
    ``guard``: ended, ``learner._left`` set, at a Jacobian whose values are not stable at
    ``substeps`` (:func:`.steps.stable_at_one_step`), and stopped also by steps below the
    cluster-robust standard errors (:mod:`._lm`; trusted only at stable steps: the rounding
    an unstable simulation amplifies widens them, and stopped a fit of a stiff block a
    quarter short of its modulus). ``last`` False: a stage before the last, whose Jacobian
    at the result goes unused (``jacobian_at_end`` of :func:`._lm.levenberg_marquardt`);
    True: the last, whose result's standard errors may take the Jacobian of the point before
    it when the step between is statistically nothing (``learner._last`` then holds it,
    :meth:`._passes.Last.behind`)."""
    def full(x):
        values = theta.copy()
        values[active] = x
        return values

    terms, scale = learner._prior_terms, learner._prior_scale

    def with_prior(x, data):
        return data if terms is None else np.concatenate([data,
                                                          scale * terms.residuals(full(x))])

    def residuals(x):
        return with_prior(x, learner._residuals(sensitivity, experiments, full(x), starts,
                                                substeps))

    taken = []              # the pass of the last Jacobian

    def jacobian(x):
        J = learner._jacobian(sensitivity, experiments, full(x), starts, substeps,
                              columns=active)
        taken[:] = [learner._last]
        if terms is None:
            return J
        return np.vstack([J, scale * terms.jacobian(full(x)).toarray()[:, active]])

    def both(x):           # one pass: the Jacobian's runs hold the residuals at x
        J = jacobian(x)
        return with_prior(x, passes.stacked(learner._last.runs)), J

    # a Jacobian pass simulates the state and ceil(columns / threads) tangents per thread
    threads = max(1, passes.cores() // len(experiments))
    cheap = 1 + -(-len(active) // threads) <= SPECULATE_COST
    strikes = 0             # floors asked about in a row that are above ``abandon``

    def give_up(least):
        nonlocal strikes
        # the cost is half the sum of squares; the runs are the Jacobian's at the point
        above = passes.per_marker(2.0 * least, learner._last.runs,
                                  sensitivity.length_unit) > abandon
        strikes = strikes + 1 if above else 0
        learner.abandoned_ = strikes >= ABANDON_AFTER
        return learner.abandoned_

    def meat(J, r):        # the cluster-robust sandwich's B: clusters of the last runs
        return cluster_meat(J, r, [run.residuals.shape[:2] for run in learner._last.runs])

    def leave(x):
        learner._left = not stable_at_one_step(sensitivity.parameters.model(full(x)),
                                               experiments, substeps)
        return learner._left

    result = levenberg_marquardt(
        residuals, jacobian, theta[active], lower[active], upper[active],
        max_evaluations=int(learner.max_iterations), tolerance=tolerance,
        both=both if cheap else None, give_up=None if abandon is None else give_up,
        meat=meat if guard else None, leave=leave if guard else None,
        jacobian_at_end="near" if last else False)
    if result.jacobian_behind:
        learner._last = learner._last.behind(taken[0])
    return full(result.x)


def solve_lbfgs(learner, sensitivity, experiments, theta, starts, substeps, lower, upper,
                active, tolerance, abandon=None, guard=False, last=True):
    """The parameters ``theta`` with their ``active`` entries fitted by L-BFGS-B with the
    adjoint gradient (for Jacobians too large to hold; ``abandon`` is not used: without a
    Jacobian there is no prediction of the least error; nor are ``guard`` and ``last``)."""
    def objective(x):
        values = theta.copy()
        values[active] = x
        parts = passes.side_by_side(lambda e, s: sensitivity.gradient(
            values, e, substeps=substeps, starts=s), experiments, starts)
        loss = sum(value for value, _, _ in parts)
        grad = np.sum([g for _, g, _ in parts], axis=0)
        runs = [run for _, _, run in parts]
        learner._record(runs, sensitivity.length_unit)
        if learner._prior_terms is not None:
            loss += learner._prior_scale**2 * learner._prior_terms.cost(values)
            grad += learner._prior_scale**2 * learner._prior_terms.gradient(values)
        if not np.isfinite(loss):
            return 1e30, np.zeros_like(x)
        return loss, grad[active]

    bounds = list(zip(np.where(np.isfinite(lower), lower, None)[active],
                      np.where(np.isfinite(upper), upper, None)[active]))
    result = minimize(objective, theta[active], jac=True, method="L-BFGS-B", bounds=bounds,
                      options={"maxiter": int(learner.max_iterations), "ftol": tolerance,
                               "gtol": 1e-12, "maxcor": 30})
    if not np.all(np.isfinite(result.x)):
        raise NeurofuzzyError("the gradient fit diverged; start from plausible parameters")
    values = theta.copy()
    values[active] = result.x
    return values
