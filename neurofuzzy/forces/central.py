"""The derivatives of a central force ``f = m u`` (a magnitude ``m(l, c)`` along the unit
vector ``u`` between two nodes: a spring, a spring effect) and the stiffness a set of springs
has at rest (:func:`projected_laplacian`).

    df = (m_l u·dd + m_c (dv·du + u·ddv)) u + m du,    du = (I - u uᵀ) dd / l
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["central_jvp", "central_vjp", "projected_laplacian"]


def projected_laplacian(springs: np.ndarray, direction: np.ndarray, constants: np.ndarray,
                        n_nodes: int) -> sp.csr_matrix:
    """Assemble ``Σ_j k_j (e_a - e_b)(e_a - e_b)ᵀ ⊗ u_j u_jᵀ`` as a (3N, 3N) sparse matrix."""
    block = constants[:, None, None] * direction[:, :, None] * direction[:, None, :]
    a, b = springs.T
    rows, cols, data = [], [], []
    for first, second, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
        r = (3 * first[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
        c = (3 * second[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
        rows.append(r.ravel())
        cols.append(c.ravel())
        data.append(sign * block.ravel())
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(3 * n_nodes, 3 * n_nodes))


def central_jvp(state, magnitude, d_length, d_closing, dd, ddv) -> np.ndarray:
    """Forward derivative of ``f = m u`` per spring.

    Parameters
    ----------
    state : SpringState
    magnitude, d_length, d_closing : (n_springs,) float
        ``m``, ``∂m/∂l`` and ``∂m/∂c`` (``d_closing`` None for position-only forces).
    dd, ddv : (n_springs, P, 3) float
        Tangents of ``d = p_b - p_a`` and ``v_b - v_a`` for P directions.

    Returns
    -------
    (n_springs, P, 3) float
    """
    direction = state.direction
    u = direction[:, None, :]
    along = np.einsum("spk,sk->sp", dd, direction)
    du = (dd - along[..., None] * u) / state.length[:, None, None]
    scalar = d_length[:, None] * along
    if d_closing is not None:
        scalar = scalar + d_closing[:, None] * (
            np.einsum("spk,sk->sp", ddv, direction)
            + np.einsum("spk,sk->sp", du, state.relative_velocity))
    return scalar[..., None] * u + magnitude[:, None, None] * du


def central_vjp(state, magnitude, d_length, d_closing, cotangent):
    """Reverse derivative of ``f = m u``: cotangent (n_springs, 3) → ``(λ_d, λ_dv)``."""
    u = state.direction
    along = np.einsum("ij,ij->i", u, cotangent)
    project = cotangent - along[:, None] * u                     # (I - u uᵀ) λ
    bar_d = (d_length * along)[:, None] * u + (magnitude / state.length)[:, None] * project
    bar_dv = np.zeros_like(cotangent)
    if d_closing is not None:
        dv = state.relative_velocity
        dv_perp = dv - np.einsum("ij,ij->i", dv, u)[:, None] * u
        bar_d += (d_closing * along / state.length)[:, None] * dv_perp
        bar_dv = (d_closing * along)[:, None] * u
    return bar_d, bar_dv
