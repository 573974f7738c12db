"""The linear solve of an implicit step, without assembling its matrix at every step.

Each Newton iteration of a backward Euler step (:mod:`.implicit`) solves

    A δ = r,     A = M + h C + h² K     at the iteration's state (x, v),

with ``K = -∂F/∂x``, ``C = -∂F/∂v``. Assembling ``A`` at every step cost the 10,368-tetrahedron
block 46 ms a step, and a SuperLU factorisation of it 0.8 s, where a 16 ms step run in real
time has 16 ms. A :class:`StepSolver` assembles and factorises seldom:

- it keeps the factorisation ``P`` of ``A`` at an earlier state (SuperLU, as the static
  solve's, :func:`neurofuzzy.simulation.static._factor`) and starts from ``δ = P⁻¹ r``;
- it checks and corrects that against this state's matrix without assembling it: ``A y`` is
  ``M y - h (F(x + s h y, v + s y) - F(x, v)) / s``, one more evaluation of the compiled
  force (:class:`BodyForce`, the stepper's own arithmetic), a forward difference with ``s``
  scaled to ``√ε`` of the positions (within 1e-7 of the assembled product; ``tests/
  test_implicit.py``), in GMRES preconditioned on the right by ``P``, on the rows weighted
  by ``M^{-1/2}``, to a residual ``tolerance`` times the right side's;
- it factorises ``A`` afresh at this state (assembled from every term's one definition,
  :func:`~neurofuzzy.simulation.tangents.tangents`) when GMRES does not get there in
  :data:`RESTART` iterations, and solves again; and before a solve once the kept
  factorisation has cost :data:`REFRESH` GMRES iterations (counted, not timed: a run takes
  the same steps every time).

Why the weights: ``A ⪰ M`` near equilibrium (``K``, ``C`` positive semi-definite), so the
error of ``δ`` in the mass norm is at most the weighted residual: a relative residual of 1e-6
bounds the error of the motions whose ``A`` is within a few times ``M`` to a few 1e-6; the
stiff ones are bounded far tighter.

How far this goes: the kept ``P`` is not ``A`` for long. On a 2 cm block of 1,296
tetrahedra at ν 0.45 pushed for one 16 ms step (0.65 mm of motion), ``P⁻¹A`` already spread
over 0.6–1.6, the body's own stress stiffening some modes and softening others, so GMRES
takes 5 to 15 iterations a step, each a pair of triangular solves. Against assembling every
step, the step is 2.8 times as fast at 1,296 tetrahedra and 1.3 (16 ms) to 1.9 (1 ms) times
at 10,368: not the tenfold a real-time 10,368-tetrahedron block would need (the export
tutorial's real-time section).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .krylov import gmres
from .static import _factor
from .tangents import tangents

__all__ = ["BodyForce", "StepSolver", "TOLERANCE", "RESTART", "REFRESH"]

#: relative residual (weighted by M^{-1/2}) a step's solve is corrected to
TOLERANCE = 1e-6
#: GMRES iterations of one solve, preconditioned by the kept factorisation, before the
#: matrix is factorised afresh and the solve made again
RESTART = 30
#: GMRES iterations on one kept factorisation after which the next solve factorises afresh.
#: A factorisation from rest grows stale as the body deforms: on the 2 cm block of
#: ``benchmarks/realtime.py`` pushed at 16 ms steps its solves took 13 iterations a step.
#: Refreshed every 200 iterations, 1,296 tetrahedra (100 steps) stepped in 1.76–1.78 ms
#: instead of 3.63–3.79, and 10,368 (30 steps) in 52–55 ms instead of 62–72 (2026-12-03,
#: alternately). At 1 ms a fresh factorisation saves little (about five iterations a step
#: remain), so the refresh must be rare: every 200 iterations gave the same 1 ms times
#: within the noise (2.76–2.85 against 2.91–2.94 ms; 50–55 against 50–54 ms); every 60 made
#: them 10–20 % slower.
REFRESH = 200


class BodyForce:
    """The model's force ``F(x, v)`` (springs, elements, the compiled effects' node drag and
    constant forces; no external load) at any state, compiled
    (:func:`neurofuzzy.kernels.body.body_force`), from the stepper's arrays of the model for
    steps of ``h`` seconds.

    Elements that relax carry their internal variables here (:attr:`internal`, the Prony
    terms' ``rᵢ`` of :mod:`neurofuzzy.kernels.relaxation`): a call reads them and leaves them
    as they were (every trial state of a Newton solve sees the same ones); :meth:`advance`
    takes them one step on from a state, ``rᵢ ← aᵢ rᵢ - (1 - aᵢ) S_e``, as the explicit
    stepper does after each step."""

    def __init__(self, model, h: float = 1.0):
        from .steppers import _prepared

        prepared = _prepared(model, float(h), np.dtype(np.float64))
        elements = prepared.elements
        #: the elements (:class:`~.layout.ElementArrays`; none: ``tets`` of shape (0, 4))
        self.elements = (elements if elements.tets is not None
                         else elements._replace(tets=np.zeros((0, 4), np.intp)))
        #: ``(g, a)``: the Prony terms of steps of ``h`` (n_elements, n_terms) each
        self.relaxation = prepared.relaxation
        #: the internal variables of the relaxation (n_elements, n_terms, 6), zero at rest
        self.internal = np.zeros(self.relaxation[0].shape + (6,))
        self._trial = np.zeros_like(self.internal)
        self._node_strain = np.zeros((model.n_nodes, 2))   # the kernel's scratch, its own
        self.springs = prepared.springs
        self.kappa, self.drag = float(prepared.kappa), float(prepared.drag)
        self.constant = np.asarray(prepared.constant, float)
        self.n_nodes = model.n_nodes
        self.relaxes = self.internal.shape[1] > 0

    def __call__(self, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
        """``F`` at ``(positions, velocities)``, both (n_nodes, 3) or flat; flat (3 n_nodes,)."""
        self._trial[...] = self.internal
        return self._force(positions, velocities, self._trial)

    def advance(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """The relaxation's internal variables one step on from this state (nothing without
        Prony terms)."""
        if self.relaxes:
            self._force(positions, velocities, self.internal)

    def _force(self, positions, velocities, internal):
        from ..kernels.body import body_force

        out = np.empty((self.n_nodes, 3))
        body_force(np.ascontiguousarray(positions, float).reshape(-1, 3),
                   np.ascontiguousarray(velocities, float).reshape(-1, 3), self.springs,
                   self.elements, self._node_strain, (*self.relaxation, internal),
                   (self.kappa, self.drag), out)
        out += self.constant
        return out.ravel()


class StepSolver:
    """Solves ``(M + hC + h²K) δ = r`` at a state by a kept factorisation and GMRES on
    differences of this state's force (module docstring). One per run: it keeps ``P``.

    Parameters
    ----------
    model : Model
    body : BodyForce
        The model's force.
    h : float
        The step (s).
    free : (3 n_nodes,) bool
        The degrees of freedom solved for (the fixed nodes' are not).
    mass : (n_free,) float
        Their masses.
    tolerance : float
        The relative residual a solve is corrected to (:data:`TOLERANCE`).
    """

    def __init__(self, model, body: BodyForce, h: float, free: np.ndarray, mass: np.ndarray,
                 tolerance: float = TOLERANCE):
        self.model, self.body, self.h = model, body, float(h)
        self.free, self.mass = free, mass
        self.weight = 1.0 / np.sqrt(mass)
        self.tolerance = float(tolerance)
        self.factor = None
        #: a rigid tool's :class:`~.contact.Contact` at this step, or None: its force joins
        #: the products' differences and its stiffness the factorised matrix
        self.contact = None
        #: what the run cost: solves by the kept factorisation, products by differences of
        #: the force, GMRES iterations, factorisations
        self.counts = {"solves": 0, "products": 0, "iterations": 0, "factorisations": 0}
        self._spent = 0         # GMRES iterations on the kept factorisation

    def solve(self, right: np.ndarray, x: np.ndarray, v: np.ndarray,
              force: np.ndarray) -> np.ndarray:
        """``δ`` with ``A δ = right`` at the state ``x``, ``v`` (flat, every node) whose force
        ``F(x, v)`` (flat, no load) is ``force``."""
        if not np.any(right):
            return np.zeros_like(right)
        fresh = self.factor is None or self._spent >= REFRESH
        if fresh:
            self._factorise(x, v)
        delta = self._refined(right, x, v, force)
        if delta is None and not fresh:
            self._factorise(x, v)
            delta = self._refined(right, x, v, force)
        if delta is None:        # P is this state's A: its solve is the exact one
            delta = self.factor.solve(right)
        return delta

    def adopt(self, factor) -> None:
        """Keep ``factor``, a factorisation of this step's matrix made elsewhere at a nearby
        state (the derivatives' pass of :mod:`.implicit_derivatives`, at the solved step), as
        if it were its own: the :data:`REFRESH` count starts again."""
        self.factor = factor
        self._spent = 0

    def _refined(self, right, x, v, force):
        """``P⁻¹ right`` corrected by GMRES to the tolerance, or None where GMRES does not
        reach it in :data:`RESTART` iterations."""
        start = self._apply(right)
        residual = right - self.product(start, x, v, force)
        goal = self.tolerance * np.linalg.norm(self.weight * right)
        if np.linalg.norm(self.weight * residual) <= goal:
            return start
        # GMRES on the rows weighted by M^{-1/2}, preconditioned on the right by the kept
        # factorisation (so the residual it minimises is the true one)
        solved = gmres(lambda u: self.weight * self.product(u, x, v, force),
                       self.weight * residual, goal, precondition=self._apply,
                       restart=RESTART)
        self.counts["iterations"] += solved.iterations
        self._spent += solved.iterations
        return start + solved.x if solved.converged else None

    def product(self, y: np.ndarray, x: np.ndarray, v: np.ndarray,
                force: np.ndarray) -> np.ndarray:
        """``A y`` at ``(x, v)`` by a forward difference of the force (module docstring)."""
        self.counts["products"] += 1
        full = np.zeros_like(x)
        full[self.free] = y
        largest = np.abs(full).max()
        if largest == 0.0:
            return np.zeros_like(y)
        s = np.sqrt(np.finfo(float).eps) * max(np.abs(x).max(), 1e-300) / (self.h * largest)
        moved = x + (s * self.h) * full
        changed = self.body(moved, v + s * full)
        if self.contact is not None:
            changed = changed + self.contact.forces(moved.reshape(-1, 3)).ravel()
        return self.mass * y - self.h * ((changed - force) / s)[self.free]

    def _apply(self, right):
        self.counts["solves"] += 1
        return self.factor.solve(right)

    def _factorise(self, x, v):
        """``A`` assembled at this state (every term's one definition) and factorised."""
        n = self.model.n_nodes
        state = tangents(self.model, x.reshape(n, 3), v.reshape(n, 3),
                         self.body.internal if self.body.relaxes else None)
        f = self.free
        stiffness = state.stiffness if self.contact is None else (
            state.stiffness + self.contact.stiffness_matrix(x.reshape(n, 3)))
        self.factor = _factor(sp.diags(self.mass) + self.h * state.damping[f][:, f]
                              + (self.h * self.h) * stiffness[f][:, f])
        self.counts["factorisations"] += 1
        self._spent = 0
