"""Compiled discrete adjoint (numba) of :meth:`neurofuzzy.learn.Sensitivity.gradient` for
spring models: two calls per experiment, no Python per time step.

:func:`sweep` runs semi-implicit Euler over the frames and keeps the state at the start of
every substep; :func:`pull_back` runs the adjoint backwards over those states and sums, per
spring, ``λ · ∂F/∂s_j`` and ``λ · ∂F/∂c_j`` (the caller multiplies by the constants and sums
per tie group: the gradient by ``log s`` and ``log c``). The arithmetic is that of the numpy
reference path (:meth:`neurofuzzy.forces.SpringForce.vjp`, :func:`~neurofuzzy.forces.springs.
central_vjp`; tested equal): springs ``f = (s (l - L0) + c ((v_b - v_a)·u)) u``, a node drag
``-drag v`` and constant loads.

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from ._numba_kernels import _spring


@numba.njit(cache=True, nogil=True)
def sweep(a, b, stiffness, damping, rest, drag, weight, loads, h, n_frames, substeps,
          start_index, start_p, start_v, positions, states_p, states_v):
    """Positions (n_frames, N, 3) and the state at the start of every substep
    (``states_p``, ``states_v``: ((n_frames - 1) · substeps, N, 3), in time order; the
    substeps of a window's first frame are left unset)."""
    n_nodes = start_p.shape[1]
    p = start_p[0].copy()
    v = start_v[0].copy()
    force = np.empty((n_nodes, 3))
    step = 0
    for t in range(n_frames):
        if start_index[t] >= 0:
            p[:] = start_p[start_index[t]]
            v[:] = start_v[start_index[t]]
            positions[t] = p
            if t > 0:
                step += substeps
            continue
        load = loads[min(t - 1, loads.shape[0] - 1)]
        for _ in range(substeps):
            states_p[step] = p
            states_v[step] = v
            step += 1
            for i in range(n_nodes):
                for k in range(3):
                    force[i, k] = load[i, k] - drag * v[i, k]
            for j in range(a.shape[0]):
                _spring(p, v, a[j], b[j], stiffness[j], damping[j], rest[j], force)
            for i in range(n_nodes):
                w = h * weight[i]
                for k in range(3):
                    v[i, k] += w * force[i, k]
                    p[i, k] += h * v[i, k]
        positions[t] = p


@numba.njit(cache=True, nogil=True)
def pull_back(a, b, stiffness, damping, rest, drag, weight, h, n_frames, substeps,
              start_index, states_p, states_v, frame_adjoint, d_stiffness, d_damping):
    """The backward sweep: ``frame_adjoint[t]`` (n_frames, N, 3) is ``∂L/∂p(t)``; adds
    ``Σ λ_F · ∂F/∂s_j`` to ``d_stiffness[j]`` and ``Σ λ_F · ∂F/∂c_j`` to ``d_damping[j]``
    over every substep (``λ_F = h W λ_v'``, the cotangent of the step's force)."""
    n_nodes = frame_adjoint.shape[1]
    lam_p = np.zeros((n_nodes, 3))
    lam_v = np.zeros((n_nodes, 3))
    lam_force = np.empty((n_nodes, 3))
    d_p = np.empty((n_nodes, 3))
    d_v = np.empty((n_nodes, 3))
    step = (n_frames - 1) * substeps
    for t in range(n_frames - 1, 0, -1):
        if start_index[t] >= 0:
            lam_p[:] = 0.0
            lam_v[:] = 0.0
            step -= substeps
            continue
        for i in range(n_nodes):
            for k in range(3):
                lam_p[i, k] += frame_adjoint[t, i, k]
        for _ in range(substeps):
            step -= 1
            p = states_p[step]
            v = states_v[step]
            # p' = p + h v', v' = v + h W F: the new velocity's cotangent, then the force's
            for i in range(n_nodes):
                for k in range(3):
                    lam_v[i, k] += h * lam_p[i, k]
                    if weight[i] == 0.0:          # fixed nodes do not move
                        lam_v[i, k] = 0.0
                    lam_force[i, k] = h * weight[i] * lam_v[i, k]
                    d_p[i, k] = 0.0
                    d_v[i, k] = -drag * lam_force[i, k]
            for j in range(a.shape[0]):
                ia, ib = a[j], b[j]
                dx = p[ib, 0] - p[ia, 0]
                dy = p[ib, 1] - p[ia, 1]
                dz = p[ib, 2] - p[ia, 2]
                length = np.sqrt(dx * dx + dy * dy + dz * dz)
                ux, uy, uz = dx / length, dy / length, dz / length
                wx = v[ib, 0] - v[ia, 0]
                wy = v[ib, 1] - v[ia, 1]
                wz = v[ib, 2] - v[ia, 2]
                closing = wx * ux + wy * uy + wz * uz
                stretch = length - rest[j]
                magnitude = stiffness[j] * stretch + damping[j] * closing
                # node a gets +f, node b -f: the cotangent of f is λ_a - λ_b
                fx = lam_force[ia, 0] - lam_force[ib, 0]
                fy = lam_force[ia, 1] - lam_force[ib, 1]
                fz = lam_force[ia, 2] - lam_force[ib, 2]
                along = ux * fx + uy * fy + uz * fz
                d_stiffness[j] += stretch * along
                d_damping[j] += closing * along
                # central_vjp with ∂m/∂l = s, ∂m/∂c = c
                ratio = magnitude / length
                rate = damping[j] * along / length
                lx = stiffness[j] * along * ux + ratio * (fx - along * ux) \
                    + rate * (wx - closing * ux)
                ly = stiffness[j] * along * uy + ratio * (fy - along * uy) \
                    + rate * (wy - closing * uy)
                lz = stiffness[j] * along * uz + ratio * (fz - along * uz) \
                    + rate * (wz - closing * uz)
                cv = damping[j] * along
                # d = p_b - p_a: node b gets +λ_d, node a -λ_d
                d_p[ia, 0] -= lx
                d_p[ia, 1] -= ly
                d_p[ia, 2] -= lz
                d_p[ib, 0] += lx
                d_p[ib, 1] += ly
                d_p[ib, 2] += lz
                d_v[ia, 0] -= cv * ux
                d_v[ia, 1] -= cv * uy
                d_v[ia, 2] -= cv * uz
                d_v[ib, 0] += cv * ux
                d_v[ib, 1] += cv * uy
                d_v[ib, 2] += cv * uz
            for i in range(n_nodes):
                for k in range(3):
                    lam_p[i, k] += d_p[i, k]
                    lam_v[i, k] += d_v[i, k]
