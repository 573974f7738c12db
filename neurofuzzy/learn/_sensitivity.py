"""Exact derivatives of the discrete simulator (semi-implicit Euler, eqs. 3.1–3.6).

Two ways through the same step ``F = F(p, v; θ) + f_ext``, ``v' = v + h W F``, ``p' = p + h v'``
(``W = 1/m``, zero at fixed nodes):

- forward (tangent-linear) sensitivities ``∂p(t)/∂θ`` for all parameters at once, giving the
  Jacobian of the residuals for Gauss–Newton / Levenberg–Marquardt and standard errors;
- the discrete adjoint (reverse mode), giving the gradient of ``½ Σ |r|²`` in one backward
  sweep whatever the number of parameters, for L-BFGS on large problems.

Both are exact for the discrete model (checked against central finite differences in
``tests/test_gradient.py``). Trajectories may be cut into windows whose first frame is reset to
the measurement (multiple shooting, the paper's teacher forcing): positions from the data and
velocities from the backward difference of the measured positions.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp

from ..effects import per_unit_mass_force
from ..effects.compiled import element_constants
from ..errors import InputError
from ..experiment import Experiment
from ..forces import incidence, tetrahedron_geometry
from ..observation import remove_offsets
from ..simulation import euler_update
from ._compiled import CompiledModel
from ._compiled_gradient import compiled_gradient
from ._passes import Run, cores
from ._parameters import (ELEMENT_BLOCKS, Parameterization, element_directions,
                          stiffening_columns)

__all__ = ["Sensitivity", "Run"]


class Sensitivity:
    """Simulation with derivatives for one parameterisation (arrays reused across passes).

    Parameters
    ----------
    parameters : Parameterization
        Which parameters are free.
    length_unit : float
        Residuals are divided by it (dimensionless residuals; e.g. the mean spring length).
    backend : {"auto", "numpy", "numba"}
        Forward passes in the compiled kernel (:mod:`neurofuzzy.kernels.sensitivity`, one call
        per experiment; ``"auto"`` and ``"numba"``) or the numpy reference path.
    offsets : bool
        Fit every measured row's constant offset (the markers' rest positions as nuisance
        parameters, :func:`~neurofuzzy.observation.remove_offsets`): residuals, Jacobians and
        gradients are those of the projected residuals.
    """

    def __init__(self, parameters: Parameterization, length_unit: float, *,
                 backend: str = "auto", offsets: bool = False):
        if backend not in ("auto", "numpy", "numba"):
            raise InputError(f"got {backend!r}; expected 'auto', 'numpy' or 'numba'",
                             key="backend")
        self.parameters = parameters
        self.backend = backend
        self.offsets = bool(offsets)
        model = parameters.base
        self.length_unit = float(length_unit)
        self.n_nodes = model.n_nodes
        self.incidence = incidence(model.mesh)
        # (n_ties * n_nodes, n_springs): spring j into the block of its tie group
        self.tie_incidence = (self.incidence.grouped(parameters.tied.tie,
                                                     parameters.tied.n_ties)
                              if parameters.learn_springs else None)
        if model.elements is not None:         # the three element blocks lie side by side
            self.element_slice = slice(parameters.blocks[ELEMENT_BLOCKS[0]].start,
                                       parameters.blocks[ELEMENT_BLOCKS[-1]].stop)

    @property
    def compiled(self) -> bool:
        """Do forward passes run in the compiled kernel (not the numpy reference)?"""
        return self.backend != "numpy"

    @property
    def compiled_gradient(self) -> bool:
        """Does :meth:`gradient` run in the compiled kernels? Wherever the forward passes do
        (every effect the kernels compute, learned or not; masses learned or fixed)."""
        return self.compiled

    def _stiffening_forces(self, model, p, v):
        """``(local, columns, block)``: the Yeoh elements' per-corner forces per unit
        ``log c`` (K, 4, 3), every element's ``log_stiffening`` column and the block (None
        without Yeoh elements)."""
        block = self.parameters.blocks.get("log_stiffening")
        if block is None:
            return None, None, None
        shear = element_constants(model)[1]["shear"]
        return (model.elements.stiffening_forces(model, p, v, shear),
                stiffening_columns(self.parameters, model), block)

    # -- forces of the model's terms ----------------------------------------------------------
    @staticmethod
    def _spring_state(model, p, v):
        """The springs' :class:`~neurofuzzy.forces.SpringState` at ``(p, v)`` (None without
        springs): computed once per substep for the force and its derivatives."""
        return None if model.springs is None else model.springs.state(model, p, v)

    @staticmethod
    def _force(model, p, v, state) -> np.ndarray:
        """(N, 3) every force term (no external load), the springs from ``state``."""
        springs = model.springs
        force = np.zeros((model.n_nodes, 3)) if springs is None else springs.force_of_state(
            model, state)
        for term in model.force_terms[springs is not None:]:   # elements and effects
            force += term.force(model, p, v)
        return force

    def _force_tangent(self, model, state, p, v, tp, tv, directions) -> np.ndarray:
        """(N, P, 3): ``∂F/∂p · tp + ∂F/∂v · tv + ∂F/∂θ`` for every parameter direction
        (``directions``: :func:`element_directions` of ``model``, for element models)."""
        param = self.parameters
        springs = model.springs
        d_force = (np.zeros_like(tp) if springs is None
                   else springs.state_jvp(model, p, v, tp, tv, state))
        for term in model.force_terms[springs is not None:]:
            d_force += term.state_jvp(model, p, v, tp, tv)
        if param.learn_springs:
            templates = springs.parameter_templates(state)
            n_ties = param.tied.n_ties
            for name, values in (("log_stiffness", springs.stiffness),
                                 ("log_damping", springs.damping)):
                per_spring = values[:, None] * templates[name[4:]]     # ∂f/∂log θ
                d_force[:, param.blocks[name].slice] += (
                    self.tie_incidence @ per_spring).reshape(n_ties, self.n_nodes, 3
                                                             ).transpose(1, 0, 2)
        if model.elements is not None:
            d_force[:, self.element_slice] += model.elements.parameter_jvp(model, p, v,
                                                                           directions)
            local, columns, block = self._stiffening_forces(model, p, v)
            if block is not None:
                yeoh = np.flatnonzero(columns >= 0)
                direction = sp.csr_matrix(
                    (np.ones(len(yeoh)), (yeoh, columns[yeoh] - block.start)),
                    shape=(len(columns), block.stop - block.start))
                geometry = tetrahedron_geometry(model.mesh)
                d_force[:, block.slice] += (geometry.corner_matrix(local, self.n_nodes)
                                            @ direction).toarray().reshape(
                    self.n_nodes, 3, -1).transpose(0, 2, 1)
        for i, effect in enumerate(param.effects):
            d_force[:, param.blocks[f"effect:{i}"].slice] += effect.parameter_jacobian(
                model, p, v)
        return d_force

    def _window_state(self, experiment: Experiment, start: int):
        """Positions and velocities at a window start, from the measurement."""
        if start == 0:
            return experiment.initial_positions(), experiment.initial_velocities()
        if not experiment.complete:
            raise InputError("windows (multiple shooting) need every free node measured at "
                             "every frame",
                             source=experiment.source, key="observed")
        p = experiment.positions[start].copy()
        v = (experiment.positions[start] - experiment.positions[start - 1]) / experiment.dt
        v[experiment.mesh.fixed] = 0.0
        return p, v

    # -- forward passes -----------------------------------------------------------------------
    def run(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
            starts=(0,), tangents: bool = False, threads: int | None = 1) -> Run:
        """Simulate ``experiment`` with parameters ``theta``; optionally forward sensitivities
        (in the compiled kernel split by columns over ``threads`` threads: each simulates the
        state and carries its share of the tangents; None: the cores the kernels may use)."""
        threads = cores() if threads is None else threads
        param = self.parameters
        model = param.model(theta)
        if self.compiled:
            return self._compiled_run(model, experiment, substeps, starts, tangents,
                                      threads if tangents else 1)
        weight = model.node_inverse_mass[:, None]          # (N, 1)
        h = experiment.dt / substeps
        loads = experiment.forces_per_frame()
        # the measured rows (tracked nodes or embedded markers); gaps carry no residual
        observation = experiment.observation
        seen = observation.seen
        n_frames, n_params = experiment.n_frames, param.size
        starts = set(int(t) for t in starts) | {0}
        blocks = param.blocks
        mass_rows = (np.arange(blocks["log_mass"].start, blocks["log_mass"].stop)
                     if param.learn_masses else None)
        directions = element_directions(model) if model.elements is not None and tangents else None

        positions = np.empty((n_frames, self.n_nodes, 3))
        jacobian = (np.empty((n_frames - 1, observation.n_rows, 3, n_params)) if tangents
                    else None)
        p = v = tp = tv = None
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            for t in range(n_frames):
                if t in starts:
                    p, v = self._window_state(experiment, t)
                    if tangents:                 # node-major tangents (N, P, 3)
                        tp = np.zeros((self.n_nodes, n_params, 3))
                        tv = np.zeros((self.n_nodes, n_params, 3))
                    if t > 0:
                        positions[t] = p
                        if tangents:
                            jacobian[t - 1] = 0.0
                        continue
                else:
                    for _ in range(substeps):
                        state = self._spring_state(model, p, v)
                        force = self._force(model, p, v, state) + loads[t - 1]
                        if tangents:
                            d_force = self._force_tangent(model, state, p, v, tp, tv,
                                                          directions)
                            if mass_rows is not None:      # ∂(W F)/∂log m = -W F_inertial
                                nodes = param.free_nodes
                                inertial = force - per_unit_mass_force(model, p, v)
                                d_force[nodes, mass_rows] -= inertial[nodes]
                            tp, tv = tp.copy(), tv.copy()
                            euler_update(tp, tv, d_force, weight, h)
                        p, v = p.copy(), v.copy()
                        euler_update(p, v, force, weight, h)
                    if tangents:
                        jacobian[t - 1] = (observation.apply(tp).transpose(0, 2, 1)
                                           / self.length_unit * seen[t][:, None, None])
                positions[t] = p
            residuals = self._projected(observation.residuals(positions)[1:]
                                        / self.length_unit, seen[1:], jacobian)
        return Run(positions=positions, residuals=residuals,
                   n_measured=3 * int(seen[1:].sum()), jacobian=jacobian)

    def _projected(self, residuals, seen, jacobian=None) -> np.ndarray:
        """``residuals`` (frames 1..) with the rows' offsets removed when they are fitted
        (and ``jacobian`` projected in place)."""
        if not self.offsets:
            return residuals
        return remove_offsets(residuals, seen, jacobian)

    def _compiled_run(self, model, experiment, substeps, starts, tangents, threads) -> Run:
        states = {t: self._window_state(experiment, t) for t in set(int(t) for t in starts)
                  | {0}}
        compiled = CompiledModel(self.parameters, model)
        # a thread's share of the columns costs one simulation more than the share itself:
        # split only into shares of at least one column each
        bounds = np.linspace(0, compiled.n_params, min(threads, compiled.n_params) + 1)
        shares = [(int(a), int(b)) for a, b in zip(bounds[:-1].round(), bounds[1:].round())]
        # windows are independent when no element relaxes (no internal variables go on from
        # one to the next): each thread then takes a run of whole windows with every column,
        # and no thread simulates the state of another's frames
        spans = (_window_spans(sorted(states), experiment.n_frames, threads)
                 if tangents and threads > 1 and not model.n_relaxation_terms else [])

        if len(spans) > 1 or len(shares) > 1:      # each thread writes its part of one array
            n_frames = experiment.n_frames
            jacobian = np.empty((n_frames - 1, experiment.observation.n_rows, 3,
                                 compiled.n_params))
            positions = np.empty((n_frames, model.n_nodes, 3))
            parts = ([{"frames": span} for span in spans] if len(spans) > 1
                     else [{"columns": columns} for columns in shares])

            def part(options):
                return compiled.run(experiment, states, substeps=substeps,
                                    scale=1.0 / self.length_unit, tangents=True,
                                    jacobian=jacobian, positions=positions, **options)

            with ThreadPoolExecutor(max_workers=len(parts)) as pool:
                list(pool.map(part, parts))
        else:
            positions, jacobian = compiled.run(experiment, states, substeps=substeps,
                                               scale=1.0 / self.length_unit,
                                               tangents=tangents)
        observation = experiment.observation
        with np.errstate(over="ignore", invalid="ignore"):
            residuals = self._projected(observation.residuals(positions)[1:]
                                        / self.length_unit, observation.seen[1:], jacobian)
        return Run(positions=positions, residuals=residuals,
                   n_measured=3 * int(observation.seen[1:].sum()), jacobian=jacobian)

    # -- reverse pass -------------------------------------------------------------------------
    def gradient(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
                 starts=(0,), cotangent=None) -> tuple[float, np.ndarray, Run]:
        """``(½ Σ r², ∂/∂θ, run)`` by the discrete adjoint (one forward, one backward sweep).

        ``cotangent`` (compiled models only; shaped as the run's residuals): pull it back
        instead of the residuals, for ``Jᵀ cotangent`` (every parameter's column against
        one vector, in one backward sweep)."""
        param = self.parameters
        model = param.model(theta)
        if self.compiled_gradient:
            return compiled_gradient(self, model, experiment, substeps, starts, cotangent)
        if cotangent is not None:
            raise ValueError("a cotangent of one's own needs the compiled gradient")
        weight = model.node_inverse_mass[:, None]
        h = experiment.dt / substeps
        loads = experiment.forces_per_frame()
        observation = experiment.observation
        n_frames = experiment.n_frames
        starts = set(int(t) for t in starts) | {0}
        fixed = model.mesh.fixed

        # forward sweep, keeping every substep's start state
        states = []
        positions = np.empty((n_frames, self.n_nodes, 3))
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            for t in range(n_frames):
                if t in starts:
                    p, v = self._window_state(experiment, t)
                    positions[t] = p
                    continue
                for _ in range(substeps):
                    states.append((t, p, v))
                    force = self._force(model, p, v, self._spring_state(model, p, v)
                                        ) + loads[t - 1]
                    p, v = p.copy(), v.copy()
                    euler_update(p, v, force, weight, h)
                positions[t] = p
        scale = 1.0 / self.length_unit
        with np.errstate(over="ignore", invalid="ignore"):
            residuals = self._frame_residuals(observation, positions)
        run = Run(positions=positions, residuals=residuals[1:],
                  n_measured=3 * int(observation.seen[1:].sum()))
        loss = 0.5 * float(np.sum(residuals[1:] ** 2))
        grad = np.zeros(param.size)
        if not np.isfinite(loss):
            return float("inf"), grad, run

        # backward sweep
        lam_p = np.zeros((self.n_nodes, 3))
        lam_v = np.zeros((self.n_nodes, 3))
        index = len(states)
        n_ties = param.tied.n_ties
        tie = param.tied.tie
        directions = element_directions(model) if model.elements is not None else None
        for t in range(n_frames - 1, 0, -1):
            if t in starts:
                lam_p[:] = 0.0
                lam_v[:] = 0.0
                continue
            lam_p += observation.adjoint(residuals[t]) * scale     # ∂L/∂p(t)
            for _ in range(substeps):
                index -= 1
                _, p, v = states[index]
                state = self._spring_state(model, p, v)
                force = self._force(model, p, v, state) + loads[t - 1]
                # p' = p + h v'
                lam_vnew = lam_v + h * lam_p
                lam_vnew[fixed] = 0.0
                # v' = v + h W F
                lam_force = h * weight * lam_vnew
                if param.learn_masses:
                    nodes = param.free_nodes
                    inertial = force - per_unit_mass_force(model, p, v)
                    grad[param.blocks["log_mass"].slice] -= np.einsum(
                        "ij,ij->i", lam_vnew[nodes], h * weight[nodes] * inertial[nodes])
                springs = model.springs
                if springs is None:
                    d_p, d_v = np.zeros_like(lam_force), np.zeros_like(lam_force)
                else:
                    d_p, d_v, per_spring = springs.vjp(model, lam_force, state)
                if param.learn_springs:
                    for name, values in (("log_stiffness", springs.stiffness),
                                         ("log_damping", springs.damping)):
                        grad[param.blocks[name].slice] += np.bincount(
                            tie, values * per_spring[name[4:]], n_ties)
                if model.elements is not None:
                    per_element = model.elements.parameter_vjp(model, p, v, lam_force)
                    for name, direction in directions.items():
                        grad[self.element_slice] += direction.T @ per_element[name]
                    local, columns, block = self._stiffening_forces(model, p, v)
                    if block is not None:
                        geometry = tetrahedron_geometry(model.mesh)
                        per_yeoh = np.einsum("ejk,ejk->e", lam_force[geometry.nodes], local)
                        yeoh = columns >= 0
                        grad += np.bincount(columns[yeoh], per_yeoh[yeoh], param.size)
                for i, effect in enumerate(param.effects):
                    jac = effect.parameter_jacobian(model, p, v)
                    grad[param.blocks[f"effect:{i}"].slice] += np.einsum("ipj,ij->p", jac,
                                                                         lam_force)
                for term in model.force_terms[springs is not None:]:
                    e_p, e_v = term.state_vjp(model, p, v, lam_force)
                    d_p += e_p
                    d_v += e_v
                lam_p = lam_p + d_p
                lam_v = lam_vnew + d_v
        return loss, grad, run

    def _frame_residuals(self, observation, positions) -> np.ndarray:
        """(n_frames, n_rows, 3) residuals in length units, frame 0 included (zero), the
        later frames projected when offsets are fitted (the adjoint's seed)."""
        residuals = observation.residuals(positions) / self.length_unit
        residuals[1:] = self._projected(residuals[1:], observation.seen[1:])
        return residuals


def _window_spans(starts: list[int], n_frames: int, threads: int) -> list[tuple[int, int]]:
    """Frames ``(a, b)`` of up to ``threads`` runs of whole windows (``starts`` the windows'
    first frames, ascending), cut at the window starts nearest to equal shares."""
    inner = np.array(starts[1:])
    cuts = set()
    for k in range(1, threads):
        if inner.size:
            ideal = starts[0] + k * (n_frames - starts[0]) / threads
            cuts.add(int(inner[np.argmin(np.abs(inner - ideal))]))
    bounds = [starts[0], *sorted(cuts), n_frames]
    return list(zip(bounds[:-1], bounds[1:]))
