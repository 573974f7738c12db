"""Linear tetrahedral finite elements: St. Venant–Kirchhoff (or neo-Hookean) elasticity with
Kelvin–Voigt viscosity, parameterised by the material's own Young's modulus ``E`` (Pa),
Poisson's ratio ``ν`` and viscosity ``η`` (Pa·s) per element, and each element's law
(``model.element_law``, :mod:`neurofuzzy.forces.laws`; written below for St. Venant–Kirchhoff,
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
(``model.element_volumetric``):

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
(:class:`~neurofuzzy.forces.laws.ElementStress`). This module forms ``F``, ``G``, the
volumetric strains and their node averages, and the forces from ``S``, vectorised over
elements (batched (n_elements, 3, 3) products, sparse matrices for the node averages).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .base import ForceTerm
from .laws import ElementStress, stiffening_slope
from .tetra_geometry import (ElementConstants, TetrahedronGeometry, broadcast_per_element,
                             corner_forces, lame_factors, tetrahedron_geometry)

__all__ = ["TetrahedronForce", "TETRAHEDRA", "TetrahedronGeometry", "tetrahedron_geometry",
           "lame_factors", "ElementConstants"]

#: The elements' parameters, in the order of every per-element parameter dictionary.
PARAMETERS = ("youngs_modulus", "poisson_ratio", "viscosity")


def _stateless(model) -> ElementConstants:
    """The constants of ``model``'s elements for the numpy path, which has no internal
    variables: a model with Prony relaxation (:mod:`neurofuzzy.forces.relaxation`) runs in
    the compiled kernels only, and says so here rather than be simulated without it."""
    if model.n_relaxation_terms:
        raise InputError("this model's elements relax (Prony terms), which only the compiled "
                         "kernels simulate; the numpy path was asked for (an effect the kernels "
                         "do not compute, or backend='numpy')",
                         key="element_relaxation_moduli")
    return ElementConstants.of(model)


def _sym(matrix):
    return 0.5 * (matrix + np.swapaxes(matrix, -1, -2))


def _trace_product(x, y):
    """``tr(xᵀ y)`` over the last two axes."""
    return np.einsum("...ij,...ij->...", x, y)


@dataclass(frozen=True)
class _State:
    F: np.ndarray
    F_rate: np.ndarray
    green: np.ndarray
    green_rate: np.ndarray
    theta: np.ndarray
    theta_rate: np.ndarray
    at: ElementStress            # S's arguments (π, π̇ included) and its derivatives
    stress: np.ndarray           # S


class TetrahedronForce(ForceTerm):
    """The tetrahedral elements of a model (stateless, like the springs: the parameters are
    the model's ``element_youngs_modulus``, ``element_poisson_ratio`` and
    ``element_viscosity``, the elements ``model.mesh.tetrahedra``, the volumetric form
    ``model.element_volumetric``, the law of every element ``model.element_law``).
    :data:`TETRAHEDRA` is the one instance."""

    name = "tetrahedra"
    parameters = {"youngs_modulus": "Pa", "poisson_ratio": "1", "viscosity": "Pa s"}

    def _state(self, constants: ElementConstants, positions, velocities) -> _State:
        geometry = constants.geometry
        F = geometry.edges(positions) @ geometry.inverse_rest
        F_rate = geometry.edges(velocities) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        green_rate = _sym(np.swapaxes(F, 1, 2) @ F_rate)
        theta, N = ElementStress.strains(constants.law, green)
        theta_rate = np.trace(green_rate, axis1=1, axis2=2)
        pressure, pressure_rate = constants.pressures(theta, theta_rate)
        at = ElementStress.at(constants.law, green, green_rate, constants.shear,
                              constants.shear_rate, pressure, pressure_rate,
                              constants.stiffening, (theta, N))
        return _State(F, F_rate, green, green_rate, theta, theta_rate, at, at.stress())

    @staticmethod
    def _columns(geometry, first_piola: np.ndarray) -> np.ndarray:
        """``-V P Bᵀ`` for per-element ``P`` ((K, 3, 3) or (K, P, 3, 3))."""
        inverse_transpose = np.swapaxes(geometry.inverse_rest, 1, 2)
        if first_piola.ndim == 4:
            inverse_transpose = inverse_transpose[:, None]
        return (-broadcast_per_element(geometry.volume, first_piola)
                * (first_piola @ inverse_transpose))

    def force(self, model, positions, velocities):
        return self.force_of(_stateless(model), positions, velocities)

    def state_jvp(self, model, positions, velocities, dp, dv):
        return self.state_jvp_of(_stateless(model), positions, velocities, dp, dv)

    def state_vjp(self, model, positions, velocities, cotangent):
        return self.state_vjp_of(_stateless(model), positions, velocities, cotangent)

    # the same for any per-element constants (an inclusion's extra stiffness on part of a model)
    def force_of(self, constants: ElementConstants, positions, velocities):
        """(n_nodes, 3) force of elements with the given :class:`ElementConstants`."""
        state = self._state(constants, positions, velocities)
        return constants.geometry.scatter(
            self._columns(constants.geometry, state.F @ state.stress), len(positions))

    def state_jvp_of(self, constants: ElementConstants, positions, velocities, dp, dv):
        """:meth:`state_jvp` of elements with the given :class:`ElementConstants`."""
        geometry = constants.geometry
        state = self._state(constants, positions, velocities)
        B = geometry.inverse_rest[:, None]
        dF = geometry.edges(dp) @ B                                  # (K, P, 3, 3)
        dF_rate = geometry.edges(dv) @ B
        F, F_rate = state.F[:, None], state.F_rate[:, None]
        d_green = _sym(np.swapaxes(F, -1, -2) @ dF)
        d_green_rate = _sym(np.swapaxes(dF, -1, -2) @ F_rate + np.swapaxes(F, -1, -2) @ dF_rate)
        d_theta = _trace_product(state.at.N[:, None], d_green)       # (K, P)
        d_theta_rate = np.trace(d_green_rate, axis1=-2, axis2=-1)
        d_pressure, d_pressure_rate = constants.pressures(d_theta, d_theta_rate)
        d_stress = state.at.jvp(d_green, d_green_rate, d_pressure, d_pressure_rate)
        d_piola = dF @ state.stress[:, None] + F @ d_stress
        return geometry.scatter(self._columns(geometry, d_piola), len(positions))

    def state_vjp_of(self, constants: ElementConstants, positions, velocities, cotangent):
        """:meth:`state_vjp` of elements with the given :class:`ElementConstants`."""
        geometry = constants.geometry
        state = self._state(constants, positions, velocities)
        B = geometry.inverse_rest
        # cotangent of [f1 f2 f3] (columns): λ_{n_j} - λ_{n_0}
        lam_piola = -geometry.volume[:, None, None] * (geometry.edges(cotangent) @ B)
        lam_stress = _sym(np.swapaxes(state.F, 1, 2) @ lam_piola)
        lam_green, lam_green_rate, lam_pressure, lam_pressure_rate = state.at.vjp(lam_stress)
        # π and π̇ through the volumetric strains θ(G) and θ̇ = tr Ġ
        lam_theta = constants.pressure_transpose(lam_pressure)[0]
        lam_theta_rate = constants.pressure_transpose(lam_pressure_rate)[1]
        lam_green = lam_green + lam_theta[:, None, None] * state.at.N
        lam_green_rate = lam_green_rate + lam_theta_rate[:, None, None] * np.eye(3)
        F, F_rate = state.F, state.F_rate
        lam_F = lam_piola @ state.stress + F @ lam_green + F_rate @ lam_green_rate
        lam_F_rate = F @ lam_green_rate
        # the adjoint of ``edges`` is ``scatter``: column j to node j+1, minus the sum to node 0
        n_nodes = len(positions)
        return (geometry.scatter(lam_F @ np.swapaxes(B, 1, 2), n_nodes),
                geometry.scatter(lam_F_rate @ np.swapaxes(B, 1, 2), n_nodes))

    # -- parameters ---------------------------------------------------------------------------
    def _unit_forces(self, model, positions, velocities):
        """Per-corner forces (K, 4, 3) per unit change of each element's shear part
        (``2μ`` by ``E``, ``ν``, ``η``) and of its ``π``, with the constants and state."""
        constants = _stateless(model)
        geometry = constants.geometry
        state = self._state(constants, positions, velocities)
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
        _, b, _, db = lame_factors(nu)
        by = state.at.partials()                # ∂S by 2μ, 2μβ, π, π̇ (S is linear in each)
        stresses = {"youngs_modulus": 2 * b[:, None, None] * by["shear"],
                    "viscosity": 2 * b[:, None, None] * by["shear_rate"],
                    "poisson_ratio": 2 * db[:, None, None] * (
                        E[:, None, None] * by["shear"] + eta[:, None, None] * by["shear_rate"]),
                    "pressure": by["pressure"], "pressure_rate": by["pressure_rate"]}
        local = {name: corner_forces(self._columns(geometry, state.F @ stress))
                 for name, stress in stresses.items()}
        return constants, state, local

    def lame_changes(self, model, directions):
        """``(dλ, d(λβ))`` (K, P) sparse for per-element parameter changes ``directions``."""
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
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
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
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
        constants = _stateless(model)
        geometry = constants.geometry
        F = geometry.edges(positions) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        slope = stiffening_slope(constants.law, green, constants.stiffening)
        stress = (constants.stiffening * shear)[:, None, None] * slope
        return corner_forces(self._columns(geometry, F @ stress))

    def parameter_values(self, model):
        """``{"youngs_modulus", "poisson_ratio", "viscosity"}``, each (n_elements,)."""
        return {"youngs_modulus": model.element_youngs_modulus,
                "poisson_ratio": model.element_poisson_ratio,
                "viscosity": model.element_viscosity}

    def with_parameter_values(self, model, values):
        return model.replace(element_youngs_modulus=values["youngs_modulus"],
                             element_poisson_ratio=values["poisson_ratio"],
                             element_viscosity=values["viscosity"]), self

    @classmethod
    def examples(cls, model):
        """The model's own elements (element models)."""
        return [(model, TETRAHEDRA)] if model.has_elements else []

    # -- the stability bound ------------------------------------------------------------------
    def rest_matrices(self, model):
        """``(K, C)``: ``-∂f/∂x`` and ``-∂f/∂v`` at rest, assembled (3N, 3N): the shear part
        element by element, the volumetric part ``Dᵀ W D`` from the rest divergence ``D``
        (and, for the nodal form, its node averages). Elements that relax (Prony terms) are
        ``1 + Σ gᵢ`` times stiffer at once than their long-term E, and so in the bound."""
        if model.n_relaxation_terms:
            instant = model.element_youngs_modulus * (
                1.0 + model.element_relaxation_moduli.sum(axis=1))
            return self.rest_matrices_of(ElementConstants.of(model.replace(
                element_youngs_modulus=instant)))
        return self.rest_matrices_of(ElementConstants.of(model))

    def rest_matrices_of(self, constants: ElementConstants):
        """:meth:`rest_matrices` of elements with the given :class:`ElementConstants`."""
        geometry = constants.geometry
        n_nodes = len(geometry.node_volume)
        rows = (3 * geometry.nodes[:, :, None] + np.arange(3)).reshape(-1, 12)
        divergence = self._rest_divergence(geometry, n_nodes)              # (K, 3N)
        matrices = []
        for shear, lam, node_lam in ((constants.shear, constants.lam, constants.node_lam),
                                     (constants.shear_rate, constants.lam_rate,
                                      constants.node_lam_rate)):
            blocks = self._rest_shear_blocks(geometry, shear)
            matrix = sp.csr_matrix(
                (blocks.ravel(), (np.repeat(rows, 12, axis=1).ravel(),
                                  np.tile(rows, (1, 12)).ravel())),
                shape=(3 * n_nodes, 3 * n_nodes))
            if constants.nodal:
                averaged = geometry.average @ divergence
                volumetric = averaged.T @ sp.diags(geometry.node_volume * node_lam) @ averaged
            else:
                volumetric = divergence.T @ sp.diags(geometry.volume * lam) @ divergence
            matrices.append(sp.csr_matrix(matrix + volumetric))
        return tuple(matrices)

    @staticmethod
    def _rest_divergence(geometry, n_nodes) -> sp.csr_matrix:
        """(K, 3N): ``∂θ_e/∂x`` at rest (``F = I``: the rows of ``B``, node 0 minus their
        sum)."""
        local = np.concatenate([-geometry.inverse_rest.sum(axis=1, keepdims=True),
                                geometry.inverse_rest], axis=1)             # (K, 4, 3)
        return geometry.corner_matrix(local, n_nodes).T.tocsr()

    @staticmethod
    def _rest_shear_blocks(geometry, shear) -> np.ndarray:
        """(K, 12, 12): the element stiffness at rest of ``S = shear · G`` (``-∂f/∂x``)."""
        K = len(geometry.nodes)
        tangent = np.zeros((K, 12, 4, 3))
        index = np.arange(12)
        tangent[:, index, index // 3, index % 3] = 1.0
        d_edges = np.swapaxes(tangent[:, :, 1:] - tangent[:, :, :1], -1, -2)   # (K, 12, 3, 3)
        d_piola = shear[:, None, None, None] * _sym(d_edges @ geometry.inverse_rest[:, None])
        columns = -geometry.volume[:, None, None, None] * (
            d_piola @ np.swapaxes(geometry.inverse_rest, 1, 2)[:, None])
        local = corner_forces(columns)                                       # (K, 4, 12, 3)
        return -np.moveaxis(local, 2, 1).reshape(K, 12, 12).transpose(0, 2, 1)


#: The tetrahedral-element term of element models.
TETRAHEDRA = TetrahedronForce()
