"""Large-strain elastodynamics of a tetrahedral mesh by sfepy, for data nobody here wrote.

:class:`HyperelasticSolver` is the nonlinear sibling of
:class:`~neurofuzzy.continuum_reference.ContinuumSolver` (same arguments, loads and
sampling): total-Lagrangian finite elements of sfepy (quadratic tetrahedra by default,
consistent mass), integrated with the average-acceleration Newmark scheme and Newton's
method at each step.

What is whose. sfepy (https://sfepy.org) computes the deformation gradient and its
invariants at the quadrature points, the stress and tangent of the Yeoh law
(``dw_tl_he_genyeoh`` + ``dw_tl_bulk_penalty``, its own code), the mass matrix
(``dw_dot``), the probe's surface traction (``dw_surface_ltr``), the assembly of the
total-Lagrangian residual and tangent (``dw_he_rtm``), and the sampling at markers. The
coupled neo-Hookean law, which sfepy lacks, is written here as two formulas in sfepy's
hyperelastic framework (:mod:`._sfepy_terms`) and checked three ways: its stress and tangent
equal sfepy's own C neo-Hookean terms when given the uncoupled law's formulas, a block in
uniaxial stress reproduces the closed form of :mod:`.closed_forms` (written in principal
stretches, a different formula), and the solver reduces to the linear reference at small
strain. The time stepping (Newmark, Newton, the Prony update) is written here, as in
``ContinuumSolver``; it is checked by convergence in time, energy conservation without
damping, and the closed forms of creep.

Why sfepy rather than our own assembly on scikit-fem: its hyperelastic terms are an
implementation of the continuum mechanics that nobody here wrote (for the Yeoh law, the
whole constitutive code), compiled, and fast enough for dynamics (a residual of 2,300
quadratic tetrahedra in about 0.01 s, the tangent in 0.1 s); its Ogden term, in contrast,
loops over quadrature points in Python and is left out.

Viscoelasticity is FEBio's quasi-linear form (:class:`~.materials.Prony`): per quadrature
point and Prony term an internal stress ``Hᵢ`` with
``Hᵢ⁽ⁿ⁺¹⁾ = exp(-Δt/τᵢ) Hᵢ⁽ⁿ⁾ + (1 - exp(-Δt/τᵢ))/(Δt/τᵢ) (Sₑ⁽ⁿ⁺¹⁾ - Sₑ⁽ⁿ⁾)`` (exact for a
piecewise-linear elastic stress history) and total stress ``S = Sₑ + Σ gᵢ Hᵢ``. Within a
step S is ``(1 + Σ gᵢ hᵢ) Sₑ`` plus a constant, so the elastic terms are scaled and the
constant is a given stress. Kelvin–Voigt viscosity (optional) is our elements' form: the
viscous second Piola–Kirchhoff stress is the small-strain elastic stress of the Green
strain rate times η/E (``S_v = η/E ℂ₀ : Ė``), which at small strain is the linear
reference's stiffness-proportional damping.

Loads are *dead*: a force per reference area of fixed direction (the probe's push, as our
node forces are), or gravity. Needs sfepy (``pip install sfepy``, or
``pip install 'neurofuzzy[validation]'``).
"""

from __future__ import annotations

import contextlib
import io
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from ..errors import InputError
from .materials import NeoHookean, Prony, Yeoh

__all__ = ["HyperelasticSolver", "Trajectory"]


@contextlib.contextmanager
def _quiet():
    """sfepy reports its progress on stdout (and, without jax, a warning on import)."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


def _sfepy():
    try:
        with _quiet():
            import sfepy.discrete  # noqa: F401
            import sfepy.discrete.fem  # noqa: F401
            import sfepy.terms  # noqa: F401
            from sfepy.base.base import output
            output.set_output(quiet=True)  # sfepy's own switch; it only silences sfepy
    except ImportError:
        raise InputError("the nonlinear reference needs sfepy: pip install sfepy "
                         "(or neurofuzzy[validation])") from None
    import sfepy
    return sfepy


@dataclass
class Trajectory:
    """A run of :meth:`HyperelasticSolver.dynamic` with what it cost.

    Attributes
    ----------
    displacement, velocity : (n_frames, n_dofs) float
        At the frames (m, m/s).
    newton_iterations : int
        Over all steps.
    factorisations : int
        Sparse LU factorisations of the step matrix (modified Newton reuses them).
    seconds : float
        Wall time.
    """

    displacement: np.ndarray
    velocity: np.ndarray
    newton_iterations: int
    factorisations: int
    seconds: float


class HyperelasticSolver:
    """Large-strain elastodynamics of a tetrahedral mesh, by sfepy (module docstring).

    Parameters
    ----------
    points : (n_points, 3) float
        Mesh vertices (m).
    tetrahedra : (n_tetrahedra, 4) int
    material : NeoHookean or Yeoh
        The elastic law (the long-term one when ``prony`` is given).
    density : float
        kg/m³.
    fixed : callable or dict
        ``fixed(x)`` with ``x`` of shape (3, n): True where the boundary is held (evaluated
        at the vertices of boundary facets). A dict ``{component: callable}`` holds single
        components (0, 1, 2 for x, y, z), e.g. symmetry planes.
    viscosity : float
        Kelvin–Voigt η (Pa·s); 0 for none.
    prony : Prony, optional
        Quasi-linear viscoelasticity on top of ``material``.
    order : {1, 2}
        Linear or quadratic tetrahedra.
    quadrature_order : int, optional
        Of the stiffness integrals; default ``2 * order`` (the mass always takes
        ``2 * order``, exact).
    """

    def __init__(self, points, tetrahedra, *, material: NeoHookean | Yeoh, density: float,
                 fixed: Callable | dict, viscosity: float = 0.0, prony: Prony | None = None,
                 order: int = 2, quadrature_order: int | None = None):
        _sfepy()
        from sfepy.discrete import Equation, Equations, Function, Integral, Material, Problem
        from sfepy.discrete.conditions import Conditions, EssentialBC
        from sfepy.discrete.fem import FEDomain, Field, Mesh
        from sfepy.terms import Term

        from ._sfepy_terms import CoupledNeoHookeanTLTerm, GivenStressTLTerm, isotropic_tangent

        points = np.asarray(points, float)
        tetrahedra = np.asarray(tetrahedra)
        if points.ndim != 2 or points.shape[1] != 3:
            raise InputError(f"got shape {points.shape}; expected (n_points, 3)", key="points")
        if tetrahedra.ndim != 2 or tetrahedra.shape[1] != 4:
            raise InputError(f"got shape {tetrahedra.shape}; expected (n_tetrahedra, 4)",
                             key="tetrahedra")
        if not isinstance(material, (NeoHookean, Yeoh)):
            raise InputError(f"got {type(material).__name__}; expected NeoHookean or Yeoh",
                             key="material")
        if order not in (1, 2):
            raise InputError(f"got {order!r}; expected 1 or 2", key="order")
        if not (np.isfinite(viscosity) and viscosity >= 0):
            raise InputError(f"must be a non-negative number of Pa·s, got {viscosity!r}",
                             key="viscosity")
        if not density > 0:
            raise InputError(f"must be positive kg/m³, got {density!r}", key="density")
        self.material, self.density, self.viscosity = material, float(density), float(viscosity)
        self.prony, self.order = prony, order
        self.quadrature_order = quadrature_order or 2 * order

        # sfepy wants right-handed tetrahedra
        corners = points[tetrahedra]
        volume = np.einsum("ij,ij->i", np.cross(corners[:, 1] - corners[:, 0],
                                                corners[:, 2] - corners[:, 0]),
                           corners[:, 3] - corners[:, 0])
        tetrahedra = np.where((volume < 0)[:, None], tetrahedra[:, [0, 2, 1, 3]], tetrahedra)

        with _quiet():
            mesh = Mesh.from_data("block", points, None, [tetrahedra.astype(np.int32)],
                                  [np.zeros(len(tetrahedra), np.int32)], ["3_4"])
            self.domain = FEDomain("domain", mesh)
            self.omega = self.domain.create_region("Omega", "all")
            self.surface = self.domain.create_region("Surface", "vertices of surface",
                                                     "facet")
            self.field = Field.from_args("displacement", np.float64, "vector", self.omega,
                                         approx_order=order)
            variables = _variables(self.field)
            self.u, self.v = variables["u"], variables["v"]
            integral = Integral("stiffness", order=self.quadrature_order)
            self._integral = integral

            constants = {"rho": self.density}
            if isinstance(material, NeoHookean):
                constants["lame"] = np.array([[material.shear_modulus, material.lame_lambda]])
            else:
                # sfepy's generalised Yeoh: K1 (I1b-3)^m + K2 (I1b-3)^p + K3 (I1b-3)^q
                constants["yeoh"] = np.array([[material.c10, material.c20, material.c30,
                                               1.0, 2.0, 3.0]])
                constants["bulk"] = material.bulk_modulus
            self._material = Material("m", **constants)
            args = {"m": self._material, "v": self.v, "u": self.u}
            if isinstance(material, NeoHookean):
                elastic = [CoupledNeoHookeanTLTerm(CoupledNeoHookeanTLTerm.name,
                                                   "m.lame, v, u", integral, self.omega,
                                                   **args)]
            else:
                elastic = [Term.new("dw_tl_he_genyeoh(m.yeoh, v, u)", integral, self.omega,
                                    **args),
                           Term.new("dw_tl_bulk_penalty(m.bulk, v, u)", integral, self.omega,
                                    **args)]
            given = GivenStressTLTerm(GivenStressTLTerm.name, "v, u", integral, self.omega,
                                      v=self.v, u=self.u)
            if self.viscosity > 0:
                mu, lam = material.shear_modulus, _lame_lambda(material)
                given.viscous_tangent = (self.viscosity / material.youngs_modulus
                                         * isotropic_tangent(lam, mu))
            self._elastic, self._given = elastic, given

            ebcs = []
            rules = fixed if isinstance(fixed, dict) else {"all": fixed}
            for component, where in rules.items():
                if component not in ("all", 0, 1, 2):
                    raise InputError(f"components are 0, 1, 2; got {component!r}",
                                     key="fixed")
                name = f"Fixed{component}"
                vertex_test = Function(f"fixed_{component}",
                                       lambda coors, domain=None, where=where:
                                       np.flatnonzero(where(coors.T)))
                region = self.domain.create_region(name, f"vertices by fixed_{component}",
                                                   "facet", functions={
                                                       f"fixed_{component}": vertex_test},
                                                   allow_empty=True)
                if region.vertices.size == 0:
                    raise InputError(f"holds no vertex of the mesh (component {component})",
                                     key="fixed")
                dofs = "u.all" if component == "all" else f"u.{component}"
                ebcs.append(EssentialBC(f"fix_{component}", region, {dofs: 0.0}))
            self._ebcs = Conditions(ebcs)

            self.problem = Problem("nonlinear_reference",
                                   equations=Equations([Equation("balance",
                                                                 sum(elastic[1:],
                                                                     elastic[0]) + given)]),
                                   active_only=True)
            self.problem.set_bcs(ebcs=self._ebcs)
            self.problem.time_update()
            self.problem.update_materials(verbose=False)
            self.problem.equations.init_state()
            self._evaluator = self.problem.get_evaluator()

            mass_integral = Integral("mass", order=2 * order)
            # own variables: sfepy binds variables to the equations that use them
            mass_term = Term.new("dw_dot(m.rho, v, u)", mass_integral, self.omega,
                                 m=self._material, **_variables(self.field))
            mass_problem = Problem("mass", equations=Equations([Equation("mass", mass_term)]),
                                   active_only=True)
            mass_problem.set_bcs(ebcs=self._ebcs)
            mass_problem.time_update()
            mass_problem.update_materials(verbose=False)
            mass_problem.equations.init_state()
            self.mass = mass_problem.get_evaluator().eval_tangent_matrix(
                np.zeros(self.u.eq_map.n_eq)).tocsc()

        self.n_dofs = self.u.n_dof
        self.free = np.asarray(self.u.eq_map.eqi)
        # sfepy's total-Lagrangian terms look their reference mapping up among the *saved*
        # ones and build it anew at every evaluation otherwise: build it once and save it
        self._reset_state()
        self._internal(np.zeros(len(self.free)))
        self.field.save_mappings()

    # -- loads --------------------------------------------------------------------------------
    def probe_load(self, point, radius: float, force) -> np.ndarray:
        """(n_dofs,): a uniform force per reference area on the boundary within ``radius``
        of ``point`` that adds up to ``force`` (N): a probe pressing on a patch."""
        point = np.asarray(point, float)
        return self.surface_load(
            force, lambda x: np.sum((x - point[:, None]) ** 2, axis=0) <= radius**2)

    def surface_load(self, force, where: Callable) -> np.ndarray:
        """(n_dofs,): a uniform dead traction on the boundary where ``where(x)`` holds (``x``
        of shape (3, n) at quadrature points of the facets) that adds up to ``force`` (N)."""
        from sfepy.discrete import Function, Material

        force = np.asarray(force, float)

        def traction(ts, coors, mode=None, **kwargs):
            if mode != "qp":
                return None
            inside = np.asarray(where(coors.T), float)
            return {"val": np.repeat(inside[:, None, None], 3, axis=1)
                    * np.array([0.0, 0.0, 1.0])[None, :, None]}

        material = Material("load", function=Function("traction", traction))
        with _quiet():
            unit = self.problem.evaluate("dw_surface_ltr.10.Surface(load.val, v)",
                                         mode="weak", dw_mode="vector", copy_materials=False,
                                         active_only=False, load=material,
                                         v=_variables(self.field)["v"])
        unit = np.asarray(unit).reshape(-1, 3)[:, 2]
        area = float(unit.sum())
        if area <= 0:
            raise InputError("the load's patch contains no boundary", key="where")
        return (unit[:, None] * force[None, :] / area).ravel()

    def gravity_load(self, gravity) -> np.ndarray:
        """(n_dofs,): the weight ``ρ g`` of the object (``gravity`` in m/s²)."""
        from sfepy.discrete import Material

        weight = Material("weight", val=(self.density * np.asarray(gravity, float))[:, None])
        with _quiet():
            out = self.problem.evaluate("dw_volume_lvf.stiffness.Omega(weight.val, v)",
                                        mode="weak", dw_mode="vector", copy_materials=False,
                                        active_only=False, weight=weight,
                                        v=_variables(self.field)["v"])
        return np.asarray(out).ravel()

    # -- the equations ------------------------------------------------------------------------
    def _full(self, reduced: np.ndarray) -> np.ndarray:
        full = np.zeros(self.n_dofs)
        full[self.free] = reduced
        return full

    def _internal(self, u):
        """Internal force (reduced) at reduced displacement ``u``."""
        try:
            return self._evaluator.eval_residual(u)
        except ValueError as error:
            if "warp" in str(error):
                raise _Inverted() from None
            raise

    def _tangent(self, u):
        """Tangent stiffness (reduced) at reduced displacement ``u``."""
        # sfepy's hyperelastic terms take the stress of the tangent's geometric part from
        # their last residual evaluation: evaluate the residual at u first
        self._internal(u)
        try:
            return self._evaluator.eval_tangent_matrix(u).tocsc()
        except ValueError as error:
            if "warp" in str(error):
                raise _Inverted() from None
            raise

    def _set_scale(self, scale: float):
        for term in self._elastic:
            term.sign = scale

    def _elastic_stress(self, u) -> np.ndarray:
        """(n_cells, n_qp, 6): the elastic second Piola–Kirchhoff stress (Pa, unscaled) and,
        as a side effect, F in the given-stress term."""
        self.problem.equations.variables.set_state(self._full(u), force=True)
        stress = 0.0
        for term in self._elastic:
            stress = stress + term.evaluate(mode="qp", term_mode="stress", standalone=False)[0][..., 0] / term.sign
        self._given.evaluate(mode="qp", term_mode="stress", standalone=False)
        return stress

    # -- solutions ----------------------------------------------------------------------------
    def static(self, load: np.ndarray, *, increments: int = 10,
               tolerance: float = 1e-10) -> np.ndarray:
        """(n_dofs,) displacement in (long-term) equilibrium with the dead ``load``, by
        Newton's method in ``increments`` equal load steps."""
        self._reset_state()
        load = np.asarray(load, float)[self.free]
        newton = _ModifiedNewton(self, None, tolerance)
        u = np.zeros(len(self.free))
        for k in range(1, increments + 1):
            u = newton.solve(u, load * k / increments, k, what="load step")
        return self._full(u)

    def _reset_state(self):
        self._set_scale(1.0)
        self._given.history_stress = None
        zero = np.zeros(self._gradient_shape())
        self._given.previous_gradient = zero + np.eye(3)
        self._given.rate_predictor = zero
        self._given.rate_coefficient = 0.0

    def _gradient_shape(self):
        n_cells = self.omega.cells.size
        n_qp = self._integral.get_qp("3_4")[0].shape[0]
        return (n_cells, n_qp, 3, 3)

    def dynamic(self, load, *, dt: float, n_frames: int, substeps: int = 4,
                tolerance: float = 1e-9) -> np.ndarray:
        """(n_frames, n_dofs) displacement from rest: average-acceleration Newmark with
        ``substeps`` steps per frame, modified Newton within each.

        ``load`` is (n_dofs,) (held from t = 0) or (n_frames, n_dofs), ``load[t]`` acting
        from frame t to t + 1 (as in our experiments).
        """
        return self.trajectory(load, dt=dt, n_frames=n_frames, substeps=substeps,
                               tolerance=tolerance).displacement

    def quasistatic(self, load, *, dt: float, n_frames: int, substeps: int = 4,
                    tolerance: float = 1e-9) -> np.ndarray:
        """As :meth:`dynamic` without inertia: equilibrium at every step, the Prony series'
        memory (and Kelvin–Voigt viscosity) the only time dependence. For creep and
        relaxation against their closed forms."""
        return self.trajectory(load, dt=dt, n_frames=n_frames, substeps=substeps,
                               tolerance=tolerance, inertia=False).displacement

    def trajectory(self, load, *, dt: float, n_frames: int, substeps: int = 4,
                   tolerance: float = 1e-9, inertia: bool = True) -> Trajectory:
        """:meth:`dynamic` (or :meth:`quasistatic`) with velocities and costs."""
        if not (dt > 0 and substeps >= 1 and n_frames >= 1):
            raise InputError(f"needs dt > 0, substeps ≥ 1, n_frames ≥ 1; got {dt}, "
                             f"{substeps}, {n_frames}", key="dt")
        started = time.perf_counter()
        loads = np.broadcast_to(np.asarray(load, float), (n_frames, self.n_dofs))[:, self.free]
        h = dt / substeps
        self._reset_state()
        given = self._given
        n_terms = 0
        if self.prony is not None:
            relative = np.asarray(self.prony.relative_moduli)[:, None, None, None]
            decay, ramp = (x[:, None, None, None] for x in self.prony.step_factors(h))
            n_terms = len(relative)
            self._set_scale(1.0 + float(np.sum(relative * ramp)))
        if self.viscosity > 0:
            given.rate_coefficient = 2.0 / h
        inertia_matrix = (4.0 / (h * h)) * self.mass if inertia else None
        newton = _ModifiedNewton(self, inertia_matrix, tolerance)

        n = len(self.free)
        u, v = np.zeros(n), np.zeros(n)
        a = spla.splu(self.mass).solve(loads[0]) if inertia else np.zeros(n)
        shape = self._gradient_shape()
        elastic_stress = np.zeros(shape[:2] + (6,))
        history = np.zeros((n_terms,) + shape[:2] + (6,))
        gradient, gradient_rate = np.zeros(shape) + np.eye(3), np.zeros(shape)
        out_u, out_v = np.zeros((n_frames, self.n_dofs)), np.zeros((n_frames, self.n_dofs))
        try:
            for t in range(1, n_frames):
                force = loads[t - 1]
                for _ in range(substeps):
                    if n_terms:
                        given.history_stress = np.sum(
                            relative * (decay * history - ramp * elastic_stress[None]), axis=0)
                    given.previous_gradient, given.rate_predictor = gradient, -gradient_rate
                    if inertia:   # the residual's inertia: M (4/h² (x - u - h v) - a)
                        inertial = inertia_matrix @ (u + h * v) + self.mass @ a
                        x = newton.solve(u + h * v + 0.25 * h * h * a, force + inertial, t)
                        a_new = 4.0 / (h * h) * (x - u - h * v) - a
                        u, v, a = x, v + 0.5 * h * (a + a_new), a_new
                    else:
                        x = newton.solve(u, force, t)
                        u, v = x, 2.0 / h * (x - u) - v
                    if n_terms or self.viscosity > 0:
                        new_stress = self._elastic_stress(u)
                        new_gradient = given.deformation_gradient
                        if n_terms:
                            history = decay * history + ramp * (new_stress - elastic_stress)
                            elastic_stress = new_stress
                        if self.viscosity > 0:
                            gradient_rate = given.gradient_rate(new_gradient)
                        gradient = new_gradient
                out_u[t, self.free] = u
                out_v[t, self.free] = v
        finally:
            self._reset_state()
        return Trajectory(out_u, out_v, newton.iterations, newton.factorisations,
                          time.perf_counter() - started)

    # -- what the solution says ---------------------------------------------------------------
    def at(self, displacement: np.ndarray, points) -> np.ndarray:
        """Displacement (…, n_points, 3) at ``points`` (n_points, 3) for displacements
        (…, n_dofs)."""
        points = np.asarray(points, float)
        flat = np.asarray(displacement, float).reshape(-1, self.n_dofs)
        values = flat.reshape(len(flat), -1, 3).transpose(1, 0, 2).reshape(-1, 3 * len(flat))
        with _quiet():
            sampled = self.field.evaluate_at(points, values, close_limit=1e-6)
        sampled = np.asarray(sampled).reshape(len(points), len(flat), 3).transpose(1, 0, 2)
        return sampled.reshape(*np.shape(displacement)[:-1], len(points), 3)

    def quadrature_points(self) -> np.ndarray:
        """(n_cells, n_qp, 3): where the stresses live (m)."""
        from sfepy.discrete.common.mappings import get_physical_qps

        qps = get_physical_qps(self.omega, self._integral)
        return qps.values.reshape(qps.shape)

    def _gradients(self, displacement) -> np.ndarray:
        self._reset_state()
        self._elastic_stress(np.asarray(displacement, float)[self.free])
        return self._given.deformation_gradient

    def principal_stretches(self, displacement) -> np.ndarray:
        """(n_cells, n_qp, 3) principal stretches, ascending, at the quadrature points."""
        gradient = self._gradients(displacement)
        cauchy_green = np.einsum("...ki,...kj->...ij", gradient, gradient)
        return np.sqrt(np.linalg.eigvalsh(cauchy_green))

    def strain_energy(self, displacement) -> float:
        """∫ Ψ dV (J) of the elastic law, from the principal stretches at the quadrature
        points and the material's own energy (:mod:`.materials`, not sfepy's)."""
        stretches = self.principal_stretches(displacement)
        mapping, _ = self.field.get_mapping(self.omega, self._integral, "cell")
        return float(np.sum(self.material.energy(stretches) * mapping.det[..., 0, 0]))

    def kinetic_energy(self, velocity) -> float:
        """½ vᵀ M v (J) for velocities (n_dofs,)."""
        v = np.asarray(velocity, float)[self.free]
        return float(0.5 * v @ (self.mass @ v))


class _Inverted(Exception):
    """sfepy met an element with negative volume."""


class _ModifiedNewton:
    """Newton's method for ``f_int(x) + A x = b`` (A: the step's inertia matrix or None)
    with old LU factors of its matrix, accelerated (Anderson mixing of the last ``memory``
    corrections, a multisecant quasi-Newton update: Walker & Ni 2011, *SIAM J. Numer.
    Anal.* 49:1715), refactorised when the iterations stop contracting fast (a factorisation
    costs as much as some forty residuals on the recordings' mesh). A step that would turn
    an element inside out is halved."""

    def __init__(self, solver: HyperelasticSolver, inertia_matrix, tolerance: float,
                 slow: float = 0.5, most: int = 15, memory: int = 6):
        self.solver, self.inertia_matrix, self.tolerance = solver, inertia_matrix, tolerance
        self.slow, self.most, self.memory = slow, most, memory
        self.lu, self.stale = None, True
        self.iterations = self.factorisations = 0

    def _residual(self, x, rhs):
        residual = self.solver._internal(x) - rhs
        if self.inertia_matrix is not None:
            residual = residual + self.inertia_matrix @ x
        return residual

    def _factorise(self, x):
        matrix = self.solver._tangent(x)
        if self.inertia_matrix is not None:
            matrix = matrix + self.inertia_matrix
        self.lu = spla.splu(matrix.tocsc())
        self.factorisations += 1
        self.stale = False

    def solve(self, x, rhs, frame: int, what: str = "frame"):
        count, previous = 0, None
        xs, fs = [], []                                  # iterates and their corrections
        try:
            residual = self._residual(x, rhs)
            while True:
                if self.lu is None or self.stale:
                    self._factorise(x)
                    previous, xs, fs = None, [], []
                correction = -self.lu.solve(residual)
                size = np.abs(correction).max()
                if size <= self.tolerance * max(np.abs(x).max(), 1e-12):
                    x = x + correction
                    break
                step = correction
                if fs:                                   # Anderson mixing
                    d_f = np.stack([correction - f for f in fs], axis=1)
                    d_x = np.stack([x - xi for xi in xs], axis=1)
                    gamma = np.linalg.lstsq(d_f, correction, rcond=None)[0]
                    step = correction - (d_x + d_f) @ gamma
                xs, fs = (xs + [x])[-self.memory:], (fs + [correction])[-self.memory:]
                for _ in range(30):                      # back off inverted elements
                    try:
                        residual = self._residual(x + step, rhs)
                        break
                    except _Inverted:
                        step = 0.5 * step
                        xs, fs = [], []
                else:
                    raise _Inverted()
                x = x + step
                count += 1
                if previous is not None and (size > self.slow * previous or count >= self.most):
                    self.stale = True                    # too slow: fresh factors
                previous = size
                if count > 100:
                    raise InputError(f"Newton's method did not converge at {what} {frame}; "
                                     "take smaller steps", key="substeps")
        except _Inverted:
            raise InputError(f"an element turned inside out at {what} {frame}; lower the "
                             "load or refine the mesh", key="load") from None
        self.iterations += count + 1
        return x


def _variables(field) -> dict:
    from sfepy.discrete import FieldVariable

    u = FieldVariable("u", "unknown", field)
    return {"u": u, "v": FieldVariable("v", "test", field, primary_var_name="u")}


def _lame_lambda(material) -> float:
    e, nu = material.youngs_modulus, material.poisson_ratio
    return e * nu / ((1 + nu) * (1 - 2 * nu))

