"""The stability bound of semi-implicit Euler for a model at rest.

For one mode with angular frequency ``ω`` and damping rate ``γ`` the scheme is stable iff
``h² ω² + 2 h γ < 4``. :func:`stability_limit` bounds ``ω²`` and ``γ`` over all modes by the
largest eigenvalues of ``M⁻¹K`` and ``M⁻¹C`` at rest (each term's ``rest_matrices``), and
:func:`~neurofuzzy.simulation.simulate` refuses (or, with ``substeps="auto"``, subdivides) a
step that breaks the bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import UnstableTimeStepError
from ..model import Model

__all__ = ["STABILITY_SAFETY", "StabilityLimit", "stability_limit", "check_time_step",
           "required_substeps"]

#: Fraction of the theoretical stability bound we allow: springs stiffen geometrically when
#: stretched, so a step right at the bound of the rest state can still blow up.
STABILITY_SAFETY = 0.9


@dataclass(frozen=True)
class StabilityLimit:
    """Stability bound of semi-implicit Euler for a model, at rest.

    Attributes
    ----------
    omega_max : float
        Upper bound of the highest natural angular frequency, ``sqrt(λ_max(M⁻¹K))``.
    damping_rate_max : float
        Upper bound of the damping rates, ``λ_max(M⁻¹C)``.
    max_step : float
        Largest stable step ``h`` (solves ``h²ω² + 2hγ = 4``), times ``STABILITY_SAFETY``.
    """

    omega_max: float
    damping_rate_max: float
    max_step: float


def stability_limit(model: Model) -> StabilityLimit:
    """Bound the stiffest mode of ``model`` at rest (see the module docstring)."""
    free = model.mesh.free
    matrices = [term.rest_matrices(model) for term in model.force_terms]
    matrices = [pair for pair in matrices if pair is not None]
    if not free.any() or not matrices:
        return StabilityLimit(0.0, 0.0, np.inf)
    dof_free = np.repeat(free, 3)
    scale = sp.diags(np.repeat(1.0 / np.sqrt(model.node_mass), 3)[dof_free])
    lam = []
    for matrix in (sum(pair[0] for pair in matrices), sum(pair[1] for pair in matrices)):
        matrix = scale @ matrix.tocsr()[dof_free][:, dof_free] @ scale
        lam.append(_largest_eigenvalue(matrix.tocsr()))
    omega2, gamma = lam
    # h² ω² + 2 h γ = 4  →  h = (-γ + sqrt(γ² + 4 ω²)) / ω²
    if omega2 > 0:
        h = (-gamma + np.sqrt(gamma * gamma + 4.0 * omega2)) / omega2
    else:
        h = 2.0 / gamma if gamma > 0 else np.inf
    return StabilityLimit(float(np.sqrt(omega2)), float(gamma), float(STABILITY_SAFETY * h))


def check_time_step(model: Model, dt: float, substeps: int = 1) -> None:
    """Raise :class:`UnstableTimeStepError` if ``dt / substeps`` is above the stable step."""
    limit = stability_limit(model)
    h = dt / substeps
    if h > limit.max_step:
        need = int(np.ceil(dt / limit.max_step))
        raise UnstableTimeStepError(
            f"time step {h:.4g} is unstable for this model: the stiffest mode "
            f"(ω = {limit.omega_max:.4g} rad per time unit, damping rate "
            f"{limit.damping_rate_max:.4g}) needs a step <= {limit.max_step:.4g}; use "
            f"substeps >= {need} (or 'auto'), a smaller dt, or softer springs / heavier nodes")


def required_substeps(model: Model, dt: float) -> int:
    """Fewest integration steps per frame of length ``dt`` that are stable."""
    limit = stability_limit(model)
    return max(1, int(np.ceil(dt / limit.max_step)))


def _largest_eigenvalue(matrix: sp.csr_matrix) -> float:
    """Largest eigenvalue of a symmetric positive semi-definite sparse matrix."""
    n = matrix.shape[0]
    if n <= 600:
        return float(np.linalg.eigvalsh(matrix.toarray())[-1])
    # Gershgorin bound as a safe fallback; eigsh when it converges.
    gershgorin = float(np.max(np.asarray(abs(matrix).sum(axis=1)).ravel()))
    try:
        value = spla.eigsh(matrix, k=1, which="LA", return_eigenvectors=False, tol=1e-4,
                           maxiter=5000, v0=np.ones(n))[0]
        return float(min(value * (1 + 1e-3), gershgorin))
    except spla.ArpackNoConvergence:
        return gershgorin
