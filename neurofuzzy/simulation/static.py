"""Static equilibrium of a model under driven boundaries and loads: Newton's method on the
stiffness generated from each term's one definition (:mod:`neurofuzzy.simulation.tangents`).

Quasi-static experiments (a specimen compressed between plates and scanned at a few load
steps) are sequences of equilibria: at each step the driven nodes sit where the plate put them,
the fixed nodes at rest, and every other node where the forces balance,
``F(p) + f_ext = 0``. :func:`equilibrium` finds that state:

- **load increments**: the driven displacements and the loads are applied in ``increments``
  equal parts, each solved from the last (large strain needs them; one suffices at small
  strain), and an increment whose Newton iterations do not converge is halved, up to
  :data:`CUTS` times (automatic cut-back, as in every nonlinear finite-element code);
- **Newton's method** with the exact stiffness ``K = -∂F/∂p`` of every law and both
  volumetric forms, a predictor that moves the free nodes with the driven ones
  (``Δp_f = -K_ff⁻¹ K_fc Δp_c``), and a backtracking line search on the residual's norm;
- **a sparse direct factorisation** by SciPy's SuperLU (``splu``, ordered by minimum degree
  on ``A + Aᵀ`` in its symmetric mode). Why: it is part of SciPy, already a dependency, it
  needs no tolerance tuned where ν → 0.5 makes the system ill-conditioned and an
  unpreconditioned iterative solver slow to converge, and it handles the indefinite
  stiffness of a strongly compressed hyperelastic body, where a Cholesky solver (CHOLMOD)
  would refuse; on the 10,368-tetrahedron block in the nodal form (whose node averages
  couple two rings of nodes) one factorisation takes 0.8 s on this 2-core machine;
- **reused as a preconditioner**: a factorisation is kept while the matrix moves little
  (later Newton iterations, the same load step at a fit's nearby parameters, the
  sensitivities) and GMRES preconditioned by it solves those systems in a few triangular
  solves (:func:`_solve`; a new factorisation where it does not converge in 60), so a
  fit from three load steps of that block factorises 20 times instead of 93;
- **a rigid tool in contact** (:mod:`.contact`: a sphere or a flat punch, a penalty on the
  surface nodes) adds its force and stiffness; its Newton steps are scaled by the energy
  along them (:func:`_energy_search`), since the largest out-of-balance force need not fall
  along a good step while nodes enter and leave contact;
- **relaxation** takes its long-time value (the Prony terms have relaxed: in equilibrium the
  internal variables cancel their share), and **viscosity** does nothing (no velocity).

The reaction is the force the supports and the drivers exert on the body, ``-(F + f_ext)`` at
the constrained degrees of freedom; its sum over a plate's nodes is what a load cell reads.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..forces.laws import stall_note
from ..model import Model
from .tangents import tangents

__all__ = ["Driven", "Equilibrium", "equilibrium", "ConvergenceError"]

#: how many times an increment is halved before :func:`equilibrium` gives up
CUTS = 6

#: the components a driven set may be held in, by name
_COMPONENTS = {"x": 0, "y": 1, "z": 2}


class ConvergenceError(InputError):
    """Newton's method did not find the equilibrium (too large an increment, an element
    squeezed flat)."""


@dataclass(frozen=True)
class Driven:
    """Nodes moved by a prescribed displacement, held in some components.

    Parameters
    ----------
    nodes : (n,) int
        The driven nodes (a plate's face, nodes under markers).
    displacement : (3,) or (n, 3) float
        Their displacement from rest (m): one for all, or one per node.
    components : str
        The components held, a subset of ``"xyz"``: ``"xyz"`` for a bonded plate, the normal
        alone (``"z"``) for a frictionless one, along which the plate slides.
    """

    nodes: np.ndarray
    displacement: np.ndarray
    components: str = "xyz"

    def dofs(self, n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
        """``(dofs, displacement)``: the held degrees of freedom (node-major, ``3 i + k``)
        and their displacements, checked against a model of ``n_nodes``."""
        nodes = np.asarray(self.nodes)
        if nodes.ndim != 1 or len(nodes) == 0 or not np.issubdtype(nodes.dtype, np.integer):
            raise InputError(f"a driven set needs a non-empty list of node indices; got "
                             f"{nodes.shape} of {nodes.dtype}", key="driven")
        if nodes.min() < 0 or nodes.max() >= n_nodes:
            raise InputError(f"driven node {int(nodes.max())} is out of range for a model of "
                             f"{n_nodes} nodes", key="driven")
        unknown = set(self.components) - set(_COMPONENTS)
        if unknown or not self.components:
            raise InputError(f"driven components {self.components!r} must be letters of "
                             "'xyz'", key="driven")
        shift = np.broadcast_to(np.asarray(self.displacement, float), (len(nodes), 3))
        if not np.all(np.isfinite(shift)):
            raise InputError("a driven displacement is not finite", key="driven")
        columns = sorted({_COMPONENTS[c] for c in self.components})
        dofs = (3 * nodes[:, None] + np.array(columns)).ravel()
        return dofs, shift[:, columns].ravel()


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium (:func:`equilibrium`).

    Attributes
    ----------
    positions : (n_nodes, 3) float
    reaction : (n_nodes, 3) float
        The force the supports and drivers exert on each node (zero at free components).
    iterations : int
        Newton iterations over all increments.
    residual : float
        The largest out-of-balance force left at a free component (N).
    stiffness : (3 n_nodes, 3 n_nodes) sparse, or None
        ``-∂F/∂p`` at the equilibrium (what its sensitivities solve with), when the last
        iteration assembled it.
    held : (n_held,) int
        The held degrees of freedom (node-major ``3 i + k``).
    factor : SuperLU or None
        The factorisation the last Newton iteration solved with (for nearby solves).
    contact_forces : (n_nodes, 3) float or None
        The force a tool in ``contact`` exerts on each node (:attr:`contact_force` sums it).
    """

    positions: np.ndarray
    reaction: np.ndarray
    iterations: int
    residual: float
    stiffness: object = None
    held: np.ndarray | None = None
    factor: object = None
    contact_forces: np.ndarray | None = None

    @property
    def contact_force(self) -> np.ndarray | None:
        """(3,) the tool's total force on the body (``contact``), or None."""
        return None if self.contact_forces is None else self.contact_forces.sum(axis=0)

    def solve_free(self, right: np.ndarray, tolerance: float = 1e-10) -> np.ndarray:
        """``K_ff⁻¹ right`` (free degrees of freedom; ``right`` (n_free,) or (n_free, k)) with
        the equilibrium's stiffness, to a relative ``tolerance``: GMRES preconditioned by the
        factorisation the Newton iterations used (:func:`_solve`), or a new factorisation
        when that does not converge."""
        free = np.setdiff1d(np.arange(self.stiffness.shape[0]), self.held)
        K = self.stiffness[free][:, free]
        right = np.asarray(right, float)
        columns = right.reshape(len(free), -1)
        out = np.empty_like(columns)
        factor = self.factor
        for k in range(columns.shape[1]):
            out[:, k], factor = _solve(K, columns[:, k], factor, tolerance)
        return out.reshape(right.shape)

    def reaction_on(self, nodes) -> np.ndarray:
        """(3,) the total reaction on ``nodes``: what a load cell under them reads."""
        return self.reaction[np.asarray(nodes)].sum(axis=0)


def equilibrium(model: Model, *, driven: Driven | Sequence[Driven] = (),
                load: np.ndarray | None = None, start: np.ndarray | None = None,
                increments: int = 1, tolerance: float = 1e-8,
                max_iterations: int = 30, factor=None, contact=None,
                tool_start=None) -> Equilibrium:
    """The static equilibrium of ``model``: its fixed nodes at rest, the ``driven`` sets moved,
    ``load`` (n_nodes, 3) N applied (module docstring).

    Parameters
    ----------
    model : Model
    driven : Driven or sequence of Driven
        Sets of nodes moved by a prescribed displacement from rest.
    load : (n_nodes, 3) float, optional
        External force per node (N).
    start : (n_nodes, 3) float, optional
        The equilibrium of the previous load step (rest by default): the increments go from
        its driven displacements and load (taken as zero) to these.
    increments : int
        Equal parts the displacements and load are applied in (each halved where needed).
    tolerance : float
        Converged when the largest out-of-balance force is ``tolerance`` times the largest
        force on the body (reaction or load), or the Newton step
        ``tolerance`` times 1e-4 of the body's size.
    max_iterations : int
        Newton iterations per increment before it is halved (:class:`ConvergenceError`
        after :data:`CUTS` halvings).
    factor : SuperLU, optional
        A factorisation of the free stiffness of a nearby equilibrium with the same held
        degrees of freedom (the same step at nearby material parameters): Newton's systems
        are solved by GMRES preconditioned by it, refactorised only where that does not
        converge (:func:`_solve`). Each Newton iteration reuses the last factorisation so.
    contact : Contact, optional
        A rigid tool pressed against the surface
        (:func:`~neurofuzzy.simulation.contact.contact_with`): its penalty force joins the
        body's force and its derivative the stiffness; :attr:`Equilibrium.contact_force` is
        the tool's force on the body.
    tool_start : (3,) float, optional
        The tool's position at ``start`` (default: ``contact``'s own): the increments move it
        from there.
    """
    n = model.n_nodes
    rest = model.mesh.rest_positions
    sets = [driven] if isinstance(driven, Driven) else list(driven)
    held, shift = _constraints(model, sets)
    f_ext = np.zeros((n, 3)) if load is None else np.asarray(load, float)
    if f_ext.shape != (n, 3) or not np.all(np.isfinite(f_ext)):
        raise InputError(f"load must be a finite ({n}, 3) array; got shape {f_ext.shape}",
                         key="load")
    if int(increments) < 1:
        raise InputError(f"increments must be at least 1; got {increments}", key="increments")
    free = np.setdiff1d(np.arange(3 * n), held)
    tool_end = None if contact is None else contact.position
    tool_from = tool_end if tool_start is None or contact is None else np.asarray(
        tool_start, float)

    def state_at(positions, fraction, matrices=True):
        """The model's force and stiffness, with the tool's at its place at ``fraction``."""
        state = tangents(model, positions, long_time=True, damping=False, matrices=matrices)
        if contact is None:
            return state
        touch = contact.at(tool_from + fraction * (tool_end - tool_from))
        force = state.force + touch.forces(positions)
        stiffness = (None if state.stiffness is None
                     else state.stiffness + touch.stiffness_matrix(positions))
        return type(state)(force, stiffness, None)

    def forces_at(positions, fraction):
        return state_at(positions, fraction, matrices=False).force

    p = np.array(rest if start is None else start, dtype=float)
    if p.shape != (n, 3) or not np.all(np.isfinite(p)):
        raise InputError(f"start must be finite positions of shape ({n}, 3); got {p.shape}",
                         key="start")
    p = p.ravel()
    first = p[held] - rest.ravel()[held]
    size = float(np.ptp(rest, axis=0).max())
    iterations = 0

    def newton_to(fraction, last_try):
        """Newton's iterations to the equilibrium at ``fraction`` of the way from ``start``
        (``p`` moves there); ``(state, load, residual)``, or :class:`_Diverged` (an uphill
        step gives up at once unless this is the ``last_try``)."""
        nonlocal factor, iterations
        target = rest.ravel()[held] + first + fraction * (shift - first)
        load_now = fraction * f_ext.ravel()
        # predictor: the free nodes follow the driven ones linearly
        move = target - p[held]
        if np.any(move):
            K = state_at(p.reshape(n, 3), fraction).stiffness
            coupling = K[free][:, held] @ move
            change, factor = _solve(K[free][:, free], coupling, factor, NEWTON_RTOL)
            p[free] -= change
        p[held] = target
        for _ in range(max_iterations):
            state = state_at(p.reshape(n, 3), fraction)
            out = state.force.ravel() + load_now
            scale = max(np.abs(out[held]).max(initial=0.0), np.abs(load_now).max(), 1e-300)
            residual = np.abs(out[free]).max(initial=0.0)
            if residual <= tolerance * scale:
                return state, load_now, residual
            delta, factor = _solve(state.stiffness[free][:, free], out[free], factor,
                                   NEWTON_RTOL)
            iterations += 1
            if contact is not None and not last_try and not float(out[free] @ delta) > 0:
                raise _Diverged(residual)     # uphill: the tangent is indefinite here
            force_at = partial(forces_at, fraction=fraction)
            p[free] += (_line_search(force_at, p, free, delta, load_now, residual)
                        if contact is None else
                        _energy_search(force_at, p, free, delta, load_now, out[free]))
            if np.abs(delta).max() <= 1e-4 * tolerance * size:
                state = state_at(p.reshape(n, 3), fraction, matrices=False)
                out = state.force.ravel() + load_now
                return state, load_now, np.abs(out[free]).max(initial=0.0)
        raise _Diverged(residual)

    # increments, each halved up to CUTS times where Newton's method does not converge from
    # the last equilibrium (nodes entering a tool's contact in bulk, an indefinite tangent)
    pending = [k / int(increments) for k in range(int(increments), 0, -1)]
    done, smallest = 0.0, 1.0 / int(increments) / 2**CUTS
    while pending:
        fraction, saved = pending[-1], p.copy()
        last_try = fraction - done <= smallest * (1 + 1e-9)
        try:
            state, load_now, residual = newton_to(fraction, last_try)
        except _Diverged as why:
            if last_try:
                raise ConvergenceError(
                    f"no equilibrium after {max_iterations} Newton iterations at "
                    f"{100 * fraction:.3g} % of the way (out-of-balance force "
                    f"{float(why.args[0]):.3g} N), even in increments of {100 * smallest:.2g} %: "
                    "apply the displacements in more increments" + stall_note(model.elements),
                    key="increments") from None
            p[:] = saved
            pending.append(done + 0.5 * (fraction - done))
            continue
        pending.pop()
        done = fraction
    reaction = np.zeros(3 * n)
    reaction[held] = -(state.force.ravel()[held] + load_now[held])
    stiffness = state.stiffness
    if stiffness is None:
        stiffness = state_at(p.reshape(n, 3), 1.0).stiffness
    touched = None if contact is None else contact.forces(p.reshape(n, 3))
    return Equilibrium(p.reshape(n, 3), reaction.reshape(n, 3), iterations, float(residual),
                       stiffness, held, factor, touched)


class _Diverged(Exception):
    """Newton's method left an increment unsolved (``args[0]``: the out-of-balance force)."""


def _constraints(model: Model, sets: list[Driven]) -> tuple[np.ndarray, np.ndarray]:
    """The held degrees of freedom (the fixed nodes' three, then the driven sets') and their
    displacements from rest; a degree of freedom held twice is refused."""
    fixed = np.asarray(model.mesh.fixed, dtype=np.intp)
    dofs = [(3 * fixed[:, None] + np.arange(3)).ravel()]
    shifts = [np.zeros(3 * len(fixed))]
    for item in sets:
        d, s = item.dofs(model.n_nodes)
        dofs.append(d)
        shifts.append(s)
    held = np.concatenate(dofs)
    unique, counts = np.unique(held, return_counts=True)
    if np.any(counts > 1):
        node = int(unique[counts > 1][0] // 3)
        raise InputError(f"node {node} is held twice (fixed and driven, or in two driven "
                         "sets): a node is held by one boundary", key="driven")
    return held, np.concatenate(shifts)


#: how exactly GMRES solves a Newton system (relative): Newton checks the residual itself, and
#: an inexact step converges as fast where the error is this much below the step's
NEWTON_RTOL = 1e-8


def _solve(matrix, right, factor=None, tolerance=1e-12):
    """``(matrix⁻¹ right, the factorisation used)``. With ``factor``, a factorisation of a
    nearby matrix (an earlier Newton iteration's, or the same step's at nearby material
    parameters), GMRES preconditioned by it: a few triangular solves instead of a new
    factorisation, which costs ten to thirty of them; a new one when GMRES has not converged
    to ``tolerance`` after 60 iterations (their triangular solves cost about half a
    factorisation)."""
    if factor is not None and tuple(factor.shape) == matrix.shape and np.any(right):
        preconditioner = spla.LinearOperator(matrix.shape, matvec=factor.solve)
        x, info = spla.gmres(matrix, right, x0=factor.solve(right), rtol=tolerance,
                             atol=0.0, restart=60, maxiter=1, M=preconditioner)
        if info == 0:
            return x, factor
    factor = _factor(matrix)
    return factor.solve(right), factor


def _factor(matrix):
    """SuperLU's factorisation of ``matrix``: ordered by minimum degree on ``A + Aᵀ`` with
    pivots taken from the diagonal unless a hundred times smaller than the column's largest
    (SuperLU's symmetric mode), since the stiffness is symmetric in structure and value. On
    the nodal form's 10,368-tetrahedron block: 0.79 s against 1.46 s with SciPy's default
    (column ordering, partial pivoting), and 7.3 s at ν 0.499 compressed 18 %, where partial
    pivoting leaves the diagonal."""
    return spla.splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.01,
                     options={"SymmetricMode": True})


def _line_search(force_at, p, free, delta, load, residual, shrink=0.5, tries=8):
    """The Newton step ``delta`` scaled back (halved up to ``tries`` times) until the largest
    out-of-balance force falls; the full step when none does (Newton's own way out).
    ``force_at(positions)`` is the body's force (n_nodes, 3)."""
    step = 1.0
    for _ in range(tries):
        trial = p.copy()
        trial[free] += step * delta
        force = force_at(trial.reshape(-1, 3)).ravel() + load
        if np.all(np.isfinite(force)) and np.abs(force[free]).max() < residual:
            return step * delta
        step *= shrink
    return delta


def _energy_search(force_at, p, free, delta, load, out, tries=8):
    """The Newton step ``delta`` scaled to where the energy stops falling along it: the
    out-of-balance force's component along the step, ``s(α) = r(p + α δ)·δ``, positive at
    ``α = 0``, is brought below half its start (regula falsi between the last ``α`` where it
    is positive and the first where it is negative). Where a tool's penalty switches on and
    off at nodes entering and leaving contact, the largest force need not fall along a good
    step, and full steps cycle; the energy (elastic and penalty, both with continuous
    gradients) does fall."""
    start = float(out @ delta)
    if not start > 0:
        return delta

    def slope(alpha):
        trial = p.copy()
        trial[free] += alpha * delta
        force = force_at(trial.reshape(-1, 3)).ravel() + load
        value = float(force[free] @ delta)
        return value if np.isfinite(value) else -np.inf

    low, s_low, high = 0.0, start, 1.0
    s_high = slope(high)
    if s_high >= -0.5 * start:
        return delta
    alpha = high
    for _ in range(tries):
        alpha = high if not np.isfinite(s_high) else low + (high - low) * s_low / (
            s_low - s_high)
        alpha = min(max(alpha, low + 0.05 * (high - low)), high - 0.05 * (high - low))
        value = slope(alpha)
        if abs(value) <= 0.5 * start:
            break
        if value > 0:
            low, s_low = alpha, value
        else:
            high, s_high = alpha, value
    return alpha * delta
