"""The reference scan is as noisy as the others: each marker's rest position a nuisance
parameter of a load-step fit.

Markers are embedded in the mesh where the reference scan (step 0) saw them, so its noise
moves every marker's rest point; a fit that takes step 0 as exact compares each later scan
with a prediction from a displaced point, and its residuals carry the noise twice (√2 σ
where σ is each scan's noise, even for a perfect model). Here each marker's rest position
is estimated from all the scans (errors in variables): the rest point moves by δ, the
prediction at step ``s`` by ``F_s δ`` (``F_s`` the deformation gradient of the marker's
tetrahedron there), and δ minimises ``|r_0 − δ|² + Σ_s |r_s − F_s δ|²`` in closed form per
marker (3 × 3; ``r_0``, the reference scan's own residual, is zero for markers embedded where
it saw them). The residuals handed to the fit are the projected ones, ``r_0 − δ`` for the
reference and ``r_s − F_s δ`` for each scan; their derivatives by the material parameters are
projected the same way (Kaufman's variable projection, which drops the small change of
``F_s`` itself). A perfect model then leaves residuals of ``σ √(S / (S + 1))`` per
coordinate over the S + 1 scans; a held-out scan is predicted to ``σ √(1 + 1 / (S + 1))``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MarkerGradients", "project"]


class MarkerGradients:
    """The deformation gradient of each marker's tetrahedron, from the nodes' positions."""

    def __init__(self, rest_positions: np.ndarray, nodes: np.ndarray):
        corners = rest_positions[nodes]                                   # (n, 4, 3)
        edges = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))
        scale = np.abs(edges).max(axis=(1, 2)) ** 3
        # a marker glued to one node (its four corners the same) moves with it: F = I
        self._glued = ~(np.abs(np.linalg.det(edges)) > 1e-9 * scale)
        edges[self._glued] = np.eye(3)
        inverse = np.linalg.inv(edges)                  # row k: the gradient of λ_(k+1)
        self._grads = np.concatenate([-inverse.sum(axis=1, keepdims=True), inverse], axis=1)
        self._nodes = nodes

    def at(self, positions: np.ndarray) -> np.ndarray:
        """(n_markers, 3, 3): ``F = Σ_a x_a ⊗ ∇λ_a`` at node positions (n_nodes, 3)."""
        F = np.einsum("nai,naj->nij", positions[self._nodes], self._grads)
        F[self._glued] = np.eye(3)
        return F


def project(reference, moved, gradients, seen, rows, derivatives=None):
    """The residuals with each marker's rest position estimated (module docstring).

    Parameters
    ----------
    reference : (n_markers, 3)
        The reference scan minus the markers' embedded rest points (zero where a marker was
        embedded where the reference scan saw it).
    moved : (n_steps, n_markers, 3)
        Measured minus predicted marker positions at steps 1..n_steps (NaN where unseen).
    gradients : (n_steps, n_markers, 3, 3)
        ``F_s`` of each marker at each step.
    seen : (n_steps, n_markers) bool
    rows : sequence of int
        The (1-based) steps that estimate the rest positions: the fitted ones.
    derivatives : (n_steps, n_parameters, n_markers, 3), optional
        ∂moved/∂θ.

    Returns
    -------
    reference : (n_markers, 3)
        The reference scan's residual, ``r_0 − δ``.
    moved : (n_steps, n_markers, 3)
        ``r_s − F_s δ`` at every step (held-out steps too: their prediction from the
        estimated rest points).
    d_reference, d_moved : arrays or None
        Their derivatives by θ, shaped as ``derivatives`` (without the step axis for the
        reference).
    """
    F = np.asarray(gradients)
    seen = seen[:len(F)]                       # the steps solved (up to the last one asked)
    weight = np.zeros(seen.shape)
    weight[[s - 1 for s in rows]] = seen[[s - 1 for s in rows]]
    r = np.where(seen[..., None], moved, 0.0)
    M = np.eye(3) + np.einsum("sn,snki,snkj->nij", weight, F, F)
    M_inv = np.linalg.inv(M)
    r_0 = np.nan_to_num(reference)
    delta = np.einsum("nij,nj->ni", M_inv, r_0 + np.einsum("sn,snkj,snk->nj", weight, F, r))
    out = moved - np.einsum("snij,nj->sni", F, delta)
    if derivatives is None:
        return r_0 - delta, out, None, None
    d = np.where(seen[:, None, :, None], derivatives, 0.0)
    d_delta = np.einsum("nij,sn,snkj,spnk->pni", M_inv, weight, F, d)
    d_out = derivatives - np.einsum("snij,pnj->spni", F, d_delta)
    return r_0 - delta, out, -d_delta, d_out
