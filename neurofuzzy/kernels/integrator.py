"""The semi-implicit Euler update of every compiled sweep, written once (paper eqs. 3.1–3.3).

One step of length ``h`` with the forces ``F`` evaluated at the start of the step::

    v' = v + h W F,    p' = p + h v'                (W = 1/m, zero at fixed nodes)

:func:`euler_update` is that update for node-major arrays of any width: the state
(``(n_nodes, 3)``: the stepper of :mod:`neurofuzzy.kernels.stepper`, the forward sweeps of
:mod:`neurofuzzy.kernels.sensitivity` and :mod:`neurofuzzy.kernels.adjoint`) and, because the
update is linear, its tangents (``(n_nodes, 3 P)``: ``tv' = tv + h W dF``, ``tp' = tp + h tv'``,
the forward sensitivities). :func:`euler_update_transpose` is its adjoint, the backward sweep
of :mod:`neurofuzzy.kernels.adjoint`. The numpy paths call the same update over their arrays
through :func:`neurofuzzy.simulation.euler_update`.
"""

import numba


@numba.njit(cache=True, nogil=True)
def euler_update(p, v, force, weight, h):
    """In place: ``v += h W force``, then ``p += h v`` (eqs. 3.2, 3.1).

    Parameters
    ----------
    p, v : (n_nodes, m) float
        Positions and velocities (``m = 3``) or their tangents (``m = 3 P``), node-major.
    force : (n_nodes, m) float
        The force (or its tangent) at the start of the step.
    weight : (n_nodes,) float
        ``W = 1/m``, zero at fixed nodes.
    h : float
        Step length (s).
    """
    if p.shape[1] == 3:        # the state: its width a constant, the loop unrolled (3 % of
        _update(p, v, force, weight, h, 3)          # the 86-spring cube's step rate)
    else:
        _update(p, v, force, weight, h, p.shape[1])


@numba.njit(cache=True, nogil=True)
def _update(p, v, force, weight, h, width):
    """:func:`euler_update` of ``width`` columns."""
    for i in range(p.shape[0]):
        step = h * weight[i]
        for k in range(width):
            v[i, k] += step * force[i, k]
            p[i, k] += h * v[i, k]


@numba.njit(cache=True, nogil=True)
def euler_update_transpose(lam_p, lam_v, weight, h, lam_force):
    """The adjoint of :func:`euler_update`, in place: with ``λ_p``, ``λ_v`` the cotangents of
    ``p'``, ``v'``, ``λ_v ← λ_v + h λ_p`` (zero at fixed nodes, which never move) is the
    cotangent of ``v'`` and ``λ_F = h W λ_v`` that of the step's force (written into
    ``lam_force``). ``λ_p`` is unchanged: ``∂p'/∂p = I``; the force's own state derivatives
    are added by the caller."""
    for i in range(lam_p.shape[0]):
        step = h * weight[i]
        for k in range(lam_p.shape[1]):
            lam_v[i, k] += h * lam_p[i, k]
            if weight[i] == 0.0:
                lam_v[i, k] = 0.0
            lam_force[i, k] = step * lam_v[i, k]
