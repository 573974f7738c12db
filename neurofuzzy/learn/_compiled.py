"""The compiled path of :meth:`neurofuzzy.learn.Sensitivity.run`: the model, its parameter
directions, the experiment's loads, window starts and observation operator laid out for
:func:`neurofuzzy.kernels.sensitivity.forward` (runs with tangents) and
:func:`neurofuzzy.kernels.stepper.frames` (runs of the state alone, and the adjoint's forward
sweep): one call per experiment, no Python per time step.

Every model is one the kernels compute (a model refuses other effects): springs, elements,
gravity and unmodeled loads (constant forces), a node drag, inclusions of springs (extra spring
stiffness) and of elements (extra element constants), strain stiffening of springs and of
elements; node masses learned or fixed.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from ..effects import per_unit_mass_force
from ..effects.compiled import CLOSING, STRETCH, KernelEffects
from ..forces.relaxation import decay
from ..forces.tetra_geometry import lame_factors
from ..simulation.layout import ElementArrays, element_arrays, spring_arrays
from ..simulation.threads import element_buffers
from ._parameters import ELEMENT_BLOCKS, RELAXATION_BLOCKS, law_constant_columns

__all__ = ["CompiledModel", "Springs", "Elements"]


class Springs(NamedTuple):
    """The springs as the kernels step them (:func:`~neurofuzzy.effects.compiled.spring_entries`;
    all springs when they are learned): end nodes, constants, rest lengths and the ``q`` of the
    last ``len(cubic)``; then the CSR of their magnitudes' parameter derivatives
    (:func:`neurofuzzy.kernels.sensitivity._spring_tangents`: entry ``pointer[j] ..
    pointer[j + 1] - 1`` of spring ``j`` is ``factor · basis`` for parameter ``column``)."""

    a: np.ndarray
    b: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    rest: np.ndarray
    cubic: np.ndarray
    pointer: np.ndarray
    column: np.ndarray
    basis: np.ndarray
    factor: np.ndarray


class Elements(NamedTuple):
    """The elements as the kernels step them (:class:`~neurofuzzy.simulation.layout.ElementArrays`)
    and their parameter derivatives: the CSR of the four constants' (``pointer``, ``column``,
    ``d_shear``, ``d_shear_rate``, ``d_lam``, ``d_lam_rate``; columns ascending per element), the
    node averages' (N, P) of the nodal form, the strain stiffening ``κ`` and its column (-1
    when not learned) and the column of each element's law constant (-1 when not learned)."""

    arrays: ElementArrays
    pointer: np.ndarray
    column: np.ndarray
    d_shear: np.ndarray
    d_shear_rate: np.ndarray
    d_lam: np.ndarray
    d_lam_rate: np.ndarray
    d_node_lam: np.ndarray
    d_node_lam_rate: np.ndarray
    kappa: float
    kappa_column: int
    law_constant_column: np.ndarray


class NodeEffects(NamedTuple):
    """The effects that act on nodes: a drag ``-drag v`` (its coefficient's column
    ``drag_column``, -1 when not learned) and constant forces (N, 3) (gravity, unmodeled loads)
    with the derivatives of the learned ones by their parameters, ``direction`` (N, 3, P),
    nonzero in the columns ``spans`` (slices) alone."""

    drag: float
    drag_column: int
    direction: np.ndarray
    constant: np.ndarray
    spans: list


class CompiledModel:
    """Kernel arrays of one model (one parameter vector) and its parameter directions."""

    def __init__(self, parameters, model):
        self.model = model
        n_params = parameters.size
        blocks = parameters.blocks
        # the model's effects are the parameterisation's, in order, when they are learned
        columns = {i: blocks[f"effect:{i}"].start for i in range(len(parameters.effects))}
        effects = KernelEffects(model, columns)
        self.springs = self._springs(parameters, model, effects)
        self.elements = self._elements(parameters, model, n_params, effects)
        self.relaxation = self._relaxation(parameters, model)
        self.effects = self._effects(model, n_params, effects)
        self.weight = model.node_inverse_mass
        self.masses = self._masses(parameters, model)
        self.n_params = n_params

    @staticmethod
    def _springs(parameters, model, effects) -> Springs:
        """The springs and the CSR of their magnitudes' parameter derivatives."""
        *arrays, derivatives = spring_arrays(model, effects,
                                             every_spring=parameters.learn_springs)
        entries = [derivatives]
        if parameters.learn_springs:    # entry j is spring j: ∂m/∂log s = s x, ∂m/∂log c = c ẋ
            own = np.arange(model.n_springs)
            for name, basis, values in (("log_stiffness", STRETCH, model.springs.stiffness),
                                        ("log_damping", CLOSING, model.springs.damping)):
                entries.append((own, parameters.blocks[name].start + parameters.tied.tie,
                                np.full(len(own), basis), np.asarray(values, float)))
        entry, column, basis, factor = (np.concatenate(part) for part in zip(*entries))
        order = np.lexsort((column, entry))
        pointer = np.searchsorted(entry[order], np.arange(len(arrays[0]) + 1))
        return Springs(*arrays, pointer.astype(np.intp), column[order].astype(np.intp),
                       basis[order].astype(np.intp), np.ascontiguousarray(factor[order], float))

    @staticmethod
    def _masses(parameters, model):
        """``(mass_column, unit_mass_force)``: the column of every node's ``log m`` (-1 for
        the fixed nodes; an empty array when masses are fixed) and the forces proportional to
        the mass (gravity: constant, so taken at rest)."""
        if not parameters.learn_masses:
            return np.zeros(0, np.intp), np.zeros((0, 3))
        column = np.full(model.n_nodes, -1, np.intp)
        column[parameters.free_nodes] = (parameters.blocks["log_mass"].start
                                         + np.arange(len(parameters.free_nodes)))
        return column, per_unit_mass_force(model, model.mesh.rest_positions,
                                           np.zeros((model.n_nodes, 3)))

    @staticmethod
    def _elements(parameters, model, n_params, effects) -> Elements:
        """Element constants (the model's plus its inclusions') and the CSR of their
        derivatives by the parameters, with the node averages' derivatives."""
        n_nodes = model.n_nodes
        arrays = element_arrays(model, effects)
        if model.elements is None:      # tets None: the kernels compile no element code
            empty, none = np.zeros(0), np.zeros(0, np.intp)
            return Elements(arrays, np.zeros(1, np.intp), none, *(empty,) * 4,
                            np.zeros((0, n_params)), np.zeros((0, n_params)), 0.0, -1, none)
        own = model.elements.constants(model)
        geometry = own.geometry
        # derivatives: (element, column, d shear, d shear_rate, d lam, d lam_rate)
        E, nu, eta = (model.elements.youngs_modulus, model.elements.poisson_ratio,
                      model.elements.viscosity)
        a, b, da, db = lame_factors(nu)
        logistic = nu * (1.0 - 2.0 * nu)                     # dν/d logit (2ν)
        first = parameters.blocks[ELEMENT_BLOCKS[0]].start
        ties, tie = model.elements.n_ties, model.elements.tie
        index = np.arange(model.mesh.n_tetrahedra)
        zero = np.zeros_like(E)
        entries = [(index, first + tie, 2 * b * E, zero, a * E, zero),
                   (index, first + ties + tie, 2 * db * E * logistic, 2 * db * eta * logistic,
                    da * E * logistic, da * eta * logistic),
                   (index, first + 2 * ties + tie, zero, 2 * b * eta, zero, a * eta),
                   *effects.element_derivatives]            # the learned element inclusions
        element, column, *values = (np.concatenate(part) for part in zip(*entries))
        order = np.lexsort((column, element))
        element, column = element[order], column[order].astype(np.intp)
        values = [np.ascontiguousarray(value[order], float) for value in values]
        pointer = np.searchsorted(element, np.arange(len(E) + 1)).astype(np.intp)
        d_node_lam = np.zeros((n_nodes, n_params))
        d_node_lam_rate = np.zeros((n_nodes, n_params))
        if own.nodal:
            for target, value in ((d_node_lam, values[2]), (d_node_lam_rate, values[3])):
                per_element = sp.csr_matrix((value, (element, column)),
                                            shape=(len(E), n_params))
                target[:] = (geometry.average @ per_element).toarray()
        return Elements(arrays, pointer, column, *values, d_node_lam, d_node_lam_rate,
                        effects.kappa, effects.kappa_column,
                        law_constant_columns(parameters, model))

    @staticmethod
    def _relaxation(parameters, model):
        """``(g, τ, columns)`` of the elements' Prony terms: (n_elements, K) each and the
        (n_elements, K, 2) columns of ``log g``, ``log τ`` (-1 when not learned)."""
        if model.elements is None:
            return np.zeros((0, 0)), np.ones((0, 0)), np.zeros((0, 0, 2), np.intp)
        n, k = model.mesh.n_tetrahedra, model.n_relaxation_terms
        columns = np.full((n, k, 2), -1, np.intp)
        for side, name in enumerate(RELAXATION_BLOCKS):
            block = parameters.blocks.get(name)
            if block is not None:
                ties = model.elements.n_ties
                columns[:, :, side] = (block.start + np.arange(k)[None, :] * ties
                                       + model.elements.tie[:, None])
        return (np.array(model.elements.relaxation_moduli, float, order="C"),
                np.array(model.elements.relaxation_times, float, order="C"), columns)

    @staticmethod
    def _effects(model, n_params, effects) -> NodeEffects:
        """The effects' drag and constant forces
        (:class:`~neurofuzzy.effects.compiled.KernelEffects`) and their parameter columns."""
        # parameters last, as the kernel's tangents; np.zeros maps its pages lazily, so the
        # (N, 3, P) array of a model with thousands of parameters costs no memory until used
        direction = np.zeros((model.n_nodes, 3, n_params))
        for span, per_parameter in effects.directions:
            direction[:, :, span] = per_parameter
        return NodeEffects(effects.drag, effects.drag_column, direction, effects.constant,
                           [span for span, _ in effects.directions])

    def run(self, experiment, states, *, substeps: int, scale: float, tangents: bool,
            columns: tuple[int, int] | None = None, jacobian: np.ndarray | None = None,
            frames: tuple[int, int] | None = None, positions: np.ndarray | None = None,
            chunks: int = 1):
        """``(positions, jacobian)`` of one experiment; ``states`` maps every window start
        frame to its ``(p, v)``. With ``columns = (first, stop)`` only those columns of the
        Jacobian, written into ``jacobian`` (the state is simulated whole either way). With
        ``frames = (a, b)`` only frames ``a .. b - 1`` (``a`` a window start; models whose
        elements do not relax, so that windows are independent), written into
        ``positions`` and ``jacobian``. ``chunks``: the threads of the element passes (one
        unless run from the main thread, :mod:`neurofuzzy.simulation.threads`)."""
        from ..kernels.sensitivity import forward

        if not tangents:        # the state alone: the stepper's driver, the faster sweep
            return self.frames(experiment, states, substeps=substeps)[0], None
        first, stop = columns if columns is not None else (0, self.n_params)
        width = stop - first
        n_frames, n_nodes = experiment.n_frames, self.model.n_nodes
        start_index, start_p, start_v = _windows(n_frames, states)
        observation = experiment.observation
        operator = observation.operator.tocsr()
        if positions is None:
            positions = np.empty((n_frames, n_nodes, 3))
        if jacobian is None:
            jacobian = np.empty((n_frames - 1, observation.n_rows, 3, self.n_params))
        direction = np.ascontiguousarray(self.effects.direction[:, :, first:first + width])
        # writable C-ordered copies: numba compiles one signature per array layout
        loads = np.array(experiment.forces_per_frame() + self.effects.constant, dtype=float,
                         order="C")
        seen = np.array(observation.seen, dtype=bool, order="C")
        a, b = (0, n_frames) if frames is None else frames
        if a > 0:           # a window starts at frame a: its residual (and row) is zero
            if start_index[a] < 0 or self.relaxation[0].shape[1]:
                raise ValueError("a run of some frames starts at a window of a model whose "
                                 "elements do not relax")
            jacobian[a - 1, :, :, first:stop] = 0.0
            loads = loads[a:] if len(loads) > 1 else loads
        h = experiment.dt / substeps
        with np.errstate(over="ignore", invalid="ignore"):
            forward((start_p[0].copy(), start_v[0].copy()), *self.groups(h, direction),
                    (loads, h, b - a, int(substeps), int(chunks)), (int(first), int(width)),
                    (start_index[a:b], start_p, start_v),
                    (operator.indptr.astype(np.intp), operator.indices.astype(np.intp),
                     operator.data.astype(float), seen[a:b], float(scale)),
                    (positions[a:b], jacobian[a:b - 1]))
        return positions, jacobian

    def groups(self, h: float, direction: np.ndarray | None = None) -> tuple:
        """``(springs, elements, relaxation, nodes)``, the model as the learners' kernels take
        it for steps of ``h``: :class:`Springs`; :class:`Elements`, or None for a model
        without them (numba then compiles no element code: it prunes a branch on an argument
        that is None); the Prony terms ``(g, a = exp(-h/τ), columns)``; and ``(W,
        drag, drag_column, direction, mass_column, unit_mass_force)``, ``direction`` the
        learned constant forces' columns the run computes (all of them when None)."""
        effects = self.effects
        g, times, relax_column = self.relaxation
        mass_column, unit_mass_force = self.masses
        return (self.springs, self.elements if self.n_elements else None,
                (g, decay(times, h), relax_column),
                (np.ascontiguousarray(self.weight, dtype=float), effects.drag,
                 effects.drag_column, effects.direction if direction is None else direction,
                 mass_column, unit_mass_force))

    @property
    def n_elements(self) -> int:
        """The tetrahedra the kernels loop over (0 for a model of springs alone)."""
        tets = self.elements.arrays.tets
        return tets.shape[0] if tets is not None else 0

    def frames(self, experiment, states, *, substeps: int, keep: bool = False):
        """``(positions, kept)``: the positions (n_frames, N, 3) of one experiment by the
        stepper's driver (:func:`neurofuzzy.kernels.stepper.frames`), every window from its
        state in ``states`` (frame → ``(p, v)``; the relaxation's internal variables from rest,
        carried over window starts). With ``keep``, ``kept`` is what the adjoint's backward
        sweep runs over: the state at the start of every substep, the internal variables
        there and, when masses are learned, every substep's force (``(states_p, states_v,
        states_r, states_f)``, empty arrays for what is not kept); else None."""
        from ..kernels.stepper import frames

        n_frames, n_nodes = experiment.n_frames, self.model.n_nodes
        start_index, start_p, start_v = _windows(n_frames, states)
        relax_g = self.relaxation[0]
        n_relaxing = relax_g.shape[0] if relax_g.shape[1] else 0
        steps = (n_frames - 1) * substeps if keep else 0
        kept = (np.empty((steps, n_nodes, 3)), np.empty((steps, n_nodes, 3)),
                np.empty((steps if n_relaxing else 0, n_relaxing, relax_g.shape[1], 6)),
                np.empty((steps if len(self.masses[0]) else 0, n_nodes, 3)))
        loads = np.array(experiment.forces_per_frame() + self.effects.constant, dtype=float,
                         order="C")
        h = experiment.dt / substeps
        positions = np.empty((n_frames, n_nodes, 3))
        with np.errstate(over="ignore", invalid="ignore"):
            # the learners' groups, as the stepper's driver takes them
            _, elements, (g, a, _), (weight, drag, *_) = self.groups(h)
            frames((start_p[0].copy(), start_v[0].copy()), self.springs[:6],
                   None if elements is None else elements.arrays,
                   (g, a, np.zeros(g.shape + (6,))), (weight, drag, self.elements.kappa),
                   (loads, h, n_frames, int(substeps)),
                   (start_index, start_p, start_v), (positions, np.empty((0, n_nodes, 3))),
                   kept, (np.empty((n_nodes, 3)), np.zeros((n_nodes, 2)),
                          element_buffers(self.n_elements, n_nodes)))
        return positions, (kept if keep else None)


def _windows(n_frames: int, states) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(start_index, start_p, start_v)`` of the kernels: for every frame the index of the
    window starting there (-1: none), and the windows' start states in frame order."""
    start_index = np.full(n_frames, -1, np.intp)
    frames = sorted(states)
    start_index[frames] = np.arange(len(frames))
    start_p = np.stack([states[t][0] for t in frames]).astype(float)
    start_v = np.stack([states[t][1] for t in frames]).astype(float)
    return start_index, start_p, start_v
