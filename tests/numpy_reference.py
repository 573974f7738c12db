"""The numpy reference of the compiled physics: only the tests use it (and the benchmarks, as
the baseline of their ratios). The package has one production path, the compiled kernels;
this is the independent, vectorised numpy statement of the same discrete model that they are
checked against:

- :class:`NumpyStepper`: semi-implicit Euler steps through every term's numpy force;
- :func:`simulate`: :func:`neurofuzzy.simulate` with ``backend="numpy"`` stepping by it;
- :class:`NumpySensitivity`: forward sensitivities and the discrete adjoint through the terms'
  numpy derivatives (``state_jvp``, ``parameter_jvp``, ``state_vjp``, ``parameter_vjp``);
  :func:`sensitivity` gives it or the compiled :class:`~neurofuzzy.learn.Sensitivity`.
"""

from __future__ import annotations

import threading
from unittest import mock

import numpy as np
import scipy.sparse as sp

import neurofuzzy.simulation.integration as integration
from neurofuzzy.effects import per_unit_mass_force
from neurofuzzy.effects.compiled import element_constants
from neurofuzzy.experiment import Experiment
from neurofuzzy.forces import incidence, tetrahedron_geometry
from neurofuzzy.learn import Sensitivity
from neurofuzzy.learn._parameters import ELEMENT_BLOCKS, element_directions, law_constant_columns
from neurofuzzy.learn._passes import Run
from neurofuzzy.simulation import euler_update

__all__ = ["NumpyStepper", "simulate", "NumpySensitivity", "sensitivity", "BACKENDS"]

#: the two ways through the model the comparisons take
BACKENDS = ("numpy", "numba")


class NumpyStepper:
    """Semi-implicit Euler steps on component-major state arrays (3, n_nodes), through the
    spring term's own force (:meth:`~neurofuzzy.forces.Springs.force_components`)."""

    def __init__(self, model, h: float, dtype=np.float64):
        self.model = model
        self.h = float(h)
        self.dtype = np.dtype(dtype)
        self.springs = springs = model.springs
        self.incidence = incidence(model.mesh)
        if self.dtype != np.float64:
            self.incidence = self.incidence.with_dtype(self.dtype)
        self.coefficients = None if springs is None else tuple(
            values.astype(self.dtype)
            for values in (springs.stiffness, springs.damping, springs.rest_length))
        self.weight = model.node_inverse_mass.astype(self.dtype)
        self.fixed = model.mesh.fixed
        self.other_terms = model.force_terms[springs is not None:]   # elements and effects

    def trajectory(self, p, v, loads, n_frames: int, substeps: int, internal):
        """Frames 0..n_frames-1 from ``(p, v)`` and the relaxation's internal variables
        ``internal`` (n_elements, K, 6); ``loads[t]`` acts from frame t to t + 1 (a single row
        ``loads[0]`` is held for all frames; ``None`` means no load).

        Returns ``(positions, velocities, internal)``: the frames, of shape (n_frames,
        n_nodes, 3), and the internal variables after the last one; stops early (the rest
        NaN) when the state stops being finite. (This stepper computes no relaxation: the
        numpy force refuses a relaxing model, and ``internal`` is returned as it came.)
        """
        positions, velocities = _frames(self, p, v, loads, n_frames, substeps)
        return positions, velocities, np.array(internal, dtype=float)

    def advance(self, p: np.ndarray, v: np.ndarray, load: np.ndarray | None, n_steps: int):
        """``n_steps`` steps from ``(p, v)``, written back into ``p`` and ``v``."""
        h = self.h
        pt = np.ascontiguousarray(p.T, dtype=self.dtype)
        vt = np.ascontiguousarray(v.T, dtype=self.dtype)
        vt[:, self.fixed] = 0.0
        load_t = None if load is None else np.ascontiguousarray(load.T, dtype=self.dtype)
        for _ in range(n_steps):
            force = (np.zeros_like(pt) if self.springs is None else
                     self.springs.force_components(self.model, pt, vt,
                                                   incidence_=self.incidence,
                                                   coefficients=self.coefficients))
            if load_t is not None:
                force += load_t
            for term in self.other_terms:
                force += term.force(self.model, pt.T, vt.T).T
            euler_update(pt, vt, force, self.weight, h, component_major=True)
        p[...] = pt.T
        v[...] = vt.T


def _frames(stepper, p, v, loads, n_frames, substeps):
    positions = np.empty((n_frames, p.shape[0], 3))
    velocities = np.empty_like(positions)
    p, v = np.array(p, dtype=float), np.array(v, dtype=float)
    positions[0], velocities[0] = p, v
    for t in range(1, n_frames):
        stepper.advance(p, v, None if loads is None else loads[min(t - 1, len(loads) - 1)],
                        substeps)
        if not np.isfinite(p.sum()):
            positions[t:] = velocities[t:] = np.nan
            break
        positions[t], velocities[t] = p, v
    return positions, velocities



_patched = threading.Lock()


def simulate(model, *, backend: str = "numba", **options):
    """:func:`neurofuzzy.simulate` (``backend="numba"``, the package's one path), or the same
    call stepped by :class:`NumpyStepper` (``"numpy"``): every check and start state of the
    package's, only the inner loop is the reference's."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}")
    if backend == "numba":
        return integration.simulate(model, **options)
    with _patched, mock.patch.object(integration, "NumbaStepper", NumpyStepper):
        return integration.simulate(model, **options)


class NumpySensitivity(Sensitivity):
    """:class:`~neurofuzzy.learn.Sensitivity` through the terms' numpy derivatives: the
    reference the compiled forward and adjoint kernels are checked against."""

    def __init__(self, parameters, length_unit: float, *, offsets: bool = False):
        super().__init__(parameters, length_unit, offsets=offsets)
        model = parameters.base
        self.incidence = incidence(model.mesh)
        # (n_ties * n_nodes, n_springs): spring j into the block of its tie group
        self.tie_incidence = (self.incidence.grouped(parameters.tied.tie,
                                                     parameters.tied.n_ties)
                              if parameters.learn_springs else None)
        if model.elements is not None:         # the three element blocks lie side by side
            self.element_slice = slice(parameters.blocks[ELEMENT_BLOCKS[0]].start,
                                       parameters.blocks[ELEMENT_BLOCKS[-1]].stop)

    def _stiffening_forces(self, model, p, v):
        """``(local, columns, block)``: the Yeoh elements' per-corner forces per unit
        ``log c`` (K, 4, 3), every element's ``log_stiffening`` column and the block (None
        without Yeoh elements)."""
        block = self.parameters.blocks.get("log_stiffening")
        if block is None:
            return None, None, None
        shear = element_constants(model)[1]["shear"]
        return (model.elements.stiffening_forces(model, p, v, shear),
                law_constant_columns(self.parameters, model), block)

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

    def run(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
            starts=(0,), tangents: bool = False, threads: int | None = 1) -> Run:
        """As :meth:`Sensitivity.run` (``threads`` unused), by numpy."""
        param = self.parameters
        model = param.model(theta)
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
                    p, v = self._window_state(experiment, t, substeps)
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

    def gradient(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
                 starts=(0,), cotangent=None) -> tuple[float, np.ndarray, Run]:
        """As :meth:`Sensitivity.gradient` (no ``cotangent`` of one's own), by numpy."""
        if cotangent is not None:
            raise ValueError("a cotangent of one's own needs the compiled gradient")
        param = self.parameters
        model = param.model(theta)
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
                    p, v = self._window_state(experiment, t, substeps)
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
        bar_p = np.zeros((self.n_nodes, 3))
        bar_v = np.zeros((self.n_nodes, 3))
        index = len(states)
        n_ties = param.tied.n_ties
        tie = param.tied.tie
        directions = element_directions(model) if model.elements is not None else None
        for t in range(n_frames - 1, 0, -1):
            if t in starts:
                bar_p[:] = 0.0
                bar_v[:] = 0.0
                continue
            bar_p += observation.adjoint(residuals[t]) * scale     # ∂L/∂p(t)
            for _ in range(substeps):
                index -= 1
                _, p, v = states[index]
                state = self._spring_state(model, p, v)
                force = self._force(model, p, v, state) + loads[t - 1]
                # p' = p + h v'
                bar_vnew = bar_v + h * bar_p
                bar_vnew[fixed] = 0.0
                # v' = v + h W F
                bar_force = h * weight * bar_vnew
                if param.learn_masses:
                    nodes = param.free_nodes
                    inertial = force - per_unit_mass_force(model, p, v)
                    grad[param.blocks["log_mass"].slice] -= np.einsum(
                        "ij,ij->i", bar_vnew[nodes], h * weight[nodes] * inertial[nodes])
                springs = model.springs
                if springs is None:
                    d_p, d_v = np.zeros_like(bar_force), np.zeros_like(bar_force)
                else:
                    d_p, d_v, per_spring = springs.vjp(model, bar_force, state)
                if param.learn_springs:
                    for name, values in (("log_stiffness", springs.stiffness),
                                         ("log_damping", springs.damping)):
                        grad[param.blocks[name].slice] += np.bincount(
                            tie, values * per_spring[name[4:]], n_ties)
                if model.elements is not None:
                    per_element = model.elements.parameter_vjp(model, p, v, bar_force)
                    for name, direction in directions.items():
                        grad[self.element_slice] += direction.T @ per_element[name]
                    local, columns, block = self._stiffening_forces(model, p, v)
                    if block is not None:
                        geometry = tetrahedron_geometry(model.mesh)
                        per_yeoh = np.einsum("ejk,ejk->e", bar_force[geometry.nodes], local)
                        yeoh = columns >= 0
                        grad += np.bincount(columns[yeoh], per_yeoh[yeoh], param.size)
                for i, effect in enumerate(param.effects):
                    jac = effect.parameter_jacobian(model, p, v)
                    grad[param.blocks[f"effect:{i}"].slice] += np.einsum("ipj,ij->p", jac,
                                                                         bar_force)
                for term in model.force_terms[springs is not None:]:
                    e_p, e_v = term.state_vjp(model, p, v, bar_force)
                    d_p += e_p
                    d_v += e_v
                bar_p = bar_p + d_p
                bar_v = bar_vnew + d_v
        return loss, grad, run


def sensitivity(parameters, length_unit: float, backend: str = "numba", **options):
    """The compiled :class:`~neurofuzzy.learn.Sensitivity` (``"numba"``) or the numpy
    reference :class:`NumpySensitivity` (``"numpy"``)."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}")
    kind = NumpySensitivity if backend == "numpy" else Sensitivity
    return kind(parameters, length_unit, **options)
