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
(sfepy's ``evaluate_at``). Needs sfepy (``pip install 'neurofuzzy[validation-nonlinear]'``).
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
                       tolerance: float = 1e-9, progress=None) -> Indentation:
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
    solver = HyperelasticSolver(points, tetrahedra, material=material, density=1000.0,
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

    def place(centre):
        for term in terms:                # the term keeps its sphere once it has made it
            term.cs = ContactSphere(np.asarray(centre, float), float(radius))

    def residual(u):
        return solver._internal(u) + reduced.eval_residual(u)

    def tangent(u):
        matrix = solver._tangent(u)
        reduced.eval_residual(u)
        return (matrix + reduced.eval_tangent_matrix(u)).tocsc()

    u = np.zeros(len(solver.free))
    count = 0
    markers = np.zeros((0, 3)) if markers is None else np.asarray(markers, float)
    forces, moved, deepest = [], [], []
    for step in range(1, len(centres)):
        for k in range(1, int(increments) + 1):
            place(centres[step - 1] + k / int(increments) * (centres[step] - centres[step - 1]))
            u, used = _newton(residual, tangent, u, tolerance, f"step {step}")
            count += used
        full = solver._full(u)
        with quiet():
            traction = np.asarray(whole.eval_residual(full)).reshape(-1, 3)
        forces.append(-traction.sum(axis=0))          # sfepy's normal points at the centre
        moved.append(solver.at(full, markers) if len(markers) else np.zeros((0, 3)))
        current = solver.field.get_coor() + full.reshape(-1, 3)
        deepest.append(max(0.0, float(radius - np.linalg.norm(current - centres[step],
                                                              axis=1).min())))
        say(f"step {step}: force {forces[-1][2]:.4g} N, {count} Newton iterations")
    return Indentation(np.array(forces), np.array(moved), np.array(deepest), count)


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
