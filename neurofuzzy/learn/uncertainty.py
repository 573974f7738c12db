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

from ..errors import InputError
from ..formatting import json_safe
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
        # (or the solver's last, a step behind that is statistically nothing)
        jacobian, runs = learner._jacobian(sensitivity, experiments, theta,
                                           [(0,)] * len(experiments), learner.substeps_,
                                           with_runs=True, near=True)
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
    check, skipped = _mesh_check(learner, sensitivity, parameters, experiments, theta)
    learner.mesh_check_ = check
    if check is not None:
        spread = np.sqrt(spread**2 + (MESH_ERROR_FACTOR * check.change) ** 2)
    learner.intervals_ = intervals(parameters, theta, spread)
    learner.intervals_hold_ = _holds(learner.model_, check, skipped)


def _mesh_check(learner, sensitivity, parameters, experiments, theta):
    """``(check, skipped)``: the learner's mesh check, or None and why none ran.

    ``"auto"`` (the default): one Gauss–Newton step on the refined mesh for an element model
    of at most :data:`STEP_COLUMNS` parameters, none otherwise; a step that moves a value by
    more than :data:`STEP_TRUSTED` is kept and said to be untrusted (the refit would cost
    about sixteen fits). ``"step"``: the step where it can be trusted, else the whole refit,
    whose ``how`` says why. ``"refit"`` or True: the whole refit."""
    from .mesh_check import linearised_mesh_check, mesh_check

    how = learner.mesh_check
    if not how:
        return None, "no mesh check (mesh_check=False, --no-mesh-check)"
    if how == "auto" and learner.model_.elements is None:
        return None, "a spring network, whose constants belong to its mesh"
    if how == "auto" and parameters.size > STEP_COLUMNS:
        return None, (f"a fit of {parameters.size} parameters is not checked by default; the "
                      "refit on the refined mesh checks it at about sixteen fits' cost "
                      "(mesh_check='refit', --mesh-check-refit)")
    why = None
    if how == "step" and parameters.size > STEP_COLUMNS:
        why = (f"{parameters.size} parameters: more than {STEP_COLUMNS} columns of the refined "
               "model's Jacobian cost more than the refit")
    elif how in ("step", "auto"):
        try:
            check = linearised_mesh_check(
                learner.model_, experiments, parameters, theta, offsets=sensitivity.offsets,
                prior=(learner._prior_terms, learner._prior_scale))
        except InputError as error:      # learned masses, tie groups refinement splits
            if how != "auto":
                raise
            return None, f"no mesh check for this fit: {error.detail}"
        untrusted = (f"one Gauss-Newton step there moved a value too far to trust, by more "
                     f"than {STEP_TRUSTED:g} in the learner's log or logit parameters")
        if check is None and how == "auto":
            return None, "the model refined once diverged at the fitted values"
        if check is None:
            why = "the refined model diverged at the fitted values"
        elif np.max(check.change) > STEP_TRUSTED and how == "auto":
            check.how += (f" ({untrusted}: the mesh is too coarse for these values; the refit, "
                          "mesh_check='refit', measures the move)")
            return check, None
        elif np.max(check.change) > STEP_TRUSTED:
            why = untrusted
        else:
            return check, None
    check = mesh_check(learner, experiments, parameters, theta)
    if why:
        check.how += f" ({why})"
    return check, None


def _holds(model, check, skipped: str | None) -> str:
    """What a fit's 95 % intervals hold, said once for the fit's text, its report and its
    JSON: the noise and the mesh (the move on the mesh refined once), or the noise alone and
    why (for an element model, with the warning that a coarse mesh biases every value)."""
    if check is not None:
        return check.holds()
    if model.elements is None:
        return "the noise"
    return (f"the noise alone: {skipped}; a coarse mesh biases every value by more than the "
            "noise may show")


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
                          "cluster-robust estimate)"
                          + (" and twice the change on the refined mesh, in quadrature"
                             if check is not None else "")
                          + "; relative (a factor either way) for moduli, viscosities, "
                          "stiffness, damping and masses"),
        "intervals_hold": getattr(learner, "intervals_hold_", None),
        "mesh_check": check.to_dict() if check else None})
