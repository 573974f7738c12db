"""What a gradient fit can say about its result: the lack of fit, the standard errors, what the
data cannot determine, the mesh check and 95 % intervals.

The interval of a parameter combines, in quadrature, its standard error (the larger of the
Gauss–Newton and the two-way cluster-robust estimate, :mod:`.identifiability`, which widens
with residuals correlated along a marker's track or across a frame, as a model that misses
something leaves them) and, after a mesh check (:mod:`.mesh_check`), how far the parameter
moves when the mesh is refined once, times :data:`MESH_ERROR_FACTOR` (the discretisation
error no standard error can see).
Log parameters give intervals that are relative (a factor either way), Poisson's ratio's
logit keeps them inside (0, 0.5).
"""

from __future__ import annotations

import numpy as np

from ..io.writing import json_safe
from .identifiability import analyse
from .lack_of_fit import lack_of_fit

__all__ = ["assess", "intervals", "Z95"]

#: The normal quantile of a two-sided 95 % interval.
Z95 = 1.959964
#: The discretisation error left on the fitted mesh, in moves on the mesh refined once:
#: Richardson's ``2^p / (2^p - 1)`` for order ``p = 1``. Linear tetrahedra converge that slowly
#: in Poisson's ratio near incompressibility (on scikit-fem data at ν = 0.45, 1 cm voxels:
#: ν 0.4225, refined 0.4342, true 0.45, an error of 2.4 moves), faster in E and η.
MESH_ERROR_FACTOR = 2.0
#: The largest move (in the learner's parameters: log moduli and viscosities, logit ν) that
#: one Gauss–Newton step of the mesh check is trusted with; a larger one is refitted. On the
#: 7.5 mm probed block the step moved E, ν and η 0.014, 0.17 and 0.15 against the refit's
#: 0.012, 0.19 and 0.17; on a block of 2 x 2 x 2 cells, E by 1.96 against 1.12.
STEP_TRUSTED = 0.3
#: The most parameters the step takes: each is a tangent of the refined model (eight times
#: the elements, twice the steps), so a fit of every element is checked by the refit, whose
#: L-BFGS gradient costs one adjoint sweep whatever the count.
STEP_COLUMNS = 64


def assess(learner, sensitivity, parameters, experiments, theta, method) -> None:
    """Set the learner's ``lack_of_fit_``, ``identifiability_``, ``std_errors_``,
    ``mesh_check_`` and ``intervals_`` at its result ``theta``."""
    jacobian = None
    if method == "lm":     # the Jacobian's pass gives the residuals too
        jacobian, runs = learner._jacobian(sensitivity, experiments, theta,
                                           [(0,)] * len(experiments), learner.substeps_,
                                           with_runs=True)
    else:
        runs = [sensitivity.run(theta, e, substeps=learner.substeps_) for e in experiments]
    residuals = np.concatenate([run.residuals.ravel() for run in runs])
    learner.lack_of_fit_ = lack_of_fit(experiments, [run.residuals * sensitivity.length_unit
                                                     for run in runs])
    if jacobian is not None and learner._prior_terms is not None:
        # the posterior: the prior's rows count as information too
        jacobian = np.vstack([jacobian, learner._prior_scale
                              * learner._prior_terms.jacobian(theta).toarray()])
        residuals = np.concatenate([residuals, np.zeros(learner._prior_terms.n_rows)])
    shapes = [run.residuals.shape[:2] for run in runs]
    learner.identifiability_ = analyse(
        parameters, theta, jacobian, residuals,
        n_measured=sum(run.n_measured for run in runs), shapes=shapes,
        n_nuisance=3 * sum(rows for _, rows in shapes) if sensitivity.offsets else 0)
    learner.std_errors_ = learner.identifiability_.std_errors
    spread = learner.std_errors_
    learner.mesh_check_ = check = (_mesh_check(learner, sensitivity, parameters, experiments,
                                               theta) if learner.mesh_check else None)
    if check is not None:
        spread = np.sqrt(spread**2 + (MESH_ERROR_FACTOR * check.change) ** 2)
    learner.intervals_ = intervals(parameters, theta, spread)


def _mesh_check(learner, sensitivity, parameters, experiments, theta):
    """The learner's mesh check: one Gauss–Newton step (``"step"``) where it can be trusted,
    else the whole refit, whose ``how`` then says why."""
    from .mesh_check import linearised_mesh_check, mesh_check

    why = None
    if learner.mesh_check == "step" and parameters.size > STEP_COLUMNS:
        why = (f"{parameters.size} parameters: more than {STEP_COLUMNS} columns of the refined "
               "model's Jacobian cost more than the refit")
    elif learner.mesh_check == "step":
        check = linearised_mesh_check(
            learner.model_, experiments, parameters, theta, offsets=sensitivity.offsets,
            prior=(learner._prior_terms, learner._prior_scale))
        if check is None:
            why = "the refined model diverged at the fitted values"
        elif np.max(check.change) > STEP_TRUSTED:
            why = (f"one Gauss-Newton step there moved a value too far to trust, by more than "
                   f"{STEP_TRUSTED:g} in the learner's log or logit parameters")
        else:
            return check
    check = mesh_check(learner, experiments, parameters, theta)
    if why:
        check.how += f" ({why})"
    return check


def intervals(parameters, theta: np.ndarray, spread: np.ndarray) -> dict:
    """``{name: (low, high)}``: 95 % intervals of every parameter in its own units (a tie
    group's shared value), from ``theta ± Z95 · spread`` in the learner's parameters; (NaN,
    NaN) where the spread is unknown, (0 or -inf, inf) where the data do not determine it."""
    names = parameters.names()
    low = parameters.physical(theta - Z95 * spread)
    high = parameters.physical(theta + Z95 * spread)
    unknown = ~np.isfinite(spread) & ~np.isinf(spread)
    low[unknown] = high[unknown] = np.nan
    return {name: (float(a), float(b)) for name, a, b in zip(names, low, high)}


def intervals_dict(learner) -> dict:
    """The JSON of a fit's intervals and mesh check."""
    check = getattr(learner, "mesh_check_", None)
    return json_safe({
        "intervals": {name: list(bounds) for name, bounds in learner.intervals_.items()},
        "intervals_how": ("95 %: the standard error (the larger of the plain and the "
                          "cluster-robust estimate)" + _mesh_part(learner, check)
                          + "; relative (a factor either way) for moduli, viscosities, "
                          "stiffness, damping and masses"),
        "mesh_check": check.to_dict() if check else None})


def _mesh_part(learner, check) -> str:
    """What the intervals hold besides the standard error: the mesh check's move, or, for an
    element model without one, the plain statement that they hold the noise alone."""
    if check is not None:
        return f" and twice the change on the refined mesh ({check.how}), in quadrature"
    if learner.model_.elements is not None:
        return ("; the noise alone: no mesh check, and a coarse mesh biases the values by "
                "more than the noise may show")
    return ""
