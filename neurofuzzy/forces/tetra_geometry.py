"""Rest geometry of tetrahedral elements and their per-element material constants (the part of
:mod:`neurofuzzy.forces.tetrahedra` that knows no state): edge matrices, volumes, node
averages, Lamé factors and the volumetric coupling of both forms."""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError

__all__ = ["TetrahedronGeometry", "tetrahedron_geometry", "corner_forces", "lame_factors",
           "ElementConstants", "broadcast_per_element"]

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


def broadcast_per_element(values, like):
    """(K,) per-element values shaped to broadcast against (K, [P,] 3, 3) arrays."""
    return values.reshape((-1,) + (1,) * (like.ndim - 1))


@dataclass(frozen=True)
class ElementConstants:
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
    law : (K,) int
        Every element's material law (:mod:`neurofuzzy.forces.laws`).
    stiffening : (K,) float
        Yeoh's ``C₂₀/C₁₀`` of every element (unused by the other laws).
    """

    geometry: TetrahedronGeometry
    nodal: bool
    shear: np.ndarray
    shear_rate: np.ndarray
    lam: np.ndarray
    lam_rate: np.ndarray
    node_lam: np.ndarray | None
    node_lam_rate: np.ndarray | None
    law: np.ndarray
    stiffening: np.ndarray

    @classmethod
    def of(cls, elements, mesh) -> ElementConstants:
        """The constants of the :class:`~neurofuzzy.forces.Tetrahedra` ``elements`` on
        ``mesh``."""
        return cls.from_values(tetrahedron_geometry(mesh), elements.youngs_modulus,
                               elements.poisson_ratio, elements.viscosity,
                               nodal=elements.volumetric == "nodal", law=elements.law,
                               stiffening=elements.stiffening)

    @classmethod
    def from_values(cls, geometry: TetrahedronGeometry, youngs_modulus, poisson_ratio,
                    viscosity, *, nodal: bool, law=None, stiffening=None) -> ElementConstants:
        """The constants from per-element E, ν, η (K,) arrays (E and η may be zero: an extra
        stiffness on part of a model, as an inclusion adds), law numbers (K,) (default
        St. Venant–Kirchhoff) and Yeoh's stiffening constants (K,) (default 0)."""
        E, eta = np.asarray(youngs_modulus, float), np.asarray(viscosity, float)
        a, b, _, _ = lame_factors(poisson_ratio)
        lam, lam_rate = E * a, eta * a
        return cls(geometry, nodal, 2 * E * b, 2 * eta * b, lam, lam_rate,
                   geometry.average @ lam if nodal else None,
                   geometry.average @ lam_rate if nodal else None,
                   np.zeros(len(geometry.volume), np.intp) if law is None
                   else np.asarray(law, np.intp),
                   np.zeros(len(geometry.volume)) if stiffening is None
                   else np.asarray(stiffening, float))

    def pressures(self, theta, theta_rate):
        """``(π, π̇)``: the elastic and the viscous volumetric stress (K, ...) of the volumetric
        strain ``θ`` and its rate (K, ...): ``λ θ`` and ``λβ θ̇`` per element, or the corner
        means of the node averages ``Λ θ̄`` and ``H θ̄̇`` (nodal form)."""
        if not self.nodal:
            return (broadcast_per_element(self.lam, theta) * theta,
                    broadcast_per_element(self.lam_rate, theta) * theta_rate)
        average, corner_mean = self.geometry.average, self.geometry.corner_mean
        return (corner_mean @ (broadcast_per_element(self.node_lam, theta[:1])
                               * (average @ theta)),
                corner_mean @ (broadcast_per_element(self.node_lam_rate, theta[:1])
                               * (average @ theta_rate)))

    def pressure_transpose(self, bar_pressure):
        """The adjoint of :meth:`pressures` for one cotangent of both: cotangents of ``θ``
        (through ``π``) and of ``θ̇`` (through ``π̇``) (K,)."""
        if not self.nodal:
            return self.lam * bar_pressure, self.lam_rate * bar_pressure
        at_nodes = self.geometry.corner_mean.T @ bar_pressure
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

    def constants_transpose(self, bar_pressure, theta, theta_rate):
        """The adjoint of :meth:`pressure_of_constants`: per-element cotangents (K,) of
        ``λ`` and ``λβ``."""
        if not self.nodal:
            return bar_pressure * theta, bar_pressure * theta_rate
        at_nodes = self.geometry.corner_mean.T @ bar_pressure
        average = self.geometry.average
        return (average.T @ ((average @ theta) * at_nodes),
                average.T @ ((average @ theta_rate) * at_nodes))


