"""Linear tetrahedral finite elements: St. Venant–Kirchhoff elasticity with Kelvin–Voigt
viscosity, parameterised by the material's own Young's modulus ``E`` (Pa), Poisson's ratio
``ν`` and viscosity ``η`` (Pa·s) per element.

Element ``e`` with nodes ``n0..n3``, rest edge matrix ``Dm = [X1-X0, X2-X0, X3-X0]``,
``B = Dm⁻¹``, volume ``V = |det Dm| / 6``; at the state ``(x, v)``::

    F = Ds B,  Ḟ = Ḋs B                       (Ds = [x1-x0, x2-x0, x3-x0], Ḋs from v)
    G = ½ (FᵀF - I),  Ġ = sym(Fᵀ Ḟ)           Green strain and its rate
    S = E L(G) + η L(Ġ),  L(X) = a tr(X) I + 2 b X,  a = ν/((1+ν)(1-2ν)),  b = 1/(2(1+ν))
    P = F S,   [f1 f2 f3] = -V P Bᵀ,   f0 = -(f1 + f2 + f3)

so ``λ = E a`` and ``μ = E b`` are the Lamé constants and the viscous stress is the elastic
one of the strain rate times ``η / E`` (a Rayleigh stiffness-proportional damping with
``β = η / E``).

Why St. Venant–Kirchhoff and not corotational linear elasticity: both reduce to linear
elasticity at small strain (tested against scikit-fem's linear-elasticity stiffness matrix to
round-off) and both are exact under rigid rotation, but SVK's force is a polynomial in the
node positions, so its exact forward and reverse derivatives (which both learners need) are a
few batched 3×3 products, where the corotational element needs the derivative of a polar
decomposition. SVK softens under strong compression (beyond ~30 %), far past the strains of
palpation and probing.

Everything is vectorised over elements (``einsum`` on (n_elements, 3, 3) arrays).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .base import ForceTerm

__all__ = ["TetrahedronForce", "TETRAHEDRA", "TetrahedronGeometry", "tetrahedron_geometry",
           "lame_factors"]

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
    """

    nodes: np.ndarray
    inverse_rest: np.ndarray
    volume: np.ndarray
    node_of_corner: sp.csr_matrix

    def edges(self, positions: np.ndarray) -> np.ndarray:
        """(n_elements, 3, 3) ``[x1-x0, x2-x0, x3-x0]`` as columns; also for tangents
        (n_nodes, P, 3) → (n_elements, P, 3, 3)."""
        corners = positions[self.nodes]                      # (K, 4, [P,] 3)
        difference = corners[:, 1:] - corners[:, :1]         # (K, 3, [P,] 3): rows = edges
        if difference.ndim == 3:
            return np.swapaxes(difference, 1, 2)             # columns = edges
        return np.moveaxis(difference, 1, -1)                # (K, P, 3, 3)

    def group_sums(self, local: np.ndarray, group: np.ndarray, n_groups: int,
                   n_nodes: int) -> np.ndarray:
        """(n_nodes, n_groups, 3): per-element node forces ``local`` (n_elements, 4, 3)
        summed within each group of elements."""
        out = np.zeros((n_nodes, n_groups, 3))
        np.add.at(out, (self.nodes.ravel(), np.repeat(group, 4)), local.reshape(-1, 3))
        return out

    def scatter(self, columns: np.ndarray, n_nodes: int) -> np.ndarray:
        """Node forces (n_nodes, [P,] 3) from per-element ``[f1 f2 f3]`` (as columns,
        (n_elements, [P,] 3, 3)); node 0 of every element gets ``-(f1 + f2 + f3)``."""
        per_node = np.moveaxis(columns, -1, 1)               # (K, 3, [P,] 3)
        first = -per_node.sum(axis=1, keepdims=True)
        local = np.concatenate([first, per_node], axis=1)    # (K, 4, [P,] 3)
        flat = local.reshape(len(self.nodes) * 4, -1)
        return np.asarray(self.node_of_corner @ flat).reshape(n_nodes, *local.shape[2:])


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
        corners_to_nodes = sp.csr_matrix(
            (np.ones(nodes.size), (nodes.ravel(), np.arange(nodes.size))),
            shape=(mesh.n_nodes, nodes.size))
        found = _CACHE[mesh] = TetrahedronGeometry(nodes, np.linalg.inv(rest),
                                                   np.abs(determinant) / 6.0, corners_to_nodes)
    return found


def lame_factors(poisson_ratio: np.ndarray):
    """``(a, b, da/dν, db/dν)`` with ``λ = E a`` and ``μ = E b``."""
    nu = np.asarray(poisson_ratio, float)
    denominator = (1 + nu) * (1 - 2 * nu)
    return (nu / denominator, 0.5 / (1 + nu), (1 + 2 * nu * nu) / denominator**2,
            -0.5 / (1 + nu) ** 2)


def _elastic(a, b, strain):
    """``L(X) = a tr(X) I + 2 b X`` per element, for (K, [P,] 3, 3) with a, b (K,)."""
    trace = np.trace(strain, axis1=-2, axis2=-1)                     # (K, [P])
    per_element = (-1,) + (1,) * (trace.ndim - 1)
    return (2 * b.reshape(per_element + (1, 1)) * strain
            + (a.reshape(per_element) * trace)[..., None, None] * np.eye(3))


def _sym(matrix):
    return 0.5 * (matrix + np.swapaxes(matrix, -1, -2))


@dataclass(frozen=True)
class _State:
    F: np.ndarray
    F_rate: np.ndarray
    green: np.ndarray
    green_rate: np.ndarray
    stress: np.ndarray           # S


class TetrahedronForce(ForceTerm):
    """The tetrahedral elements of a model (stateless, like the springs: the parameters are
    the model's ``element_youngs_modulus``, ``element_poisson_ratio`` and
    ``element_viscosity``, the elements ``model.mesh.tetrahedra``). :data:`TETRAHEDRA` is the
    one instance."""

    name = "tetrahedra"
    parameters = {"youngs_modulus": "Pa", "poisson_ratio": "1", "viscosity": "Pa s"}

    @staticmethod
    def _constants(model):
        return (model.element_youngs_modulus, model.element_poisson_ratio,
                model.element_viscosity)

    def _state(self, model, positions, velocities) -> _State:
        geometry = tetrahedron_geometry(model.mesh)
        E, nu, eta = self._constants(model)
        a, b, _, _ = lame_factors(nu)
        F = geometry.edges(positions) @ geometry.inverse_rest
        F_rate = geometry.edges(velocities) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        green_rate = _sym(np.swapaxes(F, 1, 2) @ F_rate)
        stress = (E[:, None, None] * _elastic(a, b, green)
                  + eta[:, None, None] * _elastic(a, b, green_rate))
        return _State(F, F_rate, green, green_rate, stress)

    def _nodal(self, model, first_piola: np.ndarray, n_extra: int = 0) -> np.ndarray:
        """Node forces from per-element ``P`` ((K, 3, 3) or (K, P, 3, 3))."""
        geometry = tetrahedron_geometry(model.mesh)
        shape = (-1,) + (1,) * (n_extra + 2)
        columns = -geometry.volume.reshape(shape) * (
            first_piola @ np.swapaxes(geometry.inverse_rest, 1, 2).reshape(
                (len(geometry.volume),) + (1,) * n_extra + (3, 3)))
        return geometry.scatter(columns, model.n_nodes)

    def force(self, model, positions, velocities):
        state = self._state(model, positions, velocities)
        return self._nodal(model, state.F @ state.stress)

    def state_jvp(self, model, positions, velocities, dp, dv):
        geometry = tetrahedron_geometry(model.mesh)
        state = self._state(model, positions, velocities)
        E, nu, eta = self._constants(model)
        a, b, _, _ = lame_factors(nu)
        B = geometry.inverse_rest[:, None]
        dF = geometry.edges(dp) @ B                                  # (K, P, 3, 3)
        dF_rate = geometry.edges(dv) @ B
        F, F_rate = state.F[:, None], state.F_rate[:, None]
        d_green = _sym(np.swapaxes(F, -1, -2) @ dF)
        d_green_rate = _sym(np.swapaxes(dF, -1, -2) @ F_rate + np.swapaxes(F, -1, -2) @ dF_rate)
        d_stress = (E[:, None, None, None] * _elastic(a, b, d_green)
                    + eta[:, None, None, None] * _elastic(a, b, d_green_rate))
        d_piola = dF @ state.stress[:, None] + F @ d_stress
        return self._nodal(model, d_piola, n_extra=1)

    def state_vjp(self, model, positions, velocities, cotangent):
        geometry = tetrahedron_geometry(model.mesh)
        state = self._state(model, positions, velocities)
        E, nu, eta = self._constants(model)
        a, b, _, _ = lame_factors(nu)
        B = geometry.inverse_rest
        # cotangent of [f1 f2 f3] (columns): λ_{n_j} - λ_{n_0}
        lam_columns = geometry.edges(cotangent)
        lam_piola = -geometry.volume[:, None, None] * (lam_columns @ B)
        lam_F = lam_piola @ state.stress
        lam_stress = np.swapaxes(state.F, 1, 2) @ lam_piola
        lam_green = _sym(E[:, None, None] * _elastic(a, b, lam_stress))
        lam_green_rate = _sym(eta[:, None, None] * _elastic(a, b, lam_stress))
        lam_F = lam_F + state.F @ lam_green + state.F_rate @ lam_green_rate
        lam_F_rate = state.F @ lam_green_rate
        # the adjoint of ``edges`` is ``scatter``: column j to node j+1, minus the sum to node 0
        return (geometry.scatter(lam_F @ np.swapaxes(B, 1, 2), model.n_nodes),
                geometry.scatter(lam_F_rate @ np.swapaxes(B, 1, 2), model.n_nodes))

    def parameter_templates(self, model, positions, velocities) -> dict[str, np.ndarray]:
        """(n_elements, 4, 3) per parameter: the forces on an element's four nodes
        (``tetrahedra`` order) per unit change of its ``youngs_modulus``,
        ``poisson_ratio`` and ``viscosity``."""
        geometry = tetrahedron_geometry(model.mesh)
        state = self._state(model, positions, velocities)
        E, nu, eta = self._constants(model)
        a, b, da, db = lame_factors(nu)
        per_unit = {
            "youngs_modulus": _elastic(a, b, state.green),
            "viscosity": _elastic(a, b, state.green_rate),
            "poisson_ratio": (E[:, None, None] * _elastic(da, db, state.green)
                              + eta[:, None, None] * _elastic(da, db, state.green_rate)),
        }
        out = {}
        for name, stress in per_unit.items():
            columns = -geometry.volume[:, None, None] * (
                state.F @ stress @ np.swapaxes(geometry.inverse_rest, 1, 2))
            per_node = np.swapaxes(columns, 1, 2)                    # (K, 3 nodes, 3)
            out[name] = np.concatenate([-per_node.sum(axis=1, keepdims=True), per_node], axis=1)
        return out

    def rest_matrices(self, model):
        """``(K, C)``: ``-∂f/∂x`` and ``-∂f/∂v`` at rest, assembled (3N, 3N)."""
        geometry = tetrahedron_geometry(model.mesh)
        rest = model.mesh.rest_positions
        n_nodes = model.n_nodes
        matrices = []
        for which in ("position", "velocity"):
            blocks = np.empty((len(geometry.nodes), 12, 12))
            for column in range(12):
                node, axis = divmod(column, 3)
                tangent = np.zeros((len(geometry.nodes), 4, 3))
                tangent[:, node, axis] = 1.0
                blocks[:, :, column] = -self._local_jvp(model, rest, tangent, which)
            rows = (3 * geometry.nodes[:, :, None] + np.arange(3)).reshape(-1, 12)
            matrices.append(sp.csr_matrix(
                (blocks.ravel(), (np.repeat(rows, 12, axis=1).ravel(),
                                  np.tile(rows, (1, 12)).ravel())),
                shape=(3 * n_nodes, 3 * n_nodes)))
        return tuple(matrices)

    def _local_jvp(self, model, positions, tangent, which) -> np.ndarray:
        """(K, 12): element-local force derivative for one element-local tangent (K, 4, 3)
        of the positions or the velocities, at ``positions`` at rest (zero velocity)."""
        geometry = tetrahedron_geometry(model.mesh)
        E, nu, eta = self._constants(model)
        a, b, _, _ = lame_factors(nu)
        F = geometry.edges(positions) @ geometry.inverse_rest
        d_edges = np.swapaxes(tangent[:, 1:] - tangent[:, :1], 1, 2)
        d = d_edges @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        if which == "position":
            d_stress = E[:, None, None] * _elastic(a, b, _sym(np.swapaxes(F, 1, 2) @ d))
            d_piola = d @ (E[:, None, None] * _elastic(a, b, green)) + F @ d_stress
        else:
            d_piola = F @ (eta[:, None, None] * _elastic(a, b, _sym(np.swapaxes(F, 1, 2) @ d)))
        columns = -geometry.volume[:, None, None] * (
            d_piola @ np.swapaxes(geometry.inverse_rest, 1, 2))
        nodal = np.concatenate([-columns.sum(axis=2, keepdims=True), columns], axis=2)
        return np.swapaxes(nodal, 1, 2).reshape(len(geometry.nodes), 12)


#: The tetrahedral-element term of element models.
TETRAHEDRA = TetrahedronForce()
