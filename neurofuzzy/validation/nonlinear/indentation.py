"""Deep indentation by a rigid sphere, from a solver nobody here wrote: sfepy's quadratic
tetrahedra and its own contact term, for the indentation fit's reference data (issue 46).

The closed forms of :mod:`neurofuzzy.validation.indentation` (Hertz; Dimitriadis et al. for
a bonded layer) hold for a shallow indentation of linear tissue. At 10-20 % of a block's
height the strain is large and the contact region wide, and only another solver can say what
the force and the surface's motion are. :func:`indent_with_sphere` asks sfepy:

- the tissue: the coupled compressible neo-Hookean solid, total-Lagrangian quadratic
  tetrahedra (:class:`~.solver.HyperelasticSolver`: sfepy's assembly, quadrature and
  kinematics, the law's two formulas in its framework);
- the contact: sfepy's ``dw_contact_sphere`` term (its own code), a penalty on the surface's
  quadrature points, the force per reference area ``k d`` where a point is ``d`` inside the
  sphere, pointed at the sphere's centre; another formulation than ours (a penalty on the
  surface *nodes*, :mod:`neurofuzzy.simulation.contact`), so the two agree only as both
  meshes and penalties converge;
- the solve: Newton's method on sfepy's residual and tangent with a backtracking line search,
  the sphere moved down in ``increments`` equal parts to each depth.

The tool's force is the contact term's residual summed over the surface (the integral of its
traction); the markers are the quadratic displacement field read at their rest points
(sfepy's ``evaluate_at``).

Nearly incompressible tissue (``mixed=True``, for ν 0.49 and above): quadratic tetrahedra of
displacement alone lock there (too stiff, the more the closer ν is to 0.5). The mixed form
adds a continuous linear pressure ``p`` (Taylor–Hood, stable) with sfepy's own terms: the
stress ``-p J C⁻¹`` (``dw_tl_bulk_pressure``) and the volume equation ``∫ q (J - 1 + p/λ) =
0`` (``dw_tl_volume``, ``dw_integrate``, ``dw_dot``); the rest of the law, ``μ (I - C⁻¹)``, is
the coupled term with λ = 0. The volume part is then ``λ/2 (J - 1)²`` where the law has
``λ/2 (ln J)²``: the same to second order in ``J - 1``, and at ν 0.49 ``J`` stays within a
few per cent of 1, where the pressure ``p = -λ (J - 1)`` carries the load and the two forms
differ by ``(J - 1)/2`` of it. Needs sfepy (``pip install 'neurofuzzy[validation-nonlinear]'``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from ...errors import InputError
from ._newton import Inverted
from ._sfepy_setup import field_variables, quiet
from .materials import NeoHookean
from .solver import HyperelasticSolver

__all__ = ["Indentation", "indent_with_sphere", "indent_quarter"]


@dataclass(frozen=True)
class Indentation:
    """What sfepy computed at each depth.

    Attributes
    ----------
    force : (n_steps, 3) float
        The sphere's total force on the body (N); pressing down is negative ``z``.
    displacements : (n_steps, n_markers, 3) float
        Each marker's displacement from rest (m).
    penetration : (n_steps,) float
        The deepest quadrature point inside the sphere (m): the penalty's share.
    iterations : int
        Newton iterations in all.
    """

    force: np.ndarray
    displacements: np.ndarray
    penetration: np.ndarray
    iterations: int


def indent_with_sphere(points, tetrahedra, *, material: NeoHookean, radius: float,
                       centres, fixed: dict, top: float, markers=None,
                       penalty: float, increments: int = 4, order: int = 2,
                       tolerance: float = 1e-9, mixed: bool = False,
                       progress=None) -> Indentation:
    """Press a rigid sphere into a tetrahedral mesh, in equilibrium at each of ``centres``.

    Parameters
    ----------
    points, tetrahedra
        The body's mesh (m); sfepy makes its quadratic tetrahedra from it (``order`` 2).
    material : NeoHookean
    radius : float
        The sphere's radius (m).
    centres : (n_steps + 1, 3) float
        The sphere's centre at rest (touching, or clear of the body) and at each load step.
    fixed : dict
        ``{component: where}`` as :class:`~.solver.HyperelasticSolver`'s (``"all"`` for the
        base, 0 and 1 for symmetry planes).
    top : float
        The height of the surface the sphere meets (``z``; its facets carry the contact).
    markers : (n_markers, 3) float, optional
        Rest points where the displacement is read.
    penalty : float
        The contact stiffness ``k`` (Pa/m): the force per area ``k d`` at a penetration ``d``.
    increments : int
        Equal parts each move of the sphere is made in.
    mixed : bool
        Displacement and pressure (module docstring), for nearly incompressible tissue;
        ``order`` 2 only.
    """
    from sfepy.discrete import Equation, Equations, Integral, Material, Problem
    from sfepy.mechanics.contact_bodies import ContactSphere
    from sfepy.terms import Term

    say = progress or (lambda message: None)
    centres = np.asarray(centres, float)
    if centres.ndim != 2 or centres.shape[1] != 3 or len(centres) < 2:
        raise InputError(f"got shape {centres.shape}; expected (n_steps + 1, 3)", key="centres")
    if not (radius > 0 and penalty > 0 and int(increments) >= 1):
        raise InputError("radius, penalty and increments must be positive", key="radius")
    if mixed and order != 2:
        raise InputError("the mixed form is quadratic displacement and linear pressure: "
                         f"order 2, got {order}", key="order")
    # mixed: the solver holds the law's μ part alone (ν = 0 and E = 2μ give λ = 0)
    solver = HyperelasticSolver(points, tetrahedra, material=material if not mixed else
                                NeoHookean(2 * material.shear_modulus, 0.0), density=1000.0,
                                fixed=fixed, order=order)
    span = float(np.ptp(np.asarray(points, float), axis=0).max())
    with quiet():
        surface = solver.domain.create_region(
            "Top", f"vertices in (z > {top - 1e-9 * span})", "facet")
        contact = Material("cs", f=np.array([[float(penalty), 0.0]]),
                           **{".c": centres[0], ".r": float(radius)})
        integral = Integral("contact", order=2 * order + 2)
        terms, evaluators = [], []
        for active in (True, False):      # the reduced system, and the whole surface's force
            term = Term.new("dw_contact_sphere(cs.f, cs.c, cs.r, v, u)", integral, surface,
                            cs=contact, **field_variables(solver.field))
            problem = Problem("contact", equations=Equations([Equation("contact", term)]),
                              active_only=active)
            if active:
                problem.set_bcs(ebcs=solver._ebcs)
            problem.time_update()
            problem.update_materials(verbose=False)
            problem.equations.init_state()
            terms.append(term)
            evaluators.append(problem.get_evaluator())
    reduced, whole = evaluators
    n_u = len(solver.free)
    pressure = _Pressure(solver, material.lame_lambda, span) if mixed else None

    def place(centre):
        for term in terms:                # the term keeps its sphere once it has made it
            term.cs = ContactSphere(np.asarray(centre, float), float(radius))

    def residual(x):
        u = x[:n_u]
        r = solver._internal(u) + reduced.eval_residual(u)
        return r if pressure is None else pressure.residual(x, r)

    def tangent(x):
        u = x[:n_u]
        matrix = solver._tangent(u)
        reduced.eval_residual(u)
        matrix = matrix + reduced.eval_tangent_matrix(u)
        return (matrix if pressure is None else pressure.tangent(x, matrix)).tocsc()

    u = np.zeros(n_u + (0 if pressure is None else pressure.n_p))
    count = 0
    markers = np.zeros((0, 3)) if markers is None else np.asarray(markers, float)
    forces, moved, deepest = [], [], []
    for step in range(1, len(centres)):
        for k in range(1, int(increments) + 1):
            place(centres[step - 1] + k / int(increments) * (centres[step] - centres[step - 1]))
            u, used = _newton(residual, tangent, u, tolerance, f"step {step}")
            count += used
        full = solver._full(u[:n_u])
        with quiet():
            traction = np.asarray(whole.eval_residual(full)).reshape(-1, 3)
        forces.append(-traction.sum(axis=0))          # sfepy's normal points at the centre
        moved.append(solver.at(full, markers) if len(markers) else np.zeros((0, 3)))
        current = solver.field.get_coor() + full.reshape(-1, 3)
        deepest.append(max(0.0, float(radius - np.linalg.norm(current - centres[step],
                                                              axis=1).min())))
        say(f"step {step}: force {forces[-1][2]:.4g} N, {count} Newton iterations")
    return Indentation(np.array(forces), np.array(moved), np.array(deepest), count)


class _Pressure:
    """The mixed form's pressure (module docstring): its field, the terms that hold it, and
    the whole system's residual and tangent from the displacement-only ones. The unknown is
    ``p`` in units of length (``p · span / λ``) and the volume equation's rows are scaled by
    ``λ / span``, so the Newton step's test and the line search see one scale."""

    def __init__(self, solver, lame_lambda: float, span: float):
        from sfepy.discrete import (Equation, Equations, FieldVariable, Integral, Material,
                                    Problem)
        from sfepy.discrete.fem import Field
        from sfepy.terms import Term

        self.scale = float(lame_lambda) / span        # Pa per metre of the unknown
        with quiet():
            field = Field.from_args("pressure", np.float64, "scalar", solver.omega,
                                    approx_order=1)
            u = FieldVariable("u", "unknown", solver.field)
            v = FieldVariable("v", "test", solver.field, primary_var_name="u")
            p = FieldVariable("p", "unknown", field)
            q = FieldVariable("q", "test", field, primary_var_name="p")
            integral = Integral("mixed", order=solver.quadrature_order)
            m = Material("mixed", gamma=1.0 / float(lame_lambda))
            balance = Term.new("dw_tl_bulk_pressure(v, u, p)", integral, solver.omega,
                               v=v, u=u, p=p)
            volume = (Term.new("dw_tl_volume(q, u)", integral, solver.omega, q=q, u=u)
                      - Term.new("dw_integrate(q)", integral, solver.omega, q=q)
                      + Term.new("dw_dot(mixed.gamma, q, p)", integral, solver.omega,
                                 mixed=m, q=q, p=p))
            problem = Problem("mixed", equations=Equations([Equation("balance", balance),
                                                            Equation("volume", volume)]),
                              active_only=True)
            problem.set_bcs(ebcs=solver._ebcs)
            problem.time_update()
            problem.update_materials(verbose=False)
            problem.equations.init_state()
            self.evaluator = problem.get_evaluator()
        self.n_u, self.n_p = len(solver.free), field.n_nod
        # sfepy orders the unknowns as it finds them in a set; ours: displacement, pressure
        where = self.evaluator.problem.equations.variables.adi.indx
        self._order = np.r_[np.arange(where["u"].start, where["u"].stop),
                            np.arange(where["p"].start, where["p"].stop)]
        if len(self._order) != self.n_u + self.n_p or where["u"].stop - where[
                "u"].start != self.n_u:
            raise RuntimeError("the mixed system's displacement is not the solver's")
        self._rows = np.ones(self.n_u + self.n_p)
        self._rows[self.n_u:] = self.scale

    def _state(self, x):
        """sfepy's state vector of ``x``."""
        state = np.empty_like(x)
        state[self._order] = x * self._rows
        return state

    def residual(self, x, displacement_part):
        """The whole residual at ``x`` (displacement, scaled pressure), given the
        displacement-only terms' ``displacement_part``."""
        with quiet():
            r = np.asarray(self.evaluator.eval_residual(self._state(x)), float)[self._order]
        r[:self.n_u] += displacement_part
        return r * self._rows

    def tangent(self, x, displacement_part):
        """The whole tangent at ``x``, given the displacement-only terms' one."""
        import scipy.sparse as sp

        with quiet():
            self.evaluator.eval_residual(self._state(x))
            matrix = sp.csr_matrix(self.evaluator.eval_tangent_matrix(self._state(x)))
        matrix = matrix[self._order][:, self._order]
        blocks = sp.block_diag([displacement_part, sp.csr_matrix((self.n_p, self.n_p))])
        rows = sp.diags(self._rows)
        return rows @ (matrix + blocks) @ rows


def indent_quarter(mesh, **keywords) -> Indentation:
    """:func:`indent_with_sphere` on a quarter block's ``mesh``
    (:func:`~neurofuzzy.validation.indentation.quarter_block`): its base ``z = 0`` held, its
    symmetry planes ``x = 0`` and ``y = 0`` held in their normal, the sphere meeting its top."""
    points = mesh.rest_positions
    tol = 1e-9 * float(np.ptp(points, axis=0).max())
    return indent_with_sphere(points, mesh.tetrahedra, top=float(points[:, 2].max()),
                              fixed={"all": lambda x: x[2] < tol, 0: lambda x: x[0] < tol,
                                     1: lambda x: x[1] < tol}, **keywords)


def _newton(residual, tangent, u, tolerance, where, most=100):
    """Newton's method with a backtracking line search on the residual's norm (and away from
    inverted elements), converged when the step is ``tolerance`` of the largest
    displacement."""
    r = residual(u)
    for count in range(1, most + 1):
        step = -spla.splu(tangent(u)).solve(r)
        if np.abs(step).max() <= tolerance * max(np.abs(u).max(), 1e-12):
            return u + step, count
        size, norm = 1.0, np.linalg.norm(r)
        for _ in range(20):
            try:
                trial = residual(u + size * step)
            except Inverted:                    # the step turned an element inside out
                trial = None
            if trial is not None and np.linalg.norm(trial) < (1 - 1e-4 * size) * norm:
                break
            size *= 0.5
        if trial is None:
            break
        u, r = u + size * step, trial
    raise InputError(f"sfepy's contact solve did not converge at {where}; take more "
                     "increments", key="increments")
