"""The derivatives of implicit steps (:func:`~.implicit.simulate_implicit`) by the elements'
E, ν and η: what a fit through backward Euler or BDF2 steps needs (:mod:`neurofuzzy.learn.
implicit_fit`), for loads, driven node sets (a plate on a stage) and a tool in contact.

:func:`implicit_sensitivities` differentiates the trajectory of converged steps: differentiating
the step's equation ``R(v₁; x₀, v₀, θ) = 0`` gives

    (M + hC + h²K) dv₁ = M dv₀ - hK dx₀ + h ∂F/∂θ    at (x₁, v₁),    dx₁ = dx₀ + h dv₁,

over the free degrees of freedom, with ``∂F/∂θ`` exact from the elements' forces per unit of
``2μ``, ``λ``, ``2μβ`` and ``λβ`` (:func:`~neurofuzzy.simulation.tangents.unit_forces`; the
forces are linear in each); for BDF2 the same with ``2h/3`` for ``h`` and the history's
``(4 dx₀ - dx₋₁)/3``, ``(4 dv₀ - dv₋₁)/3`` for ``dx₀``, ``dv₀``. A driven degree of freedom
follows its path whatever θ (its derivatives are zero), and a tool's contact adds its penalty
stiffness to ``K``; a penalty left ``"auto"`` scales with the largest E
(:func:`~neurofuzzy.simulation.contact.contact_with`), so its force is in that group's
``∂F/∂E`` too (per unit of E, the contact's force over E). What a driven set's driver
exerts, ``M (v₁ - v₀)/h - F - f`` summed over the set, then changes by
``Σ (K dx₁ + C dv₁ - ∂F/∂θ)`` over its degrees of freedom; what the tool exerts on the body,
by ``-Σ K_c dx₁`` (``K_c`` the contact's stiffness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import Model
from .implicit import ImplicitRun, _base
from .implicit_relaxation import RelaxationTangent
from .krylov import gmres
from .static import ConvergenceError, _factor
from .tangents import tangents, unit_forces

__all__ = ["implicit_sensitivities", "ForceDerivatives", "PARAMETERS"]

#: The element constants :func:`implicit_sensitivities` differentiates by, in its columns' order
PARAMETERS = ("youngs_modulus", "poisson_ratio", "viscosity")
#: relative residual of the derivatives' linear solves by GMRES preconditioned with an earlier
#: step's factorisation
SOLVE_TOLERANCE = 1e-9
#: GMRES restart cycles (of 20 iterations) before the step's matrix is factorised afresh
#: (:func:`.krylov.gmres`, preconditioned on the right: it ends on the true residual; SciPy's,
#: used before, ended a cycle on the preconditioned one, 10 to 100 times below the true one
#: on the pushed blocks, and needed the further cycles for that)
SOLVE_CYCLES = 4
#: Newton iterations a step may take: the derivatives are those of the solved step
ITERATIONS = 50


@dataclass(frozen=True)
class ForceDerivatives:
    """The derivatives of the forces a run's boundaries exert, beside the positions'.

    Attributes
    ----------
    reactions : (n_frames, n_columns, n_sets, 3) float or None
        ``∂Trajectory.reactions/∂θ`` (N per unit of each constant), without driven sets None.
    tool_forces : (n_frames, n_columns, 3) float or None
        ``∂Trajectory.tool_forces/∂θ``, without a tool None.
    """

    reactions: np.ndarray | None
    tool_forces: np.ndarray | None


def implicit_sensitivities(model: Model, *, dt: float, n_frames: int,
                           external_forces: np.ndarray | None = None,
                           initial_positions: np.ndarray | None = None,
                           initial_velocities: np.ndarray | None = None, substeps: int = 1,
                           groups: np.ndarray | None = None, tolerance: float = 1e-11,
                           scheme: str = "euler", driven=(), tool=None,
                           forces: bool = False):
    """Converged backward Euler (or BDF2) steps and their derivatives by each element group's
    E, ν, η (module docstring).

    Parameters
    ----------
    model : Model
        Elements (one E, ν, η per group, their Prony terms too) with no springs or effects.
    dt, n_frames, external_forces, initial_positions, initial_velocities, substeps, scheme
        As :func:`~.implicit.simulate_implicit` (the start does not depend on the constants).
    groups : (n_elements,) int, optional
        The element groups (default: one).
    tolerance : float
        Newton's tolerance on each step's velocity (the derivatives are those of the solved
        step).
    driven, tool
        Driven node sets (DrivenPaths) and a tool (a ToolPath), one row per frame, as
        :func:`~.implicit.simulate_implicit` takes them.
    forces : bool
        Also return the derivatives of the driven sets' reactions and the tool's force.

    Returns
    -------
    trajectory : Trajectory
        With its ``reactions`` and ``tool_forces`` where there are driven sets or a tool.
    derivatives : (n_frames, 3 n_groups, n_nodes, 3) float
        ``∂positions/∂θ``, column ``k n_groups + g`` by constant ``PARAMETERS[k]`` of group
        ``g`` (m per Pa, m, m per Pa·s).
    force_derivatives : ForceDerivatives
        Only with ``forces=True``.
    """
    n = model.n_nodes
    if model.elements is None or model.springs is not None or model.effects:
        raise InputError("the implicit step's derivatives cover element models without "
                         "springs or effects", key="model")
    groups, values = _grouped(model, groups)
    n_groups = len(values[0])
    run = ImplicitRun(model, dt=dt, n_frames=n_frames, external_forces=external_forces,
                      initial_positions=initial_positions,
                      initial_velocities=initial_velocities, substeps=substeps,
                      iterations=ITERATIONS, tolerance=tolerance, scheme=scheme,
                      driven=driven, tool=tool)
    free, mass, moving = run.free, run.mass, run.moving
    columns = 3 * n_groups
    dx, dv = np.zeros((columns, 3 * n)), np.zeros((columns, 3 * n))
    derivatives = np.zeros((int(n_frames), columns, n, 3))
    d_reactions = d_touched = None
    if moving.driven:
        d_reactions = np.zeros((int(n_frames), columns, len(moving.driven), 3))
    if tool is not None:
        d_touched = np.zeros((int(n_frames), columns, 3))
    penalty_column = penalty_scale = None
    if tool is not None and isinstance(tool.stiffness, str):    # "auto": κ ∝ the largest E
        penalty_column = int(np.argmax(values[0]))
        penalty_scale = float(values[0][penalty_column])
    parameter_forces = _ParameterForces(model, groups, values)
    memory = (RelaxationTangent(model, groups, values, run.body.relaxation[1])
              if run.body.relaxes else None)
    changes_before, started = None, run.p
    for step in run.steps():
        if memory is not None:              # the internal variables held through this step
            memory.advance(started, dx)
        changes = _base(step.scheme, (dx, dv), changes_before)[1]
        changes_before = (dx, dv)
        he, p, v = step.h, step.positions, step.velocities
        started = p
        state = tangents(model, p, v, run.body.internal if memory is not None else None)
        stiffness = state.stiffness
        if step.contact is not None:
            contact_stiffness = step.contact.stiffness_matrix(p)
            stiffness = stiffness + contact_stiffness
            pressing = step.contact.forces(p)                    # (n_nodes, 3) on the body
        stiffness = sp.csr_array(stiffness)
        inner = stiffness[free][:, free]
        matrix = (sp.diags(mass) + he * state.damping[free][:, free]
                  + (he * he) * inner).tocsc()
        d_force = parameter_forces(p, v)                           # (columns, 3 n)
        if memory is not None:
            d_force += memory.force(p)
        if penalty_column is not None:
            d_force[penalty_column] += pressing.ravel() / penalty_scale
        right = (mass * changes[1][:, free] - he * (inner @ changes[0][:, free].T).T
                 + he * d_force[:, free])
        dv = np.zeros_like(dv)
        # one kept factorisation for the steps and their derivatives: the step's solver
        # refreshes it by its own rule, and one made here (the exact matrix) goes to it
        solver = run.solvers.of(step.scheme)
        for c in range(columns):
            dv[c, free], factor = _solve_step(matrix, right[c], solver.factor)
            if factor is not solver.factor:
                solver.adopt(factor)
        dx = changes[0] + he * dv
        if not step.ends_frame:
            continue
        frame = step.frame
        if not np.all(np.isfinite(dx)):
            raise ConvergenceError(f"the implicit step diverged at frame {frame}", key="dt")
        derivatives[frame] = dx.reshape(columns, n, 3)
        if d_reactions is not None:
            balance = (stiffness @ dx.T).T + (state.damping @ dv.T).T - d_force
            d_reactions[frame] = np.stack([moving.reactions(row) for row in balance])
        if d_touched is not None:
            d_touched[frame] = -(contact_stiffness @ dx.T).T.reshape(columns, n, 3).sum(axis=1)
            if penalty_column is not None:
                d_touched[frame, penalty_column] += run.touched[frame] / penalty_scale
    trajectory = run.trajectory()
    if forces:
        return trajectory, derivatives, ForceDerivatives(d_reactions, d_touched)
    return trajectory, derivatives


def _grouped(model: Model, groups) -> tuple[np.ndarray, list]:
    """``(groups, [E, ν, η] per group)``, refusing groups whose elements differ."""
    k = model.mesh.n_tetrahedra
    groups = np.zeros(k, np.intp) if groups is None else np.asarray(groups, np.intp)
    if groups.shape != (k,) or groups.min(initial=0) < 0:
        raise InputError(f"groups must be ({k},) non-negative ints; got {groups.shape}",
                         key="groups")
    n_groups = int(groups.max(initial=0)) + 1
    values = []
    for name in PARAMETERS:
        per_element = np.asarray(getattr(model.elements, name), float)
        first = np.zeros(n_groups)
        first[groups] = per_element
        if not np.allclose(per_element, first[groups], rtol=1e-12, atol=0.0):
            raise InputError(f"the elements of a group must share their {name}",
                             key="groups")
        values.append(first)
    return groups, values


class _ParameterForces:
    """``∂F/∂θ`` (columns, 3 n_nodes) at ``(p, v)``: the elements' forces per unit of 2μ, λ,
    2μβ and λβ of each group (:func:`~.tangents.unit_forces`), chained to E, ν, η."""

    def __init__(self, model, groups, values):
        from ..forces.tetra_geometry import lame_factors

        self.model, self.groups = model, groups
        self.E, self.nu, self.eta = values
        self.a, self.b, self.da, self.db = (np.asarray(x, float)
                                            for x in lame_factors(self.nu))

    def __call__(self, p, v):
        units = unit_forces(self.model, p, self.groups, velocities=v, instantaneous=True)
        units = units.reshape(len(self.E), 4, -1)
        a, b, da, db = (x[:, None] for x in (self.a, self.b, self.da, self.db))
        E, eta = self.E[:, None], self.eta[:, None]
        return np.concatenate([2 * b * units[:, 0] + a * units[:, 1],
                               2 * db * (E * units[:, 0] + eta * units[:, 2])
                               + da * (E * units[:, 1] + eta * units[:, 3]),
                               2 * b * units[:, 2] + a * units[:, 3]])


def _solve_step(matrix, right, factor):
    """``(matrix⁻¹ right, the factorisation used)``: GMRES preconditioned by ``factor`` (the
    step solver's kept factorisation, :class:`~.step_solve.StepSolver`, of this matrix at
    a nearby state; None: none yet), for up to :data:`SOLVE_CYCLES` cycles; a new
    factorisation (SuperLU, as the static solve's) where that does not reach
    :data:`SOLVE_TOLERANCE`.

    The step solver's factorisation, refreshed as the forward steps need, preconditions
    better than one kept here until GMRES failed: on the plate ramp's 4-cell block (121
    frames of BDF2) the derivatives took 802 GMRES iterations instead of 3,252 and no
    factorisation instead of one."""
    if not np.any(right):
        return np.zeros_like(right), factor
    if factor is not None:
        solved = gmres(matrix.dot, right, SOLVE_TOLERANCE * np.linalg.norm(right),
                       precondition=factor.solve, start=factor.solve(right), restart=20,
                       cycles=SOLVE_CYCLES)
        if solved.converged:
            return solved.x, factor
    factor = _factor(matrix)
    return factor.solve(right), factor
