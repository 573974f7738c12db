"""Fit E, ν and η through backward Euler steps (issue 47: a fit through implicit steps).

A model run by a simulator at its own step moves as its implicit integrator makes it move
(:mod:`neurofuzzy.simulation.implicit`, which reproduces MuJoCo's ``discrete`` integrator on
the textbook element). :func:`fit_implicit` identifies the elements' E, ν and η per group as
that integrator uses them, from marker recordings whose frames are its steps (or a whole
number of them): Levenberg–Marquardt (:mod:`._lm`) on the markers' residuals with the exact
Jacobian of the converged steps
(:func:`~neurofuzzy.simulation.implicit_derivatives.implicit_sensitivities`, checked against
central differences), in ``log E``, ``logit 2ν`` and ``log η``, E within a factor
:data:`FACTOR` of the start, η within :data:`VISCOSITY_CEILING` times it and
:data:`VISCOSITY_FLOOR` of it, ν within (0, 0.5).

A recording of a displacement-controlled test in time (issue 45's plate ramped by a stage,
issue 46's tool pressed along its path) carries its driven sets or tool
(:attr:`~neurofuzzy.experiment.Experiment.driven`, ``.tool``, one row per frame) and, where a
load cell recorded it, the force (``.reaction``: the first driven set's reaction, or the
tool's force on the body, per frame). The markers and the force then enter one objective,
each residual divided by its own noise (given, or estimated from the residuals of a first fit
and the fit repeated): the markers' noise σ_m per coordinate, the load cell's σ_f per
component. An estimated noise comes from the third differences in time of the residuals
(:func:`neurofuzzy.noise.time_noise`): a misfit is smooth in time and does not become "noise"
(their RMS, which the estimate was before, let a force the model could not follow lose its
weight: FElupe's plate ramp at ν 0.49 on a coarse mesh estimated the load cell's noise at
22 % of its peak for 1 % put in, and E came out 71 % low).

Data made with the same integrator come back within 0.1 % (``tests/test_implicit.py``);
FElupe's dynamic plate ramp (another solver's quadratic tetrahedra) within the figures of
``benchmarks/plate_ramp.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..experiment import Experiment
from ..model import Model
from ..noise import time_noise
from ..simulation.implicit import simulate_implicit
from ..simulation.implicit_derivatives import PARAMETERS, implicit_sensitivities
from ._lm import levenberg_marquardt

__all__ = ["ImplicitFit", "fit_implicit", "FACTOR", "VISCOSITY_FLOOR", "VISCOSITY_CEILING"]

#: E is fitted within this factor of its start, η up to it and down to a thousandth of it (a
#: large implicit step damps by itself, and the fit may want almost no viscosity beside it)
FACTOR = 10.0
VISCOSITY_FLOOR = 1e-3
#: η may rise to this factor of its start: the words give a tissue's viscosity within an
#: order of magnitude or two at best (the tutorial's gel: 2.4 Pa·s from the words, 30 fitted)
VISCOSITY_CEILING = 100.0
#: An estimated noise is at least this share of the body's size (markers) or the load cell's
#: largest reading (force): residuals of data without noise (or a force that is all zero)
#: would otherwise weigh their rows infinitely
NOISE_FLOOR = 1e-9
#: The markers' noise assumed before it is estimated, as a share of the body's size
MARKER_NOISE_SHARE = 1e-4
#: The load cell's noise assumed before it is estimated, as a share of its largest reading
FORCE_NOISE_SHARE = 1e-2


@dataclass(frozen=True)
class ImplicitFit:
    """A fit through backward Euler (or BDF2) steps.

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
    force_rms_error : float or None
        Root-mean-square difference of the predicted and measured force per component (N),
        frames 1 onwards; None without a load cell.
    marker_noise, force_noise : float or None
        The σ_m (m) and σ_f (N) each residual was divided by (None: markers alone, whose
        fit does not depend on it).
    estimated : tuple of str
        Which of ``"markers"`` and ``"force"`` had their noise estimated from the residuals.
    mesh_check : dict or None
        Set by :func:`~.implicit_mesh_check.implicit_mesh_check`: per constant its
        ``"mesh"``, ``"refined"`` and ``"extrapolated"`` values (each (n_groups,)), and the
        two meshes' ``"elements"``.
    """

    model: Model
    values: dict
    rms_error: float
    evaluations: int
    reason: str
    at_bound: tuple = ()
    force_rms_error: float | None = None
    marker_noise: float | None = None
    force_noise: float | None = None
    estimated: tuple = ()
    mesh_check: dict | None = None

    def extrapolated(self, name: str) -> np.ndarray:
        """(n_groups,): constant ``name`` extrapolated to a fine mesh by the mesh check, or
        the fitted value without one."""
        if self.mesh_check is None:
            return np.asarray(self.values[name])
        return np.asarray(self.mesh_check[name]["extrapolated"])


def fit_implicit(model: Model, experiments: Experiment | Sequence[Experiment], *,
                 substeps: int = 1, groups: np.ndarray | None = None,
                 max_evaluations: int = 40, tolerance: float = 1e-10,
                 scheme: str = "euler", marker_noise: float | None = None,
                 force_noise: float | None = None) -> ImplicitFit:
    """Fit every group's E, ν, η so that backward Euler (or BDF2) steps of
    ``h = dt / substeps`` reproduce the experiments' markers, and a load cell's force where
    there is one (module docstring).

    Parameters
    ----------
    model : Model
        The start: elements only (no springs or effects; Prony terms held), one E, ν, η per
        group.
    experiments : Experiment or sequence of them
        Their load, start, driven sets or tool, measured markers (or nodes) and load cell.
    substeps : int
        Implicit steps per frame.
    groups : (n_elements,) int, optional
        The element groups fitted apart (default: one for all; ``model.elements.region`` for
        one per region).
    max_evaluations, tolerance
        Levenberg–Marquardt's budget and relative stop.
    scheme : {"euler", "bdf2"}
        The steps' scheme (:func:`~neurofuzzy.simulation.simulate_implicit`).
    marker_noise, force_noise : float, optional
        σ_m (m) and σ_f (N); with a load cell, each one not given is estimated from the
        residuals of a first fit and the fit is repeated from there.
    """
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    if not experiments:
        raise InputError("no experiment to fit", key="experiments")
    if model.elements is None:
        raise InputError("the implicit fit needs an element model", key="model")
    forced = [e for e in experiments if e.reaction is not None]
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

    def passes(x, noise, derivatives):
        """The residuals, the markers' (m) then the load cells' (N), each divided by its
        ``noise``; with ``derivatives``, ``(residuals, their Jacobian by x)``."""
        current = model_at(x)
        E, nu, eta = constants(x)
        chain = np.concatenate([E, nu * (1 - 2 * nu), eta])      # d constant / d x
        rows, columns, tail, ends = [], [], [], []           # the markers', the force's
        framed[:] = [], []                     # the residuals by frame, the last pass's
        for experiment in experiments:
            start = {"dt": experiment.dt, "n_frames": experiment.n_frames,
                     "external_forces": experiment.external_forces,
                     "initial_positions": experiment.initial_positions(),
                     "initial_velocities": experiment.initial_velocities(),
                     "substeps": substeps, "scheme": scheme,
                     "driven": experiment.driven, "tool": experiment.tool}
            if derivatives:
                run, d_x, d_f = implicit_sensitivities(current, groups=groups, forces=True,
                                                       **start)
            else:
                run = simulate_implicit(current, iterations=50, tolerance=1e-11, **start)
            observation = experiment.observation
            seen = observation.seen[1:]
            error = observation.residuals(run.positions)[1:]
            rows.append(error[seen].ravel() / noise[0])
            framed[0].append(np.where(seen[..., None], error, np.nan))
            if derivatives:
                columns.append(np.stack([observation.frames(d_x[:, c])[1:][seen].ravel()
                                         for c in range(d_x.shape[1])], axis=1)
                               * chain[None, :] / noise[0])
            if experiment.reaction is not None:
                force, d_force = _force(experiment, run, d_f if derivatives else None)
                tail.append((force[1:] - experiment.reaction[1:]).ravel() / noise[1])
                framed[1].append(force[1:] - experiment.reaction[1:])
                if derivatives:
                    ends.append(d_force[1:].transpose(0, 2, 1).reshape(-1, len(chain))
                                * chain[None, :] / noise[1])
        r = np.concatenate(rows + tail)
        measured[np.asarray(x, float).tobytes()] = r * np.repeat(noise, [sum(map(len, rows)),
                                                                        sum(map(len, tail))])
        return (r, np.concatenate(columns + ends)) if derivatives else r

    measured = {}                  # the unweighted residuals of every point evaluated
    framed = [[], []]

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
                            x0[2 * n_groups:] + np.log(VISCOSITY_CEILING)])
    count = sum(int(e.observation.seen[1:].sum()) for e in experiments)
    size = float(np.ptp(model.mesh.rest_positions, axis=0).max())
    peak = max((float(np.abs(e.reaction).max()) for e in forced), default=0.0)
    noise = (marker_noise or MARKER_NOISE_SHARE * size,
             force_noise or FORCE_NOISE_SHARE * peak or 1.0)
    if not forced:
        noise = (marker_noise or 1.0, 1.0)
    estimated = () if not forced else tuple(
        name for name, given in (("markers", marker_noise), ("force", force_noise))
        if given is None)
    evaluations, x = 0, x0
    for _ in range(2 if estimated else 1):
        solution = levenberg_marquardt(lambda x: passes(x, noise, False),
                                       lambda x: passes(x, noise, True)[1], x, lower, upper,
                                       max_evaluations=max_evaluations, tolerance=tolerance,
                                       both=lambda x: passes(x, noise, True))
        evaluations += solution.evaluations
        x = solution.x
        markers = measured.get(np.asarray(x, float).tobytes())
        if markers is None:
            markers = passes(x, (1.0, 1.0), False)
        force_residuals = markers[3 * count:]
        markers = markers[:3 * count]
        if estimated:                # the noise of what was not given, from the residuals
            passes(x, (1.0, 1.0), False)                  # (framed: the residuals at x)
            found = [time_noise(series) for series in framed]
            noise = (marker_noise or max(found[0] or float(np.sqrt(np.mean(markers ** 2))),
                                         NOISE_FLOOR * size),
                     force_noise or max(found[1] or float(np.sqrt(np.mean(force_residuals**2))),
                                        NOISE_FLOOR * (peak or 1.0)))
    E, nu, eta = constants(x)
    edge = (np.isclose(x, lower, rtol=0.0, atol=1e-6)
            | np.isclose(x, upper, rtol=0.0, atol=1e-6)).reshape(3, n_groups)
    return ImplicitFit(model=model_at(x), values=dict(zip(PARAMETERS, (E, nu, eta))),
                       rms_error=float(np.sqrt(np.sum(markers ** 2) / max(count, 1))),
                       evaluations=evaluations, reason=solution.reason,
                       at_bound=tuple(name for name, hit in zip(PARAMETERS, edge)
                                      if hit.any()),
                       force_rms_error=(float(np.sqrt(np.mean(force_residuals ** 2)))
                                        if forced else None),
                       marker_noise=noise[0] if forced or marker_noise else None,
                       force_noise=noise[1] if forced else None,
                       estimated=estimated)


def _force(experiment, run, derivatives):
    """``(force, its derivatives or None)`` per frame: what ``experiment``'s load cell reads
    in ``run``, the tool's force on the body or the first driven set's reaction."""
    if experiment.tool is not None:
        return run.tool_forces, derivatives and derivatives.tool_forces
    return run.reactions[:, 0], derivatives and derivatives.reactions[:, :, 0]
