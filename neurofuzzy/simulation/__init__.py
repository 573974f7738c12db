"""Time stepping of a model (paper eqs. 3.1–3.6): :func:`simulate` and :func:`step`
(:mod:`~neurofuzzy.simulation.integration`), the stability bound of the step
(:mod:`~neurofuzzy.simulation.stability`) and the steppers that run it, the numpy reference
and the compiled one (:mod:`~neurofuzzy.simulation.steppers`)."""

from .integration import State, Trajectory, check_substeps, internal_forces, simulate, step
from .stability import (STABILITY_SAFETY, StabilityLimit, check_time_step, required_substeps,
                        stability_limit)
from .steppers import euler_update, numba_available

__all__ = [
    "State",
    "Trajectory",
    "StabilityLimit",
    "STABILITY_SAFETY",
    "internal_forces",
    "step",
    "euler_update",
    "simulate",
    "stability_limit",
    "check_time_step",
    "check_substeps",
    "required_substeps",
    "numba_available",
]
