"""Time stepping of a model (paper eqs. 3.1–3.6): :func:`simulate` and :func:`step`
(:mod:`~neurofuzzy.simulation.integration`), the stability bound of the step
(:mod:`~neurofuzzy.simulation.stability`) and the steppers that run it, the numpy reference
and the compiled one (:mod:`~neurofuzzy.simulation.steppers`); the force's stiffness and damping
matrices (:mod:`~neurofuzzy.simulation.tangents`) and the static equilibrium under driven
boundaries and loads (:mod:`~neurofuzzy.simulation.static`); backward Euler steps at a
simulator's step (:mod:`~neurofuzzy.simulation.implicit`)."""

from .integration import State, Trajectory, check_substeps, internal_forces, simulate, step
from .stability import (STABILITY_SAFETY, StabilityLimit, check_time_step, required_substeps,
                        stability_limit)
from .implicit import simulate_implicit
from .static import ConvergenceError, Driven, Equilibrium, equilibrium
from .steppers import euler_update
from .tangents import Tangents, tangents

__all__ = [
    "State",
    "Trajectory",
    "StabilityLimit",
    "STABILITY_SAFETY",
    "internal_forces",
    "step",
    "euler_update",
    "simulate",
    "simulate_implicit",
    "stability_limit",
    "check_time_step",
    "check_substeps",
    "required_substeps",
    "Driven",
    "Equilibrium",
    "equilibrium",
    "ConvergenceError",
    "Tangents",
    "tangents",
]
