"""Fit E, ν and η through backward Euler steps (issue 47: a fit through implicit steps).

A model run by a simulator at its own step moves as its implicit integrator makes it move
(:mod:`neurofuzzy.simulation.implicit`, which reproduces MuJoCo's ``discrete`` integrator on
the textbook element). :func:`fit_implicit` identifies the elements' E, ν and η per group as
that integrator uses them, from marker recordings whose frames are its steps (or a whole
number of them): Levenberg–Marquardt (:mod:`._lm`) on the markers' residuals with the exact
Jacobian of the converged steps
(:func:`~neurofuzzy.simulation.implicit_derivatives.implicit_sensitivities`, checked against
central differences), in ``log E``, ``logit 2ν`` and ``log η``, E within a factor
:data:`FACTOR` of the start, η within it above and :data:`VISCOSITY_FLOOR` of it below, ν
within (0, 0.5).

What it is for, and what it is not yet: data made with the same integrator come back within
0.1 % (``tests/test_implicit.py``); fitting a recording of real tissue (or another solver) for a
simulator's step, and writing the result to that simulator (issue 47's ``fit --target``), is
not built on it yet.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..experiment import Experiment
from ..model import Model
from ..simulation.implicit import simulate_implicit
from ..simulation.implicit_derivatives import PARAMETERS, implicit_sensitivities
from ._lm import levenberg_marquardt

__all__ = ["ImplicitFit", "fit_implicit", "FACTOR", "VISCOSITY_FLOOR"]

#: E is fitted within this factor of its start, η up to it and down to a thousandth of it (a
#: large implicit step damps by itself, and the fit may want almost no viscosity beside it)
FACTOR = 10.0
VISCOSITY_FLOOR = 1e-3


@dataclass(frozen=True)
class ImplicitFit:
    """A fit through backward Euler steps.

    Attributes
    ----------
    model : Model
        The start with the fitted E, ν, η of every group.
    values : dict
        ``{name: (n_groups,) array}`` of
        :data:`~neurofuzzy.simulation.implicit_derivatives.PARAMETERS`.
    rms_error : float
        Root-mean-square marker distance (m), frames 1 onwards, as
        :func:`~neurofuzzy.experiment.rms_error` counts it.
    evaluations : int
        Simulations with their derivatives.
    reason : str
        Why Levenberg–Marquardt stopped.
    at_bound : tuple of str
        The constants that ended at a bound of the search (in some group): the data ask for
        a value beyond it, or do not tell it (η where the step's own damping exceeds it).
    """

    model: Model
    values: dict
    rms_error: float
    evaluations: int
    reason: str
    at_bound: tuple = ()


def fit_implicit(model: Model, experiments: Experiment | Sequence[Experiment], *,
                 substeps: int = 1, groups: np.ndarray | None = None,
                 max_evaluations: int = 40, tolerance: float = 1e-10,
                 scheme: str = "euler") -> ImplicitFit:
    """Fit every group's E, ν, η so that backward Euler (or BDF2) steps of
    ``h = dt / substeps`` reproduce the experiments' markers (module docstring).

    Parameters
    ----------
    model : Model
        The start: elements only (no springs, effects or relaxation), one E, ν, η per group.
    experiments : Experiment or sequence of them
        Their load, start and measured markers (or nodes).
    substeps : int
        Implicit steps per frame.
    groups : (n_elements,) int, optional
        The element groups fitted apart (default: one for all; ``model.elements.region`` for
        one per region).
    max_evaluations, tolerance
        Levenberg–Marquardt's budget and relative stop.
    scheme : {"euler", "bdf2"}
        The steps' scheme (:func:`~neurofuzzy.simulation.implicit.simulate_implicit`).
    """
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    if not experiments:
        raise InputError("no experiment to fit", key="experiments")
    if model.elements is None:
        raise InputError("the implicit fit needs an element model", key="model")
    groups = (np.zeros(model.mesh.n_tetrahedra, np.intp) if groups is None
              else np.asarray(groups, np.intp))
    # the model, the groups and their shared values checked before any work
    implicit_sensitivities(model, dt=experiments[0].dt, n_frames=1, groups=groups,
                           scheme=scheme)
    n_groups = int(groups.max(initial=0)) + 1

    def constants(x):
        E, y, eta = np.split(np.asarray(x, float), 3)
        return np.exp(E), 0.5 / (1.0 + np.exp(-y)), np.exp(eta)

    def model_at(x):
        E, nu, eta = constants(x)
        return model.with_elements(youngs_modulus=E[groups], poisson_ratio=nu[groups],
                                   viscosity=eta[groups])

    def both(x):
        current = model_at(x)
        E, nu, eta = constants(x)
        chain = np.concatenate([E, nu * (1 - 2 * nu), eta])      # d constant / d x
        rows, columns = [], []
        for experiment in experiments:
            run, derivatives = implicit_sensitivities(
                current, dt=experiment.dt, n_frames=experiment.n_frames,
                external_forces=experiment.external_forces,
                initial_positions=experiment.initial_positions(),
                initial_velocities=experiment.initial_velocities(), substeps=substeps,
                groups=groups, scheme=scheme)
            observation = experiment.observation
            seen = observation.seen[1:]
            rows.append(observation.residuals(run.positions)[1:][seen].ravel())
            moved = np.stack([observation.frames(derivatives[:, c])[1:][seen].ravel()
                              for c in range(derivatives.shape[1])], axis=1)
            columns.append(moved * chain[None, :])
        return np.concatenate(rows), np.concatenate(columns)

    first = {}
    for name in PARAMETERS:
        first[name] = np.zeros(n_groups)
        first[name][groups] = np.asarray(getattr(model.elements, name), float)
    nu0 = first["poisson_ratio"]
    x0 = np.concatenate([np.log(first["youngs_modulus"]), np.log(nu0 / (0.5 - nu0)),
                         np.log(first["viscosity"])])
    spread = np.log(FACTOR)
    lower = np.concatenate([x0[:n_groups] - spread, np.full(n_groups, -12.0),
                            x0[2 * n_groups:] + np.log(VISCOSITY_FLOOR)])
    upper = np.concatenate([x0[:n_groups] + spread, np.full(n_groups, 12.0),
                            x0[2 * n_groups:] + spread])
    def residuals(x):
        """The residuals alone (a trial step): the same converged steps, no derivatives."""
        current = model_at(x)
        rows = []
        for experiment in experiments:
            run = simulate_implicit(current, dt=experiment.dt, n_frames=experiment.n_frames,
                                    external_forces=experiment.external_forces,
                                    initial_positions=experiment.initial_positions(),
                                    initial_velocities=experiment.initial_velocities(),
                                    substeps=substeps, iterations=50, tolerance=1e-11,
                                    scheme=scheme)
            observation = experiment.observation
            rows.append(observation.residuals(run.positions)[1:][observation.seen[1:]].ravel())
        return np.concatenate(rows)

    solution = levenberg_marquardt(residuals, lambda x: both(x)[1], x0, lower,
                                   upper, max_evaluations=max_evaluations,
                                   tolerance=tolerance, both=both)
    count = sum(int(e.observation.seen[1:].sum()) for e in experiments)
    E, nu, eta = constants(solution.x)
    edge = (np.isclose(solution.x, lower, rtol=0.0, atol=1e-6)
            | np.isclose(solution.x, upper, rtol=0.0, atol=1e-6)).reshape(3, n_groups)
    return ImplicitFit(model=model_at(solution.x),
                       values=dict(zip(PARAMETERS, (E, nu, eta))),
                       rms_error=float(np.sqrt(2 * solution.cost / max(count, 1))),
                       evaluations=solution.evaluations, reason=solution.reason,
                       at_bound=tuple(name for name, hit in zip(PARAMETERS, edge)
                                      if hit.any()))
