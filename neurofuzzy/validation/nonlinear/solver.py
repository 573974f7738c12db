"""Large-strain elastodynamics of a tetrahedral mesh by sfepy, for data nobody here wrote.

:class:`HyperelasticSolver` is the nonlinear sibling of
:class:`~neurofuzzy.validation.continuum.ContinuumSolver` (same arguments, loads and
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
strain. The time stepping (Newmark, Newton, the Prony update) is written in this package
(:mod:`._stepping`, :mod:`._newton`), as in
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
node forces are), or gravity. Needs sfepy (``pip install
'neurofuzzy[validation-nonlinear]'``; pip builds it from its source).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...errors import InputError
from ._newton import Inverted, ModifiedNewton
from ._sfepy_setup import field_variables, quiet, require_sfepy
from ._stepping import Trajectory, newmark
from .materials import NeoHookean, Prony, Yeoh, lame_from_youngs

__all__ = ["HyperelasticSolver", "Trajectory"]


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
        require_sfepy()
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

        with quiet():
            mesh = Mesh.from_data("block", points, None, [tetrahedra.astype(np.int32)],
                                  [np.zeros(len(tetrahedra), np.int32)], ["3_4"])
            self.domain = FEDomain("domain", mesh)
            self.omega = self.domain.create_region("Omega", "all")
            self.surface = self.domain.create_region("Surface", "vertices of surface",
                                                     "facet")
            self.field = Field.from_args("displacement", np.float64, "vector", self.omega,
                                         approx_order=order)
            variables = field_variables(self.field)
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
                mu, lam = lame_from_youngs(material.youngs_modulus, material.poisson_ratio)
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
                                 m=self._material, **field_variables(self.field))
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
        with quiet():
            unit = self.problem.evaluate("dw_surface_ltr.10.Surface(load.val, v)",
                                         mode="weak", dw_mode="vector", copy_materials=False,
                                         active_only=False, load=material,
                                         v=field_variables(self.field)["v"])
        unit = np.asarray(unit).reshape(-1, 3)[:, 2]
        area = float(unit.sum())
        if area <= 0:
            raise InputError("the load's patch contains no boundary", key="where")
        return (unit[:, None] * force[None, :] / area).ravel()

    def gravity_load(self, gravity) -> np.ndarray:
        """(n_dofs,): the weight ``ρ g`` of the object (``gravity`` in m/s²)."""
        from sfepy.discrete import Material

        weight = Material("weight", val=(self.density * np.asarray(gravity, float))[:, None])
        with quiet():
            out = self.problem.evaluate("dw_volume_lvf.stiffness.Omega(weight.val, v)",
                                        mode="weak", dw_mode="vector", copy_materials=False,
                                        active_only=False, weight=weight,
                                        v=field_variables(self.field)["v"])
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
                raise Inverted() from None
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
                raise Inverted() from None
            raise

    def _set_scale(self, scale: float):
        for term in self._elastic:
            term.sign = scale

    def _elastic_stress(self, u) -> np.ndarray:
        """(n_cells, n_qp, 6): the elastic second Piola–Kirchhoff stress (Pa, unscaled) and,
        as a side effect, F in the given-stress term."""
        self.problem.equations.variables.set_state(self._full(u), force=True)
        stress = 0.0
        for term in self._elastic:   # (n_cells, n_qp, 6, 1) each
            stress = stress + term.evaluate(mode="qp", term_mode="stress",
                                            standalone=False)[..., 0] / term.sign
        self._given.evaluate(mode="qp", term_mode="stress", standalone=False)
        return stress

    # -- solutions ----------------------------------------------------------------------------
    def static(self, load: np.ndarray, *, increments: int = 10,
               tolerance: float = 1e-10) -> np.ndarray:
        """(n_dofs,) displacement in (long-term) equilibrium with the dead ``load``, by
        Newton's method in ``increments`` equal load steps."""
        self._reset_state()
        load = np.asarray(load, float)[self.free]
        newton = ModifiedNewton(self, None, tolerance)
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
        return newmark(self, load, dt=dt, n_frames=n_frames, substeps=substeps,
                       tolerance=tolerance, inertia=inertia)

    # -- what the solution says ---------------------------------------------------------------
    def at(self, displacement: np.ndarray, points) -> np.ndarray:
        """Displacement (…, n_points, 3) at ``points`` (n_points, 3) for displacements
        (…, n_dofs)."""
        points = np.asarray(points, float)
        flat = np.asarray(displacement, float).reshape(-1, self.n_dofs)
        values = flat.reshape(len(flat), -1, 3).transpose(1, 0, 2).reshape(-1, 3 * len(flat))
        with quiet():
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
