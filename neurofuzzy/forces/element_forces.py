"""The numpy forces of tetrahedral elements with given :class:`ElementConstants`, and their
state derivatives: the model's own elements (:class:`~neurofuzzy.forces.tetrahedra.Tetrahedra`)
and an inclusion's or a law switch's constants on part of a model (:mod:`neurofuzzy.effects`)
go through these functions (the equations are in :mod:`neurofuzzy.forces.tetrahedra`).

The stress ``S`` and its derivatives come from the compiled law
(:class:`~neurofuzzy.forces.laws.ElementStress`); this module forms ``F``, ``G``, the
volumetric strains and the forces ``-V P Bᵀ``, vectorised over elements (batched (K, 3, 3)
products).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .laws import ElementStress
from .tetra_geometry import ElementConstants, broadcast_per_element

__all__ = ["ElementState", "element_state", "columns", "element_force", "element_state_jvp",
           "element_state_vjp", "element_rest_matrices"]


def _sym(matrix):
    return 0.5 * (matrix + np.swapaxes(matrix, -1, -2))


def _trace_product(x, y):
    """``tr(xᵀ y)`` over the last two axes."""
    return np.einsum("...ij,...ij->...", x, y)


@dataclass(frozen=True)
class ElementState:
    """The elements' kinematics and stress at one state (K elements)."""

    F: np.ndarray
    F_rate: np.ndarray
    green: np.ndarray
    green_rate: np.ndarray
    theta: np.ndarray
    theta_rate: np.ndarray
    at: ElementStress            # S's arguments (π, π̇ included) and its derivatives
    stress: np.ndarray           # S


def element_state(constants: ElementConstants, positions, velocities) -> ElementState:
    """``F``, ``Ḟ``, ``G``, ``Ġ``, ``θ``, ``θ̇`` and ``S`` of every element."""
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
    return ElementState(F, F_rate, green, green_rate, theta, theta_rate, at, at.stress())


def columns(geometry, first_piola: np.ndarray) -> np.ndarray:
    """``-V P Bᵀ`` for per-element ``P`` ((K, 3, 3) or (K, P, 3, 3)): the forces on an
    element's nodes 1–3 as columns (node 0 gets minus their sum)."""
    inverse_transpose = np.swapaxes(geometry.inverse_rest, 1, 2)
    if first_piola.ndim == 4:
        inverse_transpose = inverse_transpose[:, None]
    return (-broadcast_per_element(geometry.volume, first_piola)
            * (first_piola @ inverse_transpose))


def element_force(constants: ElementConstants, positions, velocities) -> np.ndarray:
    """(n_nodes, 3) force of elements with the given constants."""
    state = element_state(constants, positions, velocities)
    return constants.geometry.scatter(
        columns(constants.geometry, state.F @ state.stress), len(positions))


def element_state_jvp(constants: ElementConstants, positions, velocities, dp, dv):
    """(n_nodes, P, 3): ``∂F/∂p · dp + ∂F/∂v · dv`` of the elements' force."""
    geometry = constants.geometry
    state = element_state(constants, positions, velocities)
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
    return geometry.scatter(columns(geometry, d_piola), len(positions))


def element_state_vjp(constants: ElementConstants, positions, velocities, cotangent):
    """``((∂F/∂p)ᵀ λ, (∂F/∂v)ᵀ λ)`` of the elements' force, each (n_nodes, 3)."""
    geometry = constants.geometry
    state = element_state(constants, positions, velocities)
    B = geometry.inverse_rest
    # cotangent of [f1 f2 f3] (columns): λ_{n_j} - λ_{n_0}
    bar_piola = -geometry.volume[:, None, None] * (geometry.edges(cotangent) @ B)
    bar_stress = _sym(np.swapaxes(state.F, 1, 2) @ bar_piola)
    bar_green, bar_green_rate, bar_pressure, bar_pressure_rate = state.at.vjp(bar_stress)
    # π and π̇ through the volumetric strains θ(G) and θ̇ = tr Ġ
    bar_theta = constants.pressure_transpose(bar_pressure)[0]
    bar_theta_rate = constants.pressure_transpose(bar_pressure_rate)[1]
    bar_green = bar_green + bar_theta[:, None, None] * state.at.N
    bar_green_rate = bar_green_rate + bar_theta_rate[:, None, None] * np.eye(3)
    F, F_rate = state.F, state.F_rate
    bar_F = bar_piola @ state.stress + F @ bar_green + F_rate @ bar_green_rate
    bar_F_rate = F @ bar_green_rate
    # the adjoint of ``edges`` is ``scatter``: column j to node j+1, minus the sum to node 0
    n_nodes = len(positions)
    return (geometry.scatter(bar_F @ np.swapaxes(B, 1, 2), n_nodes),
            geometry.scatter(bar_F_rate @ np.swapaxes(B, 1, 2), n_nodes))


def element_rest_matrices(constants: ElementConstants):
    """``(K, C)``: ``-∂f/∂x`` and ``-∂f/∂v`` at rest, assembled (3N, 3N): the shear part
    element by element, the volumetric part ``Dᵀ W D`` from the rest divergence ``D`` (and,
    for the nodal form, its node averages)."""
    geometry = constants.geometry
    n_nodes = len(geometry.node_volume)
    rows = (3 * geometry.nodes[:, :, None] + np.arange(3)).reshape(-1, 12)
    # the volumetric strains' rest gradient: per element, or the nodal form's node averages
    divergence = _rest_divergence(geometry, n_nodes)                      # (K, 3N)
    if constants.nodal:
        divergence = (geometry.average @ divergence).tocsr()              # (N, 3N)
    unit = _rest_shear_blocks(geometry)        # the shear blocks of both, per unit shear
    row_index, column_index = np.repeat(rows, 12, axis=1).ravel(), np.tile(rows, (1, 12)).ravel()
    matrices = []
    for shear, lam, node_lam in ((constants.shear, constants.lam, constants.node_lam),
                                 (constants.shear_rate, constants.lam_rate,
                                  constants.node_lam_rate)):
        matrix = sp.csr_matrix(((shear[:, None, None] * unit).ravel(),
                                (row_index, column_index)), shape=(3 * n_nodes, 3 * n_nodes))
        weight = (geometry.node_volume * node_lam if constants.nodal
                  else geometry.volume * lam)
        volumetric = divergence.T @ sp.diags(weight) @ divergence
        matrices.append(sp.csr_matrix(matrix + volumetric))
    return tuple(matrices)


def _rest_divergence(geometry, n_nodes) -> sp.csr_matrix:
    """(K, 3N): ``∂θ_e/∂x`` at rest (``F = I``: the rows of ``B``, node 0 minus their sum)."""
    local = np.concatenate([-geometry.inverse_rest.sum(axis=1, keepdims=True),
                            geometry.inverse_rest], axis=1)                 # (K, 4, 3)
    return geometry.corner_matrix(local, n_nodes).T.tocsr()


def _rest_shear_blocks(geometry) -> np.ndarray:
    """(K, 12, 12): the element stiffness at rest of ``S = G`` (``-∂f/∂x``; times the
    element's shear coefficient for ``S = shear · G``), row ``3a + i`` and column ``3b + j``
    for corner ``a`` along axis ``i`` and corner ``b`` along ``j``.

    With ``g_a`` the gradient of corner ``a``'s shape function (a row of ``B``; corner 0 minus
    their sum) and ``G ≈ sym(∇u)`` at rest, ``f_a = -V S g_a`` gives
    ``V (δᵢⱼ g_a·g_b + g_{b,i} g_{a,j}) / 2``."""
    gradients = np.concatenate([-geometry.inverse_rest.sum(axis=1, keepdims=True),
                                geometry.inverse_rest], axis=1)             # (K, 4, 3)
    half = 0.5 * geometry.volume[:, None, None]
    blocks = np.einsum("kbi,kaj->kaibj", half * gradients, gradients)
    blocks += (np.einsum("kai,kbi->kab", half * gradients, gradients)[:, :, None, :, None]
               * np.eye(3)[:, None, :])
    return blocks.reshape(len(gradients), 12, 12)
