"""The inner loop of :func:`neurofuzzy.simulation.simulate`: many steps of one model.

:class:`NumbaStepper`, with ``advance(p, v, load, n_steps)`` (in place, positions and
velocities of shape (n_nodes, 3)) and ``trajectory``, is one compiled loop over springs,
tetrahedral elements (with their Prony relaxation), the effects of
:mod:`neurofuzzy.effects.compiled` and nodes (numba, a core dependency): the package's one
path. The tests check it against the numpy reference (``tests/numpy_reference.py``), which
steps every term's numpy force and computes what :func:`neurofuzzy.simulation.step` computes.
"""

from __future__ import annotations

import functools
import threading
import weakref
from typing import NamedTuple

import numpy as np

from .layout import ElementArrays
from .threads import element_buffers

__all__ = ["NumbaStepper", "euler_update"]


def euler_update(p: np.ndarray, v: np.ndarray, force: np.ndarray, weight: np.ndarray,
                 h: float, *, component_major: bool = False) -> None:
    """The semi-implicit Euler update, in place (eqs. 3.2, 3.1): ``v += h W F``, then
    ``p += h v``: the compiled :func:`neurofuzzy.kernels.integrator.euler_update` (the one
    update of the package) for the numpy paths (:func:`neurofuzzy.simulation.step`, the paper's
    learner, the tests' numpy reference). Linear, so it also advances
    tangents.

    Parameters
    ----------
    p, v : ndarray
        Positions and velocities (n_nodes, 3) or their tangents (n_nodes, P, 3), node-major,
        or with ``component_major`` (3, n_nodes); updated in place.
    force : ndarray
        The force (or its tangent) at the start of the step, the shape of ``v`` (not changed).
    weight : ndarray
        ``W = 1/m`` (n_nodes,) (any shape of n_nodes entries), zero at fixed nodes.
    h : float
        Step length (s).
    """
    if component_major:
        p, v, force = p.T, v.T, force.T
    if p.ndim != 2:                                      # tangents (n_nodes, P, 3)
        n = p.shape[0]
        rows_p, rows_v = p.reshape(n, -1), v.reshape(n, -1)
        if not (np.may_share_memory(rows_p, p) and np.may_share_memory(rows_v, v)):
            raise ValueError("euler_update updates in place: tangents must be contiguous")
        p, v, force = rows_p, rows_v, force.reshape(n, -1)
    _compiled_update()(p, v, force, weight if weight.ndim == 1 else weight.reshape(-1), h)


@functools.cache
def _compiled_update():
    """The compiled update, imported on first use (numba loads when a model is stepped)."""
    from ..kernels.integrator import euler_update

    return euler_update


class NumbaStepper:
    """Semi-implicit Euler steps as one compiled loop: springs, tetrahedral elements (with
    their Prony relaxation) and every effect, as it writes itself into the kernels' arrays
    (:class:`neurofuzzy.effects.compiled.KernelEffects`)."""

    _kernel = None
    _frames_kernel = None
    #: per model (weakly: gone with it), the kernel's arrays of its constants per step and
    #: dtype: models are immutable, and a run continued in pieces (``initial_state``) or a
    #: real-time loop calls ``simulate`` on one model again and again
    _prepared = weakref.WeakKeyDictionary()
    _prepared_lock = threading.Lock()       # load cases and fit-many's workers run in threads

    def __init__(self, model, h: float, dtype=np.float64):
        self.h = float(h)
        self.dtype = np.dtype(dtype)
        prepared = _prepared(model, self.h, self.dtype)
        # the kernels' groups (:func:`neurofuzzy.kernels.stepper.advance`): the springs, the
        # elements (None without them: no element code compiled), their relaxation and the
        # node terms; the constants are shared by every stepper of the model, the scratch
        # space is this stepper's (the kernels write only it, the state and the force)
        self.constant = prepared.constant
        self.springs = prepared.springs
        elements = prepared.elements
        self.elements = elements if elements.tets is not None else None
        self.node_strain = np.zeros((model.n_nodes, 2), dtype=self.dtype)
        g, decay = prepared.relaxation
        self.history = np.zeros(g.shape + (6,), dtype=self.dtype)
        self.relaxation = (g, decay, self.history)
        self.terms = (prepared.weight, self.dtype.type(prepared.drag),
                      self.dtype.type(prepared.kappa))
        self.fixed = model.mesh.fixed
        self.force = np.zeros((model.n_nodes, 3), dtype=self.dtype)
        self.zero_load = np.zeros((model.n_nodes, 3), dtype=self.dtype)
        # one run from the given state: no window starts, no substep states kept
        none = np.zeros((0, model.n_nodes, 3), dtype=self.dtype)
        self.no_windows = (np.zeros(0, np.intp), none, none)
        self.no_kept = (none, none, np.zeros((0,) + self.history.shape, dtype=self.dtype),
                        none)
        self.n_elements = model.mesh.n_tetrahedra if model.elements is not None else 0
        self._buffers = None
        if NumbaStepper._kernel is None:
            NumbaStepper._kernel, NumbaStepper._frames_kernel = _compile()

    def scratch(self) -> tuple:
        """``(force, node_strain, buffers)`` for this call: ``buffers`` the element passes'
        per-thread scratch (None: one thread; :mod:`neurofuzzy.simulation.threads`)."""
        buffers = element_buffers(self.n_elements, self.force.shape[0], self.dtype,
                                  reuse=self._buffers)
        self._buffers = self._buffers if buffers is None else buffers
        return self.force, self.node_strain, buffers

    def trajectory(self, p, v, loads, n_frames: int, substeps: int, internal):
        """Frames 0..n_frames-1 from ``(p, v)`` and the relaxation's internal variables
        ``internal`` (n_elements, K, 6), all in one compiled call; ``loads[t]`` acts from frame
        t to t + 1 (a single row ``loads[0]`` is held for all frames; ``None`` means no load).

        Returns ``(positions, velocities, internal)``: the frames, of shape (n_frames,
        n_nodes, 3), and the internal variables after the last one; the frames after the
        state stops being finite are NaN."""
        positions = np.empty((n_frames, p.shape[0], 3), dtype=self.dtype)
        velocities = np.empty_like(positions)
        pc = np.array(p, dtype=self.dtype)
        vc = np.array(v, dtype=self.dtype)
        vc[self.fixed] = 0.0
        self.history[...] = internal        # relaxation continues from the given state
        loads = (np.zeros((1, p.shape[0], 3), dtype=self.dtype) if loads is None
                 else np.ascontiguousarray(loads[:max(n_frames - 1, 1)], self.dtype))
        loads = loads + self.constant
        NumbaStepper._frames_kernel((pc, vc), self.springs, self.elements, self.relaxation,
                                    self.terms, (loads, self.dtype.type(self.h),
                                                 int(n_frames), int(substeps)),
                                    self.no_windows, (positions, velocities), self.no_kept,
                                    self.scratch())
        return (positions.astype(float, copy=False), velocities.astype(float, copy=False),
                self.history.astype(float))

    def advance(self, p: np.ndarray, v: np.ndarray, load: np.ndarray | None, n_steps: int):
        pc = np.ascontiguousarray(p, dtype=self.dtype)
        vc = np.ascontiguousarray(v, dtype=self.dtype)
        vc[self.fixed] = 0.0
        load = (self.zero_load if load is None
                else np.ascontiguousarray(load, dtype=self.dtype)) + self.constant
        NumbaStepper._kernel((pc, vc), self.springs, self.elements, self.relaxation,
                             self.terms, load, self.dtype.type(self.h), int(n_steps),
                             self.scratch())
        p[...] = pc
        v[...] = vc


class Prepared(NamedTuple):
    """A model in the kernels' layout for steps of ``h`` (:func:`_prepared`): the node drag,
    the elements' strain stiffening ``κ``, the effects' constant forces (N, 3), the springs
    ``(a, b, stiffness, damping, rest, cubic)`` (:func:`~.layout.spring_arrays`), the
    elements (:class:`~.layout.ElementArrays`; ``tets`` None without them), their Prony terms
    ``(g, a = exp(-h/τ))`` (n_elements, K) each, and the inverse node masses ``W`` (zero at
    fixed nodes). Shared by every user of the model: each adds its own scratch space (the
    node sums (N, 2) of the nodal form, the internal variables (n_elements, K, 6))."""

    drag: float
    kappa: float
    constant: np.ndarray
    springs: tuple
    elements: ElementArrays
    relaxation: tuple
    weight: np.ndarray


def _prepared(model, h: float, dtype: np.dtype) -> Prepared:
    """``model`` in the kernels' layout for steps of ``h`` (cached per model: the last few
    steps and dtypes)."""
    key = (h, dtype.str)
    with NumbaStepper._prepared_lock:
        cache = NumbaStepper._prepared.setdefault(model, {})
        if key in cache:
            return cache[key]
    from ..effects.compiled import KernelEffects
    from .layout import element_arrays, spring_arrays

    effects = KernelEffects(model)
    # the springs with a force, then those that stiffen once more (the spring effects')
    arrays = Prepared(effects.drag, effects.kappa, effects.constant.astype(dtype),
                      spring_arrays(model, effects, dtype)[:6],
                      element_arrays(model, effects, dtype), _relaxation(model, dtype, h),
                      model.node_inverse_mass.astype(dtype))
    with NumbaStepper._prepared_lock:
        while len(cache) >= 4:                          # a learner tries many steps: keep few
            cache.pop(next(iter(cache)))
        cache[key] = arrays
    return arrays


def _relaxation(model, dtype, h: float) -> tuple:
    """``(g, a = exp(-h/τ))`` (n_elements, K) of the elements' Prony terms for steps of ``h``
    seconds (:mod:`neurofuzzy.forces.relaxation`; empty without elements)."""
    if model.elements is None:
        return np.zeros((0, 0), dtype), np.zeros((0, 0), dtype)
    from ..forces.relaxation import decay

    return (np.array(model.elements.relaxation_moduli, dtype, order="C"),
            np.ascontiguousarray(decay(model.elements.relaxation_times, h), dtype))


def _compile():
    from ..kernels.stepper import advance, frames

    return advance, frames
