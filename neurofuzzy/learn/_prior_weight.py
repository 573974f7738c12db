"""The prior's weight for the gradient learner: ``w = α σ²`` with ``σ`` the marker noise,
``α`` given or chosen by the discrepancy principle (:func:`set_prior`).

The learner keeps the prior's terms in ``_prior_terms`` and ``√w`` in ``_prior_scale``; its
solvers add them to the residuals (Levenberg–Marquardt) or the cost (L-BFGS).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..noise import marker_noise, noise_level
from ..progress import Progress

__all__ = ["set_prior", "MAX_PRIOR_FITS", "MAX_PRIOR_ALPHA"]

#: Fits the discrepancy principle may spend choosing the prior's weight (L-BFGS).
MAX_PRIOR_FITS = 5
#: The prior's weight stays within this factor of the Bayesian one.
MAX_PRIOR_ALPHA = 1e4
#: With L-BFGS, the search stops weakening the prior once a tenfold weaker one took the
#: misfit less than this share of the way down to the noise (:func:`_bracket`).
MIN_PROGRESS = 0.25


def set_prior(learner, parameters, sensitivity, experiments, theta, substeps, fit, method,
              active) -> tuple[np.ndarray, bool]:
    """The prior's terms and weight on ``learner``; with ``weight="auto"``, ``α`` by the
    discrepancy principle (:func:`_discrepancy`). ``fit(start, substeps, windows)`` is the
    learner's fit at the current weight. Returns a start for the main fit and whether it is
    already the fit at the chosen weight with ``substeps`` (the search's, whole
    trajectories)."""
    prior = learner.prior
    terms = prior.terms(parameters)
    noise = noise_level(experiments)
    # noise-free data: a prior at the noise level of 0.1 ‰ of the motion, which only
    # settles what the data leave open
    motion = max(float(np.nanmax(np.abs(np.nan_to_num(
        e.observation.values - e.observation.values[:1])))) for e in experiments)
    sigma = max(noise, 1e-4 * motion) / sensitivity.length_unit
    learner._prior_terms = terms
    learner.prior_ = {"noise": sigma * sensitivity.length_unit, "noise_estimated": noise,
                      "rows": terms.n_rows, **prior.to_dict()}
    if prior.weight != "auto":
        learner._prior_scale = np.sqrt(float(prior.weight)) * sigma
        learner.prior_.update(alpha=float(prior.weight), how="given", fits=0)
        return theta, False
    return _discrepancy(learner, sensitivity, experiments, theta, substeps, fit, method,
                        active, sigma), True


def _discrepancy(learner, sensitivity, experiments, theta, substeps, fit, method, active,
                 sigma):
    """The discrepancy principle: the largest ``α`` whose fit leaves a residual no larger
    than noise would (``‖r‖² ≤ m σ² + 2 √(2m) σ²``, two standard deviations of χ²_m;
    with a Jacobian also at most the unregularised residual plus ``n σ²``).

    From the Bayesian weight ``α = 1``: with Levenberg–Marquardt, the Gauss–Newton
    prediction of the residual at every ``α`` of a grid (one Jacobian, one small solve
    per ``α``) chooses the weight, and one more fit takes it; with L-BFGS (no Jacobian),
    fits at ``α`` ten times apart bracket it. Returns the parameters of the last fit."""
    m = sum(3 * int(e.observation.seen[1:].sum()) for e in experiments)   # measured values
    bound = np.sqrt(1.0 + 2.0 * np.sqrt(2.0 / max(m, 1)))      # RMS / σ allowed
    progress = Progress("prior weight (discrepancy principle)", MAX_PRIOR_FITS,
                        learner.progress)
    tried, scale = {}, sigma            # α → (RMS / noise, parameters); w = α scale²

    def misfit(log_alpha, start):
        learner._prior_scale = np.exp(0.5 * log_alpha) * scale
        found = fit(start, substeps, ())
        runs = [sensitivity.run(found, e, substeps=substeps) for e in experiments]
        total = sum(float(np.sum(run.residuals**2)) for run in runs)
        ratio = np.sqrt(total / m) / sigma if np.isfinite(total) else np.inf
        tried[log_alpha] = (ratio, found)
        progress.update(len(tried), f"α {np.exp(log_alpha):.3g}, RMS / noise {ratio:.3g}")
        return runs

    runs = misfit(0.0, theta)
    # the noise again, from the fit's error: smooth model error leaves first differences
    # that are mostly noise, a sharper estimate than the data's third differences
    residual_noise = marker_noise(np.concatenate([run.residuals for run in runs], axis=1),
                                  np.ones(1))
    if 0 < residual_noise < sigma:
        tried = {a: (v * sigma / residual_noise, t) for a, (v, t) in tried.items()}
        sigma = residual_noise
        learner.prior_["noise"] = sigma * sensitivity.length_unit
    theta = tried[0.0][1]
    predicted = None
    if method == "lm":
        residuals = np.concatenate([run.residuals.ravel() for run in runs])
        log_alpha, predicted, bound = _predict_alpha(
            learner, sensitivity, experiments, theta, residuals, substeps, active, sigma,
            scale, m, bound)
        if log_alpha != 0.0:
            misfit(log_alpha, theta)
    else:
        _bracket(tried, misfit, bound)
    # the largest weight within the noise, else the one closest to it
    within = [a for a, (v, _) in tried.items() if v <= bound]
    log_alpha = max(within) if within else min(tried, key=lambda a: tried[a][0])
    learner._prior_scale = np.exp(0.5 * log_alpha) * scale
    learner.prior_.update(alpha=float(np.exp(log_alpha) * (scale / sigma) ** 2),
                          how="discrepancy principle", fits=len(tried),
                          rms_over_noise=float(tried[log_alpha][0]),
                          rms_over_noise_allowed=float(bound), reaches_noise=bool(within))
    if predicted is not None:
        learner.prior_["rms_over_noise_predicted"] = predicted
    return tried[log_alpha][1]


def _bracket(tried, misfit, bound) -> None:
    """Fits at ``α`` ten times apart until the bound lies between two of them (then one
    in the middle), each from the nearest fit so far (L-BFGS: no Jacobian to predict with).

    The search stops early when a tenfold weaker prior took the misfit less than
    :data:`MIN_PROGRESS` of the way down to the noise: what stays above the noise is then
    model error (a coarse mesh, a missing effect), which a weaker prior would only let the
    items absorb. On scikit-fem data of the probed block fitted element by element on
    7.5 mm voxels, the RMS went 1.22, 1.20, 1.19, 1.19, 1.19 times the noise over
    ``α`` = 1 … 10⁻⁴: two fits instead of five."""
    step = np.log(10.0)
    while len(tried) < MAX_PRIOR_FITS:
        below = [a for a, (v, _) in tried.items() if v <= bound]
        above = [a for a, (v, _) in tried.items() if v > bound]
        if below and above and min(above) - max(below) <= step / 2:
            return
        if not below and len(above) >= 2:
            weakest, next_weakest = sorted(above)[:2]
            gained = tried[next_weakest][0] - tried[weakest][0]
            if gained < MIN_PROGRESS * (tried[next_weakest][0] - bound):
                return          # what the data leave above the noise is not the prior's
        if below and above:
            log_alpha = 0.5 * (max(below) + min(above))
        elif below:
            log_alpha = max(below) + step
        else:
            log_alpha = min(above) - step
        if abs(log_alpha) > np.log(MAX_PRIOR_ALPHA):
            return
        misfit(log_alpha, tried[min(tried, key=lambda a: abs(a - log_alpha))][1])


def _predict_alpha(learner, sensitivity, experiments, theta, r, substeps, active, sigma,
                   scale, m, bound) -> tuple[float, float, float]:
    """Gauss–Newton prediction, around the fit ``theta`` at ``α = 1`` (data residuals
    ``r``), of the RMS residual (in noise units) at every ``α`` of a grid; the largest
    ``α`` predicted within the bound (else the grid's smallest), its prediction and the
    bound.

    The bound is also at most the residual of the fit without a prior (predicted at
    ``α = 0``) plus ``n σ²`` for ``n`` free parameters, what fitting them to noise takes
    away: with few well-determined parameters the prior then moves them by no more than
    their standard errors, whatever the small error of the noise estimate."""
    starts = [(0,)] * len(experiments)
    J = learner._jacobian(sensitivity, experiments, theta, starts, substeps)[:, active]
    P = learner._prior_terms.jacobian(theta)[:, active].toarray()
    q = learner._prior_terms.residuals(theta)
    normal, gradient = J.T @ J, J.T @ r
    prior_normal, prior_gradient = P.T @ P, P.T @ q
    grid = np.log(10.0) * np.arange(np.log10(MAX_PRIOR_ALPHA), -3.01, -0.25)

    def predict(w):
        matrix = normal + w * prior_normal
        matrix[np.diag_indices_from(matrix)] += 1e-12 * max(float(np.trace(matrix)), 1e-300)
        try:
            step = -scipy.linalg.solve(matrix, gradient + w * prior_gradient,
                                       assume_a="pos", check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return np.inf
        return np.sqrt(float(np.sum((r + J @ step) ** 2)) / m) / sigma

    unregularised = predict(0.0)
    if np.isfinite(unregularised):
        bound = min(bound, np.sqrt(unregularised**2 + J.shape[1] / m))
    chosen, prediction = grid[-1], np.inf
    for log_alpha in grid:                       # from the strongest prior down
        predicted = predict(np.exp(log_alpha) * scale**2)
        if not np.isfinite(predicted):
            continue
        chosen, prediction = log_alpha, predicted
        if predicted <= bound:
            break
    return float(chosen), float(prediction), float(bound)
