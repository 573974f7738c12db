"""Spring forces and their derivatives (paper eqs. 3.4–3.6), shared by the simulator, the
effects and the learners.

Every force here is *central*: a magnitude ``m(l, c)`` along the spring's unit vector ``u``,
with ``l = |d|``, ``d = p_b - p_a`` and closing speed ``c = (v_b - v_a)·u``. The spring itself
has ``m = s (l - L0) + c_s c``. :func:`central_jvp` and :func:`central_vjp` give the exact
forward and reverse derivatives of ``f = m u`` for any such magnitude, given ``m``,
``∂m/∂l`` and ``∂m/∂c``::

    df = (m_l u·dd + m_c (dv·du + u·ddv)) u + m du,    du = (I - u uᵀ) dd / l
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["SpringTerms", "spring_terms", "accumulate", "accumulate_many", "spring_forces",
           "central_jvp", "central_vjp"]


@dataclass(frozen=True)
class SpringTerms:
    """Per-spring quantities of one state, shared by forces and learners.

    Attributes
    ----------
    length : (n_springs,) float
        Current length ``l``.
    direction : (n_springs, 3) float
        Unit vector ``u`` from node a to node b.
    stretch : (n_springs,) float
        ``l - L0``.
    closing_speed : (n_springs,) float
        ``(v_b - v_a) · u`` (positive when the spring lengthens).
    relative_velocity : (n_springs, 3) float
        ``v_b - v_a``.
    """

    length: np.ndarray
    direction: np.ndarray
    stretch: np.ndarray
    closing_speed: np.ndarray
    relative_velocity: np.ndarray


def spring_terms(model, positions: np.ndarray,
                 velocities: np.ndarray) -> SpringTerms:
    """Lengths, directions, stretches and closing speeds of all springs (eqs. 3.5, 3.6)."""
    a, b = model.mesh.springs.T
    d = np.take(positions, b, axis=0) - np.take(positions, a, axis=0)
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    direction = d / length[:, None]
    relative_velocity = np.take(velocities, b, axis=0) - np.take(velocities, a, axis=0)
    return SpringTerms(length=length, direction=direction,
                       stretch=length - model.spring_rest_length,
                       closing_speed=np.einsum("ij,ij->i", relative_velocity, direction),
                       relative_velocity=relative_velocity)


def accumulate(springs: np.ndarray, spring_force: np.ndarray, n_nodes: int) -> np.ndarray:
    """(n_nodes, 3) net force: node a of each spring gets ``+f``, node b gets ``-f``."""
    out = np.empty((n_nodes, 3))
    a, b = springs.T
    for axis in range(3):
        out[:, axis] = (np.bincount(a, spring_force[:, axis], n_nodes)
                        - np.bincount(b, spring_force[:, axis], n_nodes))
    return out


def accumulate_many(springs: np.ndarray, spring_force: np.ndarray, n_nodes: int) -> np.ndarray:
    """(n_nodes, P, 3) from (n_springs, P, 3): :func:`accumulate` for P vectors per spring."""
    n_springs, n_batch, _ = spring_force.shape
    a, b = springs.T
    rows = np.arange(n_springs)
    ones = np.ones(n_springs)
    incidence = sp.csr_matrix((np.r_[ones, -ones], (np.r_[a, b], np.r_[rows, rows])),
                              shape=(n_nodes, n_springs))
    return (incidence @ spring_force.reshape(n_springs, n_batch * 3)).reshape(n_nodes, n_batch, 3)


def spring_forces(model, positions: np.ndarray,
                  velocities: np.ndarray) -> np.ndarray:
    """(n_nodes, 3) net spring force on every node (eq. 3.4 summed as in eq. 3.3)."""
    terms = spring_terms(model, positions, velocities)
    magnitude = (model.spring_stiffness * terms.stretch
                 + model.spring_damping * terms.closing_speed)
    return accumulate(model.mesh.springs, terms.direction * magnitude[:, None], model.n_nodes)


def central_jvp(terms: SpringTerms, magnitude, d_length, d_closing, dd, ddv) -> np.ndarray:
    """Forward derivative of ``f = m u`` per spring.

    Parameters
    ----------
    terms : SpringTerms
    magnitude, d_length, d_closing : (n_springs,) float
        ``m``, ``∂m/∂l`` and ``∂m/∂c``.
    dd, ddv : (n_springs, P, 3) float
        Tangents of ``d = p_b - p_a`` and ``v_b - v_a`` for P directions.

    Returns
    -------
    (n_springs, P, 3) float
    """
    u = terms.direction[:, None, :]
    along = np.einsum("spk,sk->sp", dd, terms.direction)
    du = (dd - along[..., None] * u) / terms.length[:, None, None]
    scalar = d_length[:, None] * along
    if d_closing is not None:
        scalar = scalar + d_closing[:, None] * (
            np.einsum("spk,sk->sp", ddv, terms.direction)
            + np.einsum("spk,sk->sp", du, terms.relative_velocity))
    return scalar[..., None] * u + magnitude[:, None, None] * du


def central_vjp(terms: SpringTerms, magnitude, d_length, d_closing, cotangent):
    """Reverse derivative of ``f = m u``: cotangent (n_springs, 3) → ``(λ_d, λ_dv)``."""
    u = terms.direction
    along = np.einsum("ij,ij->i", u, cotangent)
    project = cotangent - along[:, None] * u                     # (I - u uᵀ) λ
    lam_d = (d_length * along)[:, None] * u + (magnitude / terms.length)[:, None] * project
    lam_dv = np.zeros_like(cotangent)
    if d_closing is not None:
        dv = terms.relative_velocity
        dv_perp = dv - np.einsum("ij,ij->i", dv, u)[:, None] * u
        lam_d += (d_closing * along / terms.length)[:, None] * dv_perp
        lam_dv = (d_closing * along)[:, None] * u
    return lam_d, lam_dv
