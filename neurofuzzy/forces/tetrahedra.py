"""Linear tetrahedral finite elements: St. Venant–Kirchhoff elasticity with Kelvin–Voigt
viscosity, parameterised by the material's own Young's modulus ``E`` (Pa), Poisson's ratio
``ν`` and viscosity ``η`` (Pa·s) per element.

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
far past the strains of palpation and probing.

Everything is vectorised over elements (``einsum`` on (n_elements, 3, 3) arrays, sparse
matrices for the node averages).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import VOLUMETRIC
from .base import ForceTerm

__all__ = ["TetrahedronForce", "TETRAHEDRA", "TetrahedronGeometry", "tetrahedron_geometry",
           "lame_factors", "VOLUMETRIC"]

#: The elements' parameters, in the order of every per-element parameter dictionary.
PARAMETERS = ("youngs_modulus", "poisson_ratio", "viscosity")

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class TetrahedronGeometry:
    """Rest geometry of the tetrahedra of a mesh.

    Attributes
    ----------
    nodes : (n_elements, 4) int
    inverse_rest : (n_elements, 3, 3) float
        ``B = Dm⁻¹``.
    volume : (n_elements,) float
    node_of_corner : (n_nodes, 4 n_elements) sparse
        Sums per-corner values (element e's corner j in column 4e + j) into their nodes.
    node_volume : (n_nodes,) float
        ``V_a = Σ_{e∋a} V_e / 4``.
    average : (n_nodes, n_elements) sparse
        Volume-weighted average over a node's tetrahedra, ``(V_e/4) / V_a``.
    corner_mean : (n_elements, n_nodes) sparse
        Mean over an element's four corners (``¼`` per corner).
    """

    nodes: np.ndarray
    inverse_rest: np.ndarray
    volume: np.ndarray
    node_of_corner: sp.csr_matrix
    node_volume: np.ndarray
    average: sp.csr_matrix
    corner_mean: sp.csr_matrix

    def edges(self, positions: np.ndarray) -> np.ndarray:
        """(n_elements, 3, 3) ``[x1-x0, x2-x0, x3-x0]`` as columns; also for tangents
        (n_nodes, P, 3) → (n_elements, P, 3, 3)."""
        corners = positions[self.nodes]                      # (K, 4, [P,] 3)
        difference = corners[:, 1:] - corners[:, :1]         # (K, 3, [P,] 3): rows = edges
        if difference.ndim == 3:
            return np.swapaxes(difference, 1, 2)             # columns = edges
        return np.moveaxis(difference, 1, -1)                # (K, P, 3, 3)

    def scatter(self, columns: np.ndarray, n_nodes: int) -> np.ndarray:
        """Node forces (n_nodes, [P,] 3) from per-element ``[f1 f2 f3]`` (as columns,
        (n_elements, [P,] 3, 3)); node 0 of every element gets ``-(f1 + f2 + f3)``."""
        return self.scatter_local(corner_forces(columns), n_nodes)

    def scatter_local(self, local: np.ndarray, n_nodes: int) -> np.ndarray:
        """Node sums (n_nodes, ...) of per-corner values (n_elements, 4, ...)."""
        flat = local.reshape(len(self.nodes) * 4, -1)
        return np.asarray(self.node_of_corner @ flat).reshape(n_nodes, *local.shape[2:])

    def corner_matrix(self, local: np.ndarray, n_nodes: int) -> sp.csr_matrix:
        """(3 n_nodes, n_elements) sparse: column e holds element e's per-corner forces
        ``local[e]`` (4, 3) at its nodes' rows ``3 node + axis``."""
        rows = (3 * self.nodes[:, :, None] + np.arange(3)).ravel()
        columns = np.repeat(np.arange(len(self.nodes)), 12)
        return sp.csr_matrix((local.ravel(), (rows, columns)),
                             shape=(3 * n_nodes, len(self.nodes)))


def corner_forces(columns: np.ndarray) -> np.ndarray:
    """(n_elements, 4, [P,] 3) per-corner forces from ``[f1 f2 f3]`` as columns
    (n_elements, [P,] 3, 3)."""
    per_node = np.moveaxis(columns, -1, 1)                   # (K, 3, [P,] 3)
    return np.concatenate([-per_node.sum(axis=1, keepdims=True), per_node], axis=1)


def tetrahedron_geometry(mesh) -> TetrahedronGeometry:
    """The (cached) :class:`TetrahedronGeometry` of ``mesh.tetrahedra``."""
    found = _CACHE.get(mesh)
    if found is None:
        if mesh.tetrahedra is None:
            raise InputError("the mesh has no tetrahedra", key="tetrahedra")
        nodes = np.asarray(mesh.tetrahedra)
        corners = mesh.rest_positions[nodes]
        rest = np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2)
        determinant = np.linalg.det(rest)
        scale = np.max(np.abs(corners - corners.mean(axis=1, keepdims=True)), axis=(1, 2))
        flat = np.abs(determinant) <= 1e-12 * scale**3
        if flat.any():
            bad = int(np.flatnonzero(flat)[0])
            raise InputError(f"tetrahedron {bad} (nodes {nodes[bad].tolist()}) has zero volume",
                             key="tetrahedra")
        n_nodes, n_elements = mesh.n_nodes, len(nodes)
        volume = np.abs(determinant) / 6.0
        corners_to_nodes = sp.csr_matrix(
            (np.ones(nodes.size), (nodes.ravel(), np.arange(nodes.size))),
            shape=(n_nodes, nodes.size))
        element_of_corner = np.repeat(np.arange(n_elements), 4)
        incidence = sp.csr_matrix((np.ones(nodes.size), (nodes.ravel(), element_of_corner)),
                                  shape=(n_nodes, n_elements))
        node_volume = incidence @ (volume / 4)
        average = sp.diags(1.0 / np.where(node_volume > 0, node_volume, 1.0)) @ (
            incidence @ sp.diags(volume / 4))
        found = _CACHE[mesh] = TetrahedronGeometry(
            nodes, np.linalg.inv(rest), volume, corners_to_nodes, node_volume,
            sp.csr_matrix(average), sp.csr_matrix(0.25 * incidence.T))
    return found


def lame_factors(poisson_ratio: np.ndarray):
    """``(a, b, da/dν, db/dν)`` with ``λ = E a`` and ``μ = E b``."""
    nu = np.asarray(poisson_ratio, float)
    denominator = (1 + nu) * (1 - 2 * nu)
    return (nu / denominator, 0.5 / (1 + nu), (1 + 2 * nu * nu) / denominator**2,
            -0.5 / (1 + nu) ** 2)


def _sym(matrix):
    return 0.5 * (matrix + np.swapaxes(matrix, -1, -2))


def _trace_product(x, y):
    """``tr(xᵀ y)`` over the last two axes."""
    return np.einsum("...ij,...ij->...", x, y)


def _column(values, like):
    """(K,) per-element values shaped to broadcast against (K, [P,] 3, 3) arrays."""
    return values.reshape((-1,) + (1,) * (like.ndim - 1))


@dataclass(frozen=True)
class Materials:
    """Per-element constants of a model's elements (derived from E, ν, η), and the
    volumetric coupling.

    Attributes
    ----------
    shear, shear_rate : (K,) float
        ``2μ`` and ``2μβ = 2bη``: the deviatoric-and-shear part of ``S`` per unit ``G``, ``Ġ``.
    lam, lam_rate : (K,) float
        ``λ`` and ``λβ = aη``.
    node_lam, node_lam_rate : (n_nodes,) float or None
        Their node averages ``Λ``, ``H`` (nodal volumetric form only).
    """

    geometry: TetrahedronGeometry
    nodal: bool
    shear: np.ndarray
    shear_rate: np.ndarray
    lam: np.ndarray
    lam_rate: np.ndarray
    node_lam: np.ndarray | None
    node_lam_rate: np.ndarray | None

    @classmethod
    def of(cls, model) -> Materials:
        geometry = tetrahedron_geometry(model.mesh)
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
        a, b, _, _ = lame_factors(nu)
        nodal = model.element_volumetric == "nodal"
        lam, lam_rate = E * a, eta * a
        return cls(geometry, nodal, 2 * E * b, 2 * eta * b, lam, lam_rate,
                   geometry.average @ lam if nodal else None,
                   geometry.average @ lam_rate if nodal else None)

    def pressure(self, theta, theta_rate):
        """``π`` (K, ...) from the volumetric strain and rate (K, ...)."""
        if not self.nodal:
            return _column(self.lam, theta) * theta + _column(self.lam_rate, theta) * theta_rate
        average = self.geometry.average
        at_nodes = (_column(self.node_lam, theta[:1]) * (average @ theta)
                    + _column(self.node_lam_rate, theta[:1]) * (average @ theta_rate))
        return self.geometry.corner_mean @ at_nodes

    def pressure_transpose(self, lam_pressure):
        """The adjoint of :meth:`pressure`: cotangents of ``θ`` and ``θ̇`` (K,)."""
        if not self.nodal:
            return self.lam * lam_pressure, self.lam_rate * lam_pressure
        at_nodes = self.geometry.corner_mean.T @ lam_pressure
        average = self.geometry.average
        return (average.T @ (self.node_lam * at_nodes),
                average.T @ (self.node_lam_rate * at_nodes))

    def pressure_of_constants(self, d_lam, d_lam_rate, theta, theta_rate):
        """``∂π`` (K, P) for changes ``d_lam``, ``d_lam_rate`` (K, P, sparse or dense) of
        the elements' ``λ`` and ``λβ`` at fixed strains ``θ``, ``θ̇`` (K,)."""
        if not self.nodal:
            return sp.csr_matrix(sp.diags(theta) @ d_lam + sp.diags(theta_rate) @ d_lam_rate)
        average = self.geometry.average
        at_nodes = (sp.diags(average @ theta) @ (average @ d_lam)
                    + sp.diags(average @ theta_rate) @ (average @ d_lam_rate))
        return sp.csr_matrix(self.geometry.corner_mean @ at_nodes)

    def constants_transpose(self, lam_pressure, theta, theta_rate):
        """The adjoint of :meth:`pressure_of_constants`: per-element cotangents (K,) of
        ``λ`` and ``λβ``."""
        if not self.nodal:
            return lam_pressure * theta, lam_pressure * theta_rate
        at_nodes = self.geometry.corner_mean.T @ lam_pressure
        average = self.geometry.average
        return (average.T @ ((average @ theta) * at_nodes),
                average.T @ ((average @ theta_rate) * at_nodes))


@dataclass(frozen=True)
class _State:
    F: np.ndarray
    F_rate: np.ndarray
    green: np.ndarray
    green_rate: np.ndarray
    theta: np.ndarray
    theta_rate: np.ndarray
    stress: np.ndarray           # S


class TetrahedronForce(ForceTerm):
    """The tetrahedral elements of a model (stateless, like the springs: the parameters are
    the model's ``element_youngs_modulus``, ``element_poisson_ratio`` and
    ``element_viscosity``, the elements ``model.mesh.tetrahedra``, the volumetric form
    ``model.element_volumetric``). :data:`TETRAHEDRA` is the one instance."""

    name = "tetrahedra"
    parameters = {"youngs_modulus": "Pa", "poisson_ratio": "1", "viscosity": "Pa s"}

    def _state(self, materials: Materials, positions, velocities) -> _State:
        geometry = materials.geometry
        F = geometry.edges(positions) @ geometry.inverse_rest
        F_rate = geometry.edges(velocities) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        green_rate = _sym(np.swapaxes(F, 1, 2) @ F_rate)
        theta = np.trace(green, axis1=1, axis2=2)
        theta_rate = np.trace(green_rate, axis1=1, axis2=2)
        pressure = materials.pressure(theta, theta_rate)
        stress = (materials.shear[:, None, None] * green
                  + materials.shear_rate[:, None, None] * green_rate
                  + pressure[:, None, None] * np.eye(3))
        return _State(F, F_rate, green, green_rate, theta, theta_rate, stress)

    @staticmethod
    def _columns(geometry, first_piola: np.ndarray) -> np.ndarray:
        """``-V P Bᵀ`` for per-element ``P`` ((K, 3, 3) or (K, P, 3, 3))."""
        inverse_transpose = np.swapaxes(geometry.inverse_rest, 1, 2)
        if first_piola.ndim == 4:
            inverse_transpose = inverse_transpose[:, None]
        return -_column(geometry.volume, first_piola) * (first_piola @ inverse_transpose)

    def force(self, model, positions, velocities):
        materials = Materials.of(model)
        state = self._state(materials, positions, velocities)
        return materials.geometry.scatter(
            self._columns(materials.geometry, state.F @ state.stress), model.n_nodes)

    def state_jvp(self, model, positions, velocities, dp, dv):
        materials = Materials.of(model)
        geometry = materials.geometry
        state = self._state(materials, positions, velocities)
        B = geometry.inverse_rest[:, None]
        dF = geometry.edges(dp) @ B                                  # (K, P, 3, 3)
        dF_rate = geometry.edges(dv) @ B
        F, F_rate = state.F[:, None], state.F_rate[:, None]
        d_green = _sym(np.swapaxes(F, -1, -2) @ dF)
        d_green_rate = _sym(np.swapaxes(dF, -1, -2) @ F_rate + np.swapaxes(F, -1, -2) @ dF_rate)
        d_theta = _trace_product(F, dF)                              # (K, P)
        d_theta_rate = _trace_product(dF, F_rate) + _trace_product(F, dF_rate)
        d_pressure = materials.pressure(d_theta, d_theta_rate)
        d_stress = (_column(materials.shear, d_green) * d_green
                    + _column(materials.shear_rate, d_green) * d_green_rate
                    + d_pressure[..., None, None] * np.eye(3))
        d_piola = dF @ state.stress[:, None] + F @ d_stress
        return geometry.scatter(self._columns(geometry, d_piola), model.n_nodes)

    def state_vjp(self, model, positions, velocities, cotangent):
        materials = Materials.of(model)
        geometry = materials.geometry
        state = self._state(materials, positions, velocities)
        B = geometry.inverse_rest
        # cotangent of [f1 f2 f3] (columns): λ_{n_j} - λ_{n_0}
        lam_piola = -geometry.volume[:, None, None] * (geometry.edges(cotangent) @ B)
        lam_stress = np.swapaxes(state.F, 1, 2) @ lam_piola
        lam_green = _sym(materials.shear[:, None, None] * lam_stress)
        lam_green_rate = _sym(materials.shear_rate[:, None, None] * lam_stress)
        lam_theta, lam_theta_rate = materials.pressure_transpose(
            np.trace(lam_stress, axis1=1, axis2=2))
        F, F_rate = state.F, state.F_rate
        lam_F = (lam_piola @ state.stress + F @ lam_green + F_rate @ lam_green_rate
                 + lam_theta[:, None, None] * F + lam_theta_rate[:, None, None] * F_rate)
        lam_F_rate = F @ lam_green_rate + lam_theta_rate[:, None, None] * F
        # the adjoint of ``edges`` is ``scatter``: column j to node j+1, minus the sum to node 0
        return (geometry.scatter(lam_F @ np.swapaxes(B, 1, 2), model.n_nodes),
                geometry.scatter(lam_F_rate @ np.swapaxes(B, 1, 2), model.n_nodes))

    # -- parameters ---------------------------------------------------------------------------
    def _unit_forces(self, model, positions, velocities):
        """Per-corner forces (K, 4, 3) per unit change of each element's shear part
        (``2μ`` by ``E``, ``ν``, ``η``) and of its ``π``, with the materials and state."""
        materials = Materials.of(model)
        geometry = materials.geometry
        state = self._state(materials, positions, velocities)
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
        _, b, _, db = lame_factors(nu)
        stresses = {"youngs_modulus": 2 * b[:, None, None] * state.green,
                    "viscosity": 2 * b[:, None, None] * state.green_rate,
                    "poisson_ratio": 2 * db[:, None, None] * (
                        E[:, None, None] * state.green + eta[:, None, None] * state.green_rate),
                    "pressure": np.broadcast_to(np.eye(3), state.F.shape)}
        local = {name: corner_forces(self._columns(geometry, state.F @ stress))
                 for name, stress in stresses.items()}
        return materials, state, local

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
        materials, state, local = self._unit_forces(model, positions, velocities)
        geometry = materials.geometry
        n_nodes = model.n_nodes
        total = None
        for name in PARAMETERS:
            part = geometry.corner_matrix(local[name], n_nodes) @ directions[name]
            total = part if total is None else total + part
        d_lam, d_lam_rate = self.lame_changes(model, directions)
        d_pressure = materials.pressure_of_constants(d_lam, d_lam_rate, state.theta,
                                                     state.theta_rate)
        total = total + geometry.corner_matrix(local["pressure"], n_nodes) @ d_pressure
        dense = total.toarray() if sp.issparse(total) else np.asarray(total)
        return dense.reshape(n_nodes, 3, -1).transpose(0, 2, 1)

    def parameter_vjp(self, model, positions, velocities, cotangent) -> dict[str, np.ndarray]:
        """Per-element gradients (n_elements,) of ``Σ cotangent · force`` with respect to
        every element's ``youngs_modulus``, ``poisson_ratio`` and ``viscosity`` (the adjoint
        of :meth:`parameter_jvp`)."""
        materials, state, local = self._unit_forces(model, positions, velocities)
        corners = cotangent[materials.geometry.nodes]                       # (K, 4, 3)
        out = {name: np.einsum("ejk,ejk->e", corners, values)
               for name, values in local.items()}
        lam_pressure = out.pop("pressure")
        g_lam, g_lam_rate = materials.constants_transpose(lam_pressure, state.theta,
                                                          state.theta_rate)
        E, nu, eta = (model.element_youngs_modulus, model.element_poisson_ratio,
                      model.element_viscosity)
        a, _, da, _ = lame_factors(nu)
        out["youngs_modulus"] = out["youngs_modulus"] + a * g_lam
        out["poisson_ratio"] = out["poisson_ratio"] + da * (E * g_lam + eta * g_lam_rate)
        out["viscosity"] = out["viscosity"] + a * g_lam_rate
        return out

    # -- the stability bound ------------------------------------------------------------------
    def rest_matrices(self, model):
        """``(K, C)``: ``-∂f/∂x`` and ``-∂f/∂v`` at rest, assembled (3N, 3N): the shear part
        element by element, the volumetric part ``Dᵀ W D`` from the rest divergence ``D``
        (and, for the nodal form, its node averages)."""
        materials = Materials.of(model)
        geometry = materials.geometry
        n_nodes = model.n_nodes
        rows = (3 * geometry.nodes[:, :, None] + np.arange(3)).reshape(-1, 12)
        divergence = self._rest_divergence(geometry, n_nodes)              # (K, 3N)
        matrices = []
        for shear, lam, node_lam in ((materials.shear, materials.lam, materials.node_lam),
                                     (materials.shear_rate, materials.lam_rate,
                                      materials.node_lam_rate)):
            blocks = self._rest_shear_blocks(geometry, shear)
            matrix = sp.csr_matrix(
                (blocks.ravel(), (np.repeat(rows, 12, axis=1).ravel(),
                                  np.tile(rows, (1, 12)).ravel())),
                shape=(3 * n_nodes, 3 * n_nodes))
            if materials.nodal:
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
