"""Linear tetrahedral finite elements: St. Venant–Kirchhoff (or neo-Hookean) elasticity with
Kelvin–Voigt viscosity, parameterised by the material's own Young's modulus ``E`` (Pa),
Poisson's ratio ``ν`` and viscosity ``η`` (Pa·s) per element, and each element's law
(``law``, :mod:`neurofuzzy.forces.laws`; written below for St. Venant–Kirchhoff,
whose ``D(G) = G``, ``N = I``, ``θ = tr G``: another law puts its ``2μ D(G) + π N(G)`` in place
of ``2μ G + π I`` and its ``θ(G)`` in place of ``tr G``; the viscous part is the same).

Element ``e`` with nodes ``n0..n3``, rest edge matrix ``Dm = [X1-X0, X2-X0, X3-X0]``,
``B = Dm⁻¹``, volume ``V = |det Dm| / 6``; at the state ``(x, v)``::

    F = Ds B,  Ḟ = Ḋs B                       (Ds = [x1-x0, x2-x0, x3-x0], Ḋs from v)
    G = ½ (FᵀF - I),  Ġ = sym(Fᵀ Ḟ)           Green strain and its rate
    θ = tr G,  θ̇ = tr Ġ                        volumetric strain and its rate
    S = 2μ (G + β Ġ) + π I,  β = η / E        second Piola–Kirchhoff stress
    P = F S,   [f1 f2 f3] = -V P Bᵀ,   f0 = -(f1 + f2 + f3)

with the Lamé constants ``λ = E a``, ``μ = E b`` (``a = ν/((1+ν)(1-2ν))``,
``b = 1/(2(1+ν))``). The viscous stress is the elastic one of the strain rate times ``β``
(a Rayleigh stiffness-proportional damping).

The volumetric part ``π`` (the stress of the Lamé ``λ``) comes in two forms
(``volumetric``):

- ``"element"``: ``π_e = λ_e (θ_e + β_e θ̇_e)``, the textbook linear tetrahedron (its
  stiffness at rest is scikit-fem's linear-elasticity matrix to round-off). Nearly
  incompressible tissue (ν → 0.5, ``λ ≫ μ``) *locks* on it: one volume constraint per
  element is more than a tetrahedral mesh has degrees of freedom for, and the mesh is far too
  stiff (on the 4 × 4 × 3 cm block at ν = 0.45 a fit trades the locking for a Poisson's ratio
  of 0.39).
- ``"nodal"`` (the default): the volumetric strain is averaged over the tetrahedra around
  every node first (weights ``V_e / 4``), ``θ̄_a = Σ_e (V_e/4) θ_e / V_a``, and the element
  takes the mean of its corners, ``π_e = ¼ Σ_{a∈e} (Λ_a θ̄_a + H_a θ̄̇_a)`` with ``Λ_a``,
  ``H_a`` the same averages of ``λ_e`` and ``λ_e β_e``. This is the elastic energy
  ``Σ_e V_e μ_e G:G + Σ_a ½ V_a Λ_a θ̄_a²``: one volume constraint per node, so no locking
  (the average-nodal-pressure tetrahedron of Bonet & Burton, 1998, applied to the ``λ`` part
  only, so the ``μ`` part keeps every element positive definite and there are no spurious
  zero-energy modes). Homogeneous strains are reproduced exactly (patch test), so it
  converges to the same continuum; it does so faster (tests and the README measure both
  against scikit-fem's quadratic tetrahedra).

Why St. Venant–Kirchhoff and not corotational linear elasticity: both reduce to linear
elasticity at small strain and both are exact under rigid rotation, but SVK's force is a
polynomial in the node positions, so its exact forward and reverse derivatives (which both
learners need) are a few batched 3×3 products, where the corotational element needs the
derivative of a polar decomposition. SVK softens under strong compression (beyond ~30 %),
far past the strains of palpation and probing; where a probe compresses tissue by more, the
neo-Hookean law (the same E, ν and η at small strain) does not soften.

The stress ``S`` itself (each element's law, the Kelvin–Voigt stress and the volumetric
stresses ``π``, ``π̇``) and its derivatives are not written here: they come from the compiled
:func:`neurofuzzy.kernels.laws.stress`, the one the kernels step with, over arrays
(:class:`~neurofuzzy.forces.laws.ElementStress`). :mod:`neurofuzzy.forces.element_forces` forms ``F``, ``G``, the
volumetric strains and their node averages, and the forces from ``S``, vectorised over
elements (batched (n_elements, 3, 3) products, sparse matrices for the node averages); this
module holds the term: the elements' values, checked, and the force's derivatives by them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, closest_name
from .base import MemberTerm, region_index, vector
from .element_forces import (columns, element_force, element_rest_matrices, element_state,
                             element_state_jvp, element_state_vjp)
from .laws import LAWS, law_numbers, stiffening_array, stiffening_slope, stiffens
from .relaxation import relaxation_arrays
from .tetra_geometry import (ElementConstants, TetrahedronGeometry, corner_forces,
                             lame_factors, tetrahedron_geometry)

__all__ = ["Tetrahedra", "VOLUMETRIC", "TetrahedronGeometry", "tetrahedron_geometry",
           "lame_factors", "ElementConstants"]

#: The elements' parameters, in the order of every per-element parameter dictionary.
PARAMETERS = ("youngs_modulus", "poisson_ratio", "viscosity")
#: How tetrahedral elements form their volumetric stress (module docstring).
VOLUMETRIC: tuple[str, ...] = ("nodal", "element")


@dataclass(frozen=True, eq=False)
class Tetrahedra(MemberTerm):
    """The tetrahedral finite elements of a model (``model.elements``; the elements are
    ``model.mesh.tetrahedra``): per element its Young's modulus, Poisson's ratio, viscosity,
    material law and the law's constants, tie group and region.

    Give values as numbers (every element) or (n_tetrahedra,) arrays; the model checks them
    against its mesh (:meth:`bound`) and keeps read-only arrays.

    Parameters
    ----------
    youngs_modulus, poisson_ratio, viscosity : float or (n_tetrahedra,) float
        E (Pa, > 0), ν in (0, 0.5) and η (Pa·s, ≥ 0) of every element.
    tie : (n_tetrahedra,) int, optional
        Tie group of every element (default: one group per region); tied elements are
        learned as one E, ν and η (E and η keep their start ratios).
    region : (n_tetrahedra,) int, optional
        The model region of every element (default 0).
    volumetric : {"nodal", "element"}
        How the volumetric stress is formed (module docstring): averaged over the
        tetrahedra around every node (the default; free of volumetric locking for nearly
        incompressible tissue) or per element (the textbook linear tetrahedron).
    law : str, int or (n_tetrahedra,) of them, optional
        Every element's material law (:mod:`neurofuzzy.forces.laws`):
        ``"st-venant-kirchhoff"`` (the default), ``"neo-hookean"`` or ``"yeoh"``; stored as
        law numbers.
    stiffening : float or (n_tetrahedra,) float, optional
        Yeoh's ``C₂₀/C₁₀`` (dimensionless, ≥ 0) of every element with the ``"yeoh"`` law
        (default :data:`~neurofuzzy.forces.laws.DEFAULT_STIFFENING`); the other laws leave
        theirs unused (an element switched to Yeoh's law later starts from it).
    relaxation_moduli, relaxation_times : (K,) or (n_tetrahedra, K) float, optional
        Prony-series relaxation (:mod:`neurofuzzy.forces.relaxation`, 1–3 terms): relative
        moduli ``gᵢ ≥ 0`` (of the long-term modulus E) and times ``τᵢ > 0`` (s), for all
        elements or per element; both or neither. Stored as (n_tetrahedra, K), K = 0 without
        relaxation.
    """

    youngs_modulus: np.ndarray
    poisson_ratio: np.ndarray
    viscosity: np.ndarray
    tie: np.ndarray | None = None
    region: np.ndarray | None = None
    volumetric: str = "nodal"
    law: np.ndarray | None = None
    stiffening: np.ndarray | None = None
    relaxation_moduli: np.ndarray | None = None
    relaxation_times: np.ndarray | None = None

    name = "tetrahedra"
    parameters = {"youngs_modulus": "Pa", "poisson_ratio": "1", "viscosity": "Pa s"}

    def bound(self, model) -> Tetrahedra:
        """This term checked against ``model``'s mesh and regions, as read-only arrays with
        the defaults filled in.

        Raises
        ------
        InputError
            A value missing, of the wrong shape or impossible; the message names the first
            bad element, its region and tissue, the key the model field
            (``element_youngs_modulus`` …).
        """
        if self._bound_to(model):
            return self
        n = model.mesh.n_tetrahedra
        if n == 0:
            raise InputError("element parameters need a mesh with tetrahedra",
                             key="element_youngs_modulus")
        missing = [name for name in PARAMETERS if getattr(self, name) is None]
        if missing:
            raise InputError(f"elements need all three of {', '.join(PARAMETERS)}; "
                             f"{missing[0]} is missing", key=f"element_{missing[0]}")
        out = {name: vector(getattr(self, name), n, f"element_{name}", "n_tetrahedra")
               for name in PARAMETERS}
        out["region"] = region_index(self.region, n, len(model.region_names),
                                     "element_region", "n_tetrahedra")
        tie = out["region"] if self.tie is None else np.asarray(self.tie)
        if tie.shape != (n,) or not np.issubdtype(tie.dtype, np.integer):
            raise InputError(f"expected ({n},) integers, one tie group per element",
                             key="element_tie")
        out["tie"] = np.unique(tie, return_inverse=True)[1].astype(np.intp)
        out["law"] = law_numbers(self.law, n)
        out["stiffening"] = stiffening_array(self.stiffening, n)
        out["relaxation_moduli"], out["relaxation_times"] = relaxation_arrays(
            self.relaxation_moduli, self.relaxation_times, n)
        if self.volumetric not in VOLUMETRIC:
            hint = closest_name(str(self.volumetric), VOLUMETRIC)
            raise InputError(f"got {self.volumetric!r}; expected one of {list(VOLUMETRIC)}"
                             + (f" (did you mean {hint!r}?)" if hint else ""),
                             key="element_volumetric")
        nu = out["poisson_ratio"]
        for name, bad, rule in (
                ("youngs_modulus", out["youngs_modulus"] <= 0,
                 "Young's modulus {:g} Pa; it must be positive (Pa)"),
                ("poisson_ratio", (nu <= 0) | (nu >= 0.5),
                 "Poisson's ratio {:g}; it must lie in (0, 0.5), strictly: 0.5 is a "
                 "perfectly incompressible solid, which elements cannot represent"),
                ("viscosity", out["viscosity"] < 0,
                 "viscosity {:g} Pa s; it must not be negative (Pa s)")):
            if np.any(bad):
                first = int(np.flatnonzero(bad)[0])
                more = f" ({int(bad.sum())} elements in all)" if bad.sum() > 1 else ""
                raise InputError(f"element {first}{_where(model, out['region'][first])} has "
                                 + rule.format(out[name][first]) + more,
                                 key=f"element_{name}")
        for value in out.values():
            value = np.asarray(value)
            if value.flags.writeable:
                value.setflags(write=False)
        return replace(self, **out)._checked(model)

    def blocks(self, model, *, index: int = 0):
        """E, ν, η, the Prony terms and Yeoh's constant of every tie group
        (:class:`~neurofuzzy.forces.blocks.ElementBlocks`)."""
        from .blocks import ElementBlocks

        return ElementBlocks(self)

    # -- what the values say ------------------------------------------------------------------
    @property
    def n_relaxation_terms(self) -> int:
        """How many Prony terms the elements carry (0: no relaxation)."""
        return self.relaxation_moduli.shape[1]

    @property
    def stiffens(self) -> np.ndarray:
        """(n_tetrahedra,) bool: the elements whose law has its own stiffening constant
        (:data:`~neurofuzzy.forces.laws.STIFFENING_CONSTANT`; Yeoh's C₂₀/C₁₀)."""
        return stiffens(self.law)

    def law_names(self) -> str:
        """The material laws in words: one name, or each with its element count."""
        numbers, counts = np.unique(self.law, return_counts=True)
        if len(numbers) == 1:
            return LAWS[int(numbers[0])]
        return ", ".join(f"{LAWS[int(n)]} ({int(c)} elements)" for n, c in zip(numbers, counts))

    def constants(self, model) -> ElementConstants:
        """The elements' constants on ``model``'s mesh (numpy path)."""
        return ElementConstants.of(self, model.mesh)

    def _stateless(self, model) -> ElementConstants:
        """The constants for the numpy path, which has no internal variables: elements with
        Prony relaxation (:mod:`neurofuzzy.forces.relaxation`) run in the compiled kernels
        only, and say so here rather than be simulated without it."""
        if self.n_relaxation_terms:
            raise InputError("this model's elements relax (Prony terms), which only the "
                             "compiled kernels simulate; the numpy forces (the paper's "
                             "learner, the tests' reference) have no internal variables",
                             key="element_relaxation_moduli")
        return self.constants(model)

    # -- force and state derivatives ------------------------------------------------------------
    def force(self, model, positions, velocities):
        return element_force(self._stateless(model), positions, velocities)

    def state_jvp(self, model, positions, velocities, dp, dv):
        return element_state_jvp(self._stateless(model), positions, velocities, dp, dv)

    def state_vjp(self, model, positions, velocities, cotangent):
        return element_state_vjp(self._stateless(model), positions, velocities, cotangent)

    # -- parameters ---------------------------------------------------------------------------
    def _unit_forces(self, model, positions, velocities):
        """Per-corner forces (K, 4, 3) per unit change of each element's shear part
        (``2μ`` by ``E``, ``ν``, ``η``) and of its ``π``, with the constants and state."""
        constants = self._stateless(model)
        geometry = constants.geometry
        state = element_state(constants, positions, velocities)
        E, nu, eta = self.youngs_modulus, self.poisson_ratio, self.viscosity
        _, b, _, db = lame_factors(nu)
        by = state.at.partials()                # ∂S by 2μ, 2μβ, π, π̇ (S is linear in each)
        stresses = {"youngs_modulus": 2 * b[:, None, None] * by["shear"],
                    "viscosity": 2 * b[:, None, None] * by["shear_rate"],
                    "poisson_ratio": 2 * db[:, None, None] * (
                        E[:, None, None] * by["shear"] + eta[:, None, None] * by["shear_rate"]),
                    "pressure": by["pressure"], "pressure_rate": by["pressure_rate"]}
        local = {name: corner_forces(columns(geometry, state.F @ stress))
                 for name, stress in stresses.items()}
        return constants, state, local

    def lame_changes(self, model, directions):
        """``(dλ, d(λβ))`` (K, P) sparse for per-element parameter changes ``directions``."""
        E, nu, eta = self.youngs_modulus, self.poisson_ratio, self.viscosity
        a, _, da, _ = lame_factors(nu)
        d_lam = (sp.diags(a) @ directions["youngs_modulus"]
                 + sp.diags(E * da) @ directions["poisson_ratio"])
        d_lam_rate = (sp.diags(a) @ directions["viscosity"]
                      + sp.diags(eta * da) @ directions["poisson_ratio"])
        return sp.csr_matrix(d_lam), sp.csr_matrix(d_lam_rate)

    def parameter_jvp(self, model, positions, velocities, directions) -> np.ndarray:
        """(n_nodes, P, 3): the force's change along P directions in parameter space.

        Parameters
        ----------
        directions : dict of (n_elements, P) sparse or dense
            Per-element changes of ``youngs_modulus``, ``poisson_ratio`` and ``viscosity``
            (the same P columns in each; e.g. ``∂E_e/∂θ_p`` of a parameterisation). With the
            nodal volumetric form an element's λ also moves its neighbours' forces.
        """
        directions = {name: sp.csr_matrix(directions[name]) for name in PARAMETERS}
        constants, state, local = self._unit_forces(model, positions, velocities)
        geometry = constants.geometry
        n_nodes = model.n_nodes
        total = None
        for name in PARAMETERS:
            part = geometry.corner_matrix(local[name], n_nodes) @ directions[name]
            total = part if total is None else total + part
        d_lam, d_lam_rate = self.lame_changes(model, directions)
        none = np.zeros_like(state.theta)
        d_pressure = constants.pressure_of_constants(d_lam, 0 * d_lam_rate, state.theta, none)
        d_pressure_rate = constants.pressure_of_constants(0 * d_lam, d_lam_rate, none,
                                                          state.theta_rate)
        total = (total + geometry.corner_matrix(local["pressure"], n_nodes) @ d_pressure
                 + geometry.corner_matrix(local["pressure_rate"], n_nodes) @ d_pressure_rate)
        dense = total.toarray() if sp.issparse(total) else np.asarray(total)
        return dense.reshape(n_nodes, 3, -1).transpose(0, 2, 1)

    def parameter_vjp(self, model, positions, velocities, cotangent) -> dict[str, np.ndarray]:
        """Per-element gradients (n_elements,) of ``Σ cotangent · force`` with respect to
        every element's ``youngs_modulus``, ``poisson_ratio`` and ``viscosity`` (the adjoint
        of :meth:`parameter_jvp`)."""
        constants, state, local = self._unit_forces(model, positions, velocities)
        corners = cotangent[constants.geometry.nodes]                       # (K, 4, 3)
        out = {name: np.einsum("ejk,ejk->e", corners, values)
               for name, values in local.items()}
        g_lam = constants.constants_transpose(out.pop("pressure"), state.theta,
                                              state.theta_rate)[0]
        g_lam_rate = constants.constants_transpose(out.pop("pressure_rate"), state.theta,
                                                   state.theta_rate)[1]
        E, nu, eta = self.youngs_modulus, self.poisson_ratio, self.viscosity
        a, _, da, _ = lame_factors(nu)
        out["youngs_modulus"] = out["youngs_modulus"] + a * g_lam
        out["poisson_ratio"] = out["poisson_ratio"] + da * (E * g_lam + eta * g_lam_rate)
        out["viscosity"] = out["viscosity"] + a * g_lam_rate
        return out

    def stiffening_forces(self, model, positions, velocities, shear) -> np.ndarray:
        """Per-corner forces (K, 4, 3) per unit change of every Yeoh element's ``log c``
        (its stiffening constant, :mod:`neurofuzzy.forces.laws`), for the elements' total
        shear constants ``shear`` (K,) (their own and any inclusion's): the stress is
        ``shear D(G; c)``, so ``∂S/∂ log c = c shear ∂D/∂c`` (the compiled law's exact
        derivative, :func:`~neurofuzzy.forces.laws.stiffening_slope`); 0 on the other laws'
        elements."""
        constants = self._stateless(model)
        geometry = constants.geometry
        F = geometry.edges(positions) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        slope = stiffening_slope(constants.law, green, constants.stiffening)
        stress = (constants.stiffening * shear)[:, None, None] * slope
        return corner_forces(columns(geometry, F @ stress))

    def parameter_values(self, model):
        """``{"youngs_modulus", "poisson_ratio", "viscosity"}``, each (n_elements,)."""
        return {name: getattr(self, name) for name in PARAMETERS}

    def with_parameter_values(self, model, values):
        model = model.with_term(self.replace(**{name: values[name] for name in PARAMETERS}))
        return model, model.elements

    @classmethod
    def examples(cls, model):
        """The model's own elements (element models)."""
        return [] if model.elements is None else [(model, model.elements)]

    # -- the stability bound ------------------------------------------------------------------
    def rest_matrices(self, model):
        """``(K, C)``: ``-∂f/∂x`` and ``-∂f/∂v`` at rest, assembled (3N, 3N)
        (:func:`~neurofuzzy.forces.element_forces.element_rest_matrices`). Elements that
        relax (Prony terms) are ``1 + Σ gᵢ`` times stiffer at once than their long-term E,
        and so in the bound."""
        elements = self
        if self.n_relaxation_terms:
            elements = self.replace(youngs_modulus=self.youngs_modulus * (
                1.0 + self.relaxation_moduli.sum(axis=1)))
        return element_rest_matrices(ElementConstants.of(elements, model.mesh))


def _where(model, region: int) -> str:
    """" (region 'tumour', tissue 'tumour')" for messages; "" for a one-region model."""
    names = tuple(str(name) for name in model.region_names)
    tissues = tuple(model.region_tissues or (None,) * len(names))
    if len(names) == 1 and tissues[0] is None:
        return ""
    tissue = tissues[region] if region < len(tissues) else None
    return f" (region {names[region]!r}" + (f", tissue {tissue!r})" if tissue else ")")
