"""Levenberg–Marquardt on the normal equations, for the gradient learner.

scipy's ``least_squares(method="trf")`` decomposes the dense Jacobian (an SVD of m × n) at
every iteration; with m ≈ 10⁴ residuals and n ≈ 10² parameters that SVD was most of a fit.
Here each iteration forms ``JᵀJ`` (n × n) once and solves the damped normal equations
``(JᵀJ + μ D) δ = -Jᵀr`` (``D`` = diag(JᵀJ), Marquardt's scaling, so the step does not depend
on the parameters' units) by Cholesky, for as many trial ``μ`` as a rejected step needs. The
squared condition number of ``JᵀJ`` is harmless here: its eigenvalues are damped by ``μ D``,
and the parameters the data cannot determine are reported by the identifiability analysis,
not resolved by the solver.

BLAS runs on one thread here: the matrices are small (n × n, n ≈ 10²), and a multithreaded
Cholesky of them took 70 ms instead of 0.2 ms on a 2-core machine with another job running.

Stopping: the relative cost change or the relative step below ``tolerance`` (as before); a
step that is statistically nothing, every parameter moving less than ``STEP_OF_STD_ERROR`` of
its standard error (``σ² (JᵀJ)⁻¹`` with ``σ²`` the residual variance, or, given the
residuals' clusters, the cluster-robust ``(JᵀJ)⁻¹ B (JᵀJ)⁻¹`` the fit reports, whichever
calls the step nothing); or residuals at the rounding floor of the simulation (RMS below
``FLOOR``). On exact data the standard errors shrink with the residual, so the statistical
test never stops a fit early; on noisy data, or for a model that lacks an effect, it ends
the long plateaus where the cost creeps down by amounts far below anything the data can tell
apart. Both tests come before the next Jacobian, the costliest pass, so the stop does not
pay for one it would not use; with ``jacobian_at_end="near"`` they are also predicted before
a trial step is run, so that the step that ends the fit is run without its Jacobian (the
standard errors take the one a step behind, :func:`levenberg_marquardt`).

The robust errors matter for a model that lacks something. Its residuals are smooth along a
marker's track and across a frame, so the data hold far fewer independent values than their
number, and ``σ² (JᵀJ)⁻¹`` is far too small: steps that change nothing the data can tell
apart still count as significant on it (``tests/test_lm.py``: a curve the model cannot
follow, fitted to the same cost within 10⁻⁴ in fewer evaluations).

A fit whose simulation runs beyond its stable step creeps as well, on the rounding the
unstable modes amplify; that is the learner's to prevent (``leave``, below, and
:class:`~.gradient.GradientLearner`'s ``stable_steps``), and the robust stop is asked for
only then: the amplified rounding widens the robust errors too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

#: A step smaller than this fraction of every parameter's standard error ends the fit (a
#: tenth: the estimate is then within a tenth of its uncertainty of where more steps go).
STEP_OF_STD_ERROR = 0.1
#: Residual RMS (the residuals' own unit, lengths over the length unit) at which nothing is
#: left to fit: positions agree to about a thousand rounding errors of double precision.
FLOOR = 1e-12
#: ``give_up`` is asked where Gauss–Newton predicts that at most this share of the
#: cost can go: near enough a minimum for the linearisation to be taken at its word...
TRUSTED_FLOOR = 0.5
#: ... or where its prediction agrees within this fraction with the one at the last
#: Jacobian: two linearisations at different points that promise the same least cost.
AGREEING_FLOORS = 0.1
#: Starting Marquardt damping ``μ`` (steps solve ``(JᵀJ + μ diag JᵀJ) δ = -Jᵀr``).
INITIAL_DAMPING = 1e-3


@dataclass
class Solution:
    """Where the solver stopped, its cost ``½‖r‖²``, the residual evaluations it used and
    why it stopped."""

    x: np.ndarray
    cost: float
    evaluations: int
    reason: str
    #: The last Jacobian the solver took is that of the point before ``x``, which the step
    #: to ``x`` left within ``STEP_OF_STD_ERROR`` of that Jacobian's standard errors (or
    #: at the rounding floor): good enough for the standard errors at ``x``
    #: (``jacobian_at_end="near"``). False: the caller has the Jacobian at ``x``, or none.
    jacobian_behind: bool = False


def _damped_step(normal, gradient, damping):
    """``δ`` solving ``(JᵀJ + μ D) δ = -Jᵀr``; None when the matrix is not positive definite."""
    diagonal = np.diag(normal).copy()
    diagonal[diagonal <= 0] = max(float(diagonal.max(initial=0.0)), 1.0) * 1e-12
    matrix = normal + damping * np.diag(diagonal)
    try:
        factor = scipy.linalg.cho_factor(matrix, check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return None
    step = -scipy.linalg.cho_solve(factor, gradient, check_finite=False)
    return step if np.all(np.isfinite(step)) else None


def levenberg_marquardt(residuals, jacobian, x0, lower, upper, *, max_evaluations: int,
                        tolerance: float, both=None, give_up=None, meat=None,
                        leave=None, jacobian_at_end: bool | str = True) -> Solution:
    """Minimise ``½‖r(x)‖²`` within the box ``[lower, upper]`` (steps are clipped to it).

    ``residuals(x)`` returns r (m,), ``jacobian(x)`` returns J (m, n). ``max_evaluations``
    bounds the residual evaluations (as ``max_nfev`` did).

    ``both(x)``, when given, returns ``(r, J)`` from one pass (a tangent sweep simulates the
    state too), for a Jacobian that costs a few residual passes: a trial step is then
    evaluated with its Jacobian when the last step was accepted at its first trial (the first
    Gauss–Newton step from a start within a factor of the truth, and near the solution nearly
    every step, are) and the step is not predicted to end the fit, so an accepted step needs no
    second pass, and the Jacobian at the result is there for the standard errors. The steps
    taken are the same either way; only the passes that compute them differ.
    ``jacobian_at_end`` False says that the caller has no use for the Jacobian at the result
    (a stage before the last, whose next stage starts other windows): a trial step whose
    acceptance would end the fit (by its predicted decrease or by its length, both known
    before it is run) is then evaluated by its residuals alone. True (the default): by its
    predicted decrease alone, since an ending step's length leaves the Jacobian at the result
    to the standard errors. ``"near"``: the standard errors will do with the Jacobian of a
    point that the last step leaves within ``STEP_OF_STD_ERROR`` of that Jacobian's standard
    errors, at the cost Gauss–Newton predicts for it (or at the rounding floor, where the
    standard errors are rounding); such a step is statistically nothing and ends the fit, so
    it is evaluated by its residuals alone too, and the solution says, by
    ``jacobian_behind``, when the Jacobian last taken is the one to use. (Noisy data end that
    way: the step that ends the fit was taken with a Jacobian for the standard errors alone,
    one pass of a fit's eight or so.)

    ``give_up(floor)``, when given, is asked whether to stop with the cost Gauss–Newton
    predicts as the least reachable from the point (:func:`floor`), at every Jacobian where
    that prediction is at least ``TRUSTED_FLOOR`` of the cost or agrees with the last
    Jacobian's within ``AGREEING_FLOORS``; a stop it asks for ends the fit with the reason
    ``"given up"``. Farther from a minimum the linearisation can promise
    far too little: fitting a damped oscillation from a start at 200 times the least cost,
    the first three floors were 39, 7 and 3 times it (each far below the last). A fit that
    creeps with small damped steps can promise the same all along: the relaxation refit of a
    27 %-strain block (its floors 0.48–0.50 of the cost, within 6 % of each other over eight
    Jacobians while the cost fell 3 %) was asked about only at its last.

    ``meat(J, r)``, when given, returns ``B`` of the cluster-robust sandwich at a Jacobian
    (:func:`~.identifiability.cluster_meat`; None when the clusters are too few): a step is
    then also statistically nothing when it is below ``STEP_OF_STD_ERROR`` of the robust
    standard errors (module docstring).

    ``leave(x)``, when given, is asked at every Jacobian whether the point is outside the
    range the residuals can be trusted in (the simulation's stable step); yes ends the fit
    there with the reason ``"left the trusted range"``.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _minimise(residuals, jacobian, both, x0, lower, upper, max_evaluations,
                         tolerance, give_up, meat, leave, jacobian_at_end)


def floor(normal, gradient, cost) -> float:
    """Gauss–Newton's prediction of the least cost reachable from a point: the minimum of
    the linearised cost ``½‖r + Jδ‖² = cost - ½ gᵀ(JᵀJ)⁻¹g`` (``g = Jᵀr``), bounds ignored, so
    that the prediction is never above what the linearisation allows. Far from a minimum
    the linearisation can promise too much or too little; near one it is the minimum."""
    step = _damped_step(normal, gradient, 1e-12)
    return cost if step is None else max(cost + 0.5 * float(gradient @ step), 0.0)


def _minimise(residuals, jacobian, both, x0, lower, upper, max_evaluations,
              tolerance, give_up=None, meat=None, leave=None,
              jacobian_at_end=True) -> Solution:
    x = np.clip(np.asarray(x0, float), lower, upper)
    r, J = both(x) if both is not None else (residuals(x), None)
    cost = 0.5 * float(r @ r)
    evaluations = 1
    if not np.isfinite(cost):
        return Solution(x, cost, evaluations, "the start is not finite")
    if J is None:
        J = jacobian(x)
    normal = J.T @ J
    robust = None if meat is None else _robust_covariance(normal, meat(J, r))
    damping = INITIAL_DAMPING
    near = jacobian_at_end == "near"
    speculate = True        # evaluate the next trial with its Jacobian (``both``)
    last_floor = None       # the floor at the last Jacobian
    while True:
        if leave is not None and leave(x):
            return Solution(x, cost, evaluations, "left the trusted range")
        gradient = J.T @ r
        if give_up is not None:
            least = floor(normal, gradient, cost)
            agrees = (last_floor is not None
                      and abs(least - last_floor) <= AGREEING_FLOORS * last_floor)
            last_floor = least
            if (least >= TRUSTED_FLOOR * cost or agrees) and give_up(least):
                return Solution(x, cost, evaluations, "given up")
        trials = 0
        while True:
            if evaluations >= max_evaluations:
                return Solution(x, cost, evaluations, "evaluation limit")
            step = _damped_step(normal, gradient, damping)
            if step is None:
                damping *= 10.0
                if damping > 1e16:
                    return Solution(x, cost, evaluations, "no descent direction")
                continue
            trial = np.clip(x + step, lower, upper)
            step = trial - x
            predicted = -(gradient @ step + 0.5 * step @ normal @ step)
            J_trial = None
            # not for a step predicted to end the fit (its Jacobian would go unused)
            ends = predicted <= tolerance * cost or (
                not jacobian_at_end and _short(step, trial, tolerance)) or (
                near and _nothing(step, normal, robust, cost - predicted, len(r)))
            if speculate and both is not None and not ends:
                r_trial, J_trial = both(trial)
            else:
                r_trial = residuals(trial)
            evaluations += 1
            trials += 1
            cost_trial = 0.5 * float(r_trial @ r_trial)
            if np.isfinite(cost_trial) and cost_trial < cost:
                break
            damping *= 4.0
            speculate = False    # the next trials of this step: residuals only
            if damping > 1e16 or not np.any(step):
                return Solution(x, cost, evaluations, "no step lowers the cost")
        ratio = (cost - cost_trial) / predicted if predicted > 0 else 0.0
        damping *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
        decrease = cost - cost_trial
        x, r, cost = trial, r_trial, cost_trial
        at_floor = _at_floor(cost, len(r))
        # the standard errors of the last Jacobian: the step just taken is that one's step
        insignificant = (_insignificant(step, normal, cost, len(r))
                         or _insignificant_robust(step, robust))
        # the Jacobian last taken will do at x: for a result reached without its own
        behind = near and J_trial is None and (at_floor or insignificant)
        if decrease <= tolerance * cost or _short(step, x, tolerance):
            return Solution(x, cost, evaluations, "converged", behind)
        if at_floor:
            return Solution(x, cost, evaluations, "residuals at the rounding floor", behind)
        if insignificant:
            return Solution(x, cost, evaluations, "step below the standard errors", behind)
        J = J_trial if J_trial is not None else jacobian(x)
        normal = J.T @ J
        robust = None if meat is None else _robust_covariance(normal, meat(J, r))
        speculate = trials == 1


def _nothing(step, normal, robust, cost, m) -> bool:
    """Is the step from the Jacobian whose ``JᵀJ`` is ``normal`` (``robust``: its
    cluster-robust covariance, or None) statistically nothing at ``cost`` (``m``
    residuals): below ``STEP_OF_STD_ERROR`` of the standard errors, or ending at the
    rounding floor?"""
    return bool(_at_floor(cost, m) or _insignificant(step, normal, cost, m)
                or _insignificant_robust(step, robust))


def _at_floor(cost, m) -> bool:
    """Are ``m`` residuals of cost ``½‖r‖²`` at the rounding floor (RMS below ``FLOOR``)?"""
    return bool(2.0 * cost <= FLOOR**2 * m)


def _short(step, x, tolerance) -> bool:
    """Does the step to ``x`` end the fit by its length (``‖δ‖ ≤ tol (tol + ‖x‖)``)?"""
    return bool(np.linalg.norm(step) <= tolerance * (tolerance + np.linalg.norm(x)))


def _insignificant(step, normal, cost, m) -> bool:
    """Is ``step`` below ``STEP_OF_STD_ERROR`` of the standard error along every direction
    (eigenvectors of ``normal`` = JᵀJ, ``m`` residuals)?

    Measured in the directions of ``JᵀJ``, not per parameter: with many parameters (one per
    element) some combinations are barely determined, which makes every parameter's own
    standard error large, while the well-determined combinations may still be moving.
    """
    n = len(step)
    if m <= n or not np.any(step):
        return False
    variance = 2.0 * cost / (m - n)
    try:
        values, vectors = np.linalg.eigh(normal)
    except np.linalg.LinAlgError:
        return False
    # the step along direction k against that direction's standard error σ / √λ_k
    whitened = np.abs(vectors.T @ step) * np.sqrt(np.maximum(values, 0.0))
    return bool(np.all(whitened <= STEP_OF_STD_ERROR * np.sqrt(variance)))


def _robust_covariance(normal, meat) -> np.ndarray | None:
    """The cluster-robust sandwich ``(JᵀJ)⁺ B (JᵀJ)⁺`` (None without ``B``)."""
    if meat is None:
        return None
    try:
        values, vectors = np.linalg.eigh(normal)
    except np.linalg.LinAlgError:
        return None
    keep = values > 1e-12 * max(float(values.max(initial=0.0)), 1e-300)
    inverse = (vectors[:, keep] / values[keep]) @ vectors[:, keep].T
    return inverse @ meat @ inverse


def _insignificant_robust(step, covariance) -> bool:
    """Is ``step`` below ``STEP_OF_STD_ERROR`` of the robust standard error along every
    direction of ``covariance`` (eigenvectors; a direction without variance counts only when
    the step has no component along it)?"""
    if covariance is None or not np.any(step):
        return False
    try:
        values, vectors = np.linalg.eigh(covariance)
    except np.linalg.LinAlgError:
        return False
    along = np.abs(vectors.T @ step)
    scale = np.sqrt(np.maximum(values, 0.0))
    tiny = scale <= 1e-300
    if np.any(along[tiny] > 0):
        return False
    return bool(np.all(along[~tiny] <= STEP_OF_STD_ERROR * scale[~tiny]))
