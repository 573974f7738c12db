"""How the gradient learner steps through the data: substeps per frame, a start stable at
that step, and whether the markers' rest positions are fitted too."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..experiment import Experiment
from ..model import Model
from ..simulation import stability_limit

__all__ = ["auto_substeps", "stable_start", "stable_at_one_step", "fits_offsets",
           "parameter_bounds", "AUTO_STEP_OMEGA"]

#: Largest ``h·ω_max`` that :func:`auto_substeps` accepts: semi-implicit Euler shifts a mode's
#: frequency by about ``(hω)²/24`` and its damping by about ``hγ/2``.
AUTO_STEP_OMEGA = 0.15

def stable_start(model: Model, h: float) -> Model:
    """Scale all spring constants down until steps of ``h`` are stable (a start that blows up
    gives the optimiser nothing to work with); unchanged when already stable."""
    limit = stability_limit(model)
    if h <= limit.max_step:
        return model
    # h² ω² + 2 h γ scales linearly in a common factor of stiffness and viscosity
    factor = 0.8 * (limit.max_step / h) ** 2
    springs, elements = model.springs, model.elements
    if springs is not None:
        model = model.with_term(springs.replace(stiffness=springs.stiffness * factor,
                                                damping=springs.damping * factor))
    if elements is not None:
        model = model.with_term(elements.replace(youngs_modulus=elements.youngs_modulus * factor,
                                                 viscosity=elements.viscosity * factor))
    return model


def fits_offsets(option: bool | str, experiments: Sequence[Experiment]) -> bool:
    """Whether markers' rest offsets are fitted (``GradientLearner(offsets=...)``)."""
    if option == "auto":
        return any(e.markers is not None for e in experiments)
    if isinstance(option, (bool, np.bool_)):
        return bool(option)
    raise InputError(f"got {option!r}; expected True, False or 'auto'", key="offsets")


def auto_substeps(model: Model, dt: float) -> int:
    """Substeps per frame so that ``h·ω_max <= AUTO_STEP_OMEGA`` and the step is stable.

    Element models take twice the stability bound instead: a mesh's stiffest modes are
    discretisation artefacts (``ω_max`` grows as the mesh is refined) far above the motion a
    recording resolves, and the Richardson extrapolation the learner applies removes the
    first-order bias of the modes that are seen (on scikit-fem continuum data: E, ν and η
    within 1 % at this step, docs/tutorials/springs-or-elements.md).
    """
    limit = stability_limit(model)
    by_stability = dt / limit.max_step
    if model.elements is not None:
        return max(1, int(np.ceil(2.0 * by_stability)))
    by_accuracy = limit.omega_max * dt / AUTO_STEP_OMEGA
    return max(1, int(np.ceil(max(by_accuracy, by_stability))))


def stable_at_one_step(model: Model, experiments: Sequence[Experiment],
                       substeps: int = 1) -> bool:
    """Is one step per frame (the paper's network), or ``substeps`` per frame, stable for
    ``model`` on every experiment?"""
    limit = stability_limit(model).max_step
    return all(e.dt <= substeps * limit for e in experiments)


def parameter_bounds(parameters, theta: np.ndarray, factor: float):
    """``(lower, upper)`` of the learner's parameters: stiffness, viscosity, modulus, mass and
    the Prony terms' relative moduli and times within ``factor`` of their start ``theta``;
    Poisson's ratio between 0.001 and 0.4999.

    (A relaxation the data do not show once drove g to 1e-18 and τ to 0.1 µs, a thousandth
    of a substep: the Prony terms' decay factors and history then underflowed into subnormal
    numbers, which the processor computes a hundred times slower, and one refit of the
    7.5 mm block took three minutes instead of ten seconds.)"""
    lower = np.full_like(theta, -np.inf)
    upper = np.full_like(theta, np.inf)
    span = np.log(factor)
    if "logit_poisson_ratio" in parameters.blocks:
        # Poisson's ratio between 0.001 and 0.4999 (θ = logit 2ν)
        block = parameters.blocks["logit_poisson_ratio"].slice
        lower[block], upper[block] = np.log(0.002 / 0.998), np.log(0.9998 / 0.0002)
    for name in ("log_stiffness", "log_damping", "log_mass", "log_youngs_modulus",
                 "log_viscosity", "log_relaxation_moduli", "log_relaxation_times"):
        if name in parameters.blocks:
            block = parameters.blocks[name].slice
            lower[block] = theta[block] - span
            upper[block] = theta[block] + span
    return lower, upper
