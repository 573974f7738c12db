"""Pieces of :mod:`.load_step_fit` that know no model: each scan's rigid registration
(Kabsch's closed form) and what it leaves of the markers' derivatives, the markers' RMS error
over some steps, and the noise estimated from the residuals."""

from __future__ import annotations

import numpy as np

__all__ = ["kabsch", "beyond_rigid", "marker_rms", "residual_noise"]


def kabsch(measured, model):
    """The rigid transform ``(R, t)`` moving ``measured`` (n, 3) closest onto ``model``."""
    a0, b0 = measured.mean(axis=0), model.mean(axis=0)
    u, _, vt = np.linalg.svd((measured - a0).T @ (model - b0))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return R, b0 - R @ a0


def beyond_rigid(points, change):
    """``change`` (..., n, 3), a change of the markers at ``points`` (n, 3), less its rigid
    part (the least-squares translation and small rotation of ``points``).

    A scan registered onto the model's markers by :func:`kabsch` follows any rigid motion of
    them, so its residual's derivative by a material parameter is the markers' derivative
    with its rigid part taken out (the variable projection's Jacobian, Kaufman's form).
    Without it the fit alternated between the material and the registration and converged
    linearly: on the deep indentation with 20 markers, ν crept 0.0005 an iteration at the
    30th; with it, five iterations."""
    arm = points - points.mean(axis=0)
    n = len(points)
    basis = np.zeros((n, 3, 6))
    for a in range(3):
        basis[:, a, a] = 1.0                               # translations
        basis[:, :, 3 + a] = np.cross(np.eye(3)[a], arm)   # small rotations about the centre
    q, _ = np.linalg.qr(basis.reshape(3 * n, 6))
    flat = change.reshape(-1, 3 * n)
    return (flat - (flat @ q) @ q.T).reshape(change.shape)


def marker_rms(moved, seen, steps):
    """Root mean square of the marker misfit per marker (m) over ``steps``."""
    values = np.concatenate([np.sum(moved[s - 1][seen[s - 1]] ** 2, axis=-1) for s in steps])
    return float(np.sqrt(values.mean()))


def residual_noise(moved, reference, seen, fitted, reactions, reaction, sigma_m, sigma_f, given_m,
           given_f, register, n_parameters):
    """The markers' and the load cell's noise from the residuals (per coordinate, with the
    degrees of freedom the fit used: the material's, per scan the registration's six, and
    per marker its rest position's three when the reference scan's ``reference`` residual
    is fitted too)."""
    count = sum(int(seen[s - 1].sum()) * 3 for s in fitted)
    blocks = 1 + (reaction is not None)
    used = n_parameters / blocks + (6 * len(fitted) if register else 0)
    squares = 0.0
    if reference is not None:
        count, used = count + reference.size, used + reference.size
        squares = float(np.sum(reference**2))
    if given_m is None and count:
        squares += sum(float(np.sum(moved[s - 1][seen[s - 1]] ** 2)) for s in fitted)
        sigma_m = np.sqrt(squares / max(count - used, 1))
    if reaction is not None and given_f is None:
        rows = [s - 1 for s in fitted]
        squares = float(np.sum((reaction[rows] - reactions[rows]) ** 2))
        sigma_f = max(np.sqrt(squares / max(3 * len(rows) - n_parameters / blocks, 1)),
                      1e-9 * np.abs(reaction).max())
    return sigma_m, sigma_f
