"""Compiled inner loops (numba) of :class:`neurofuzzy._steppers.NumbaStepper`.

Imported only when numba is installed; module-level so that ``cache=True`` keeps the machine
code between runs.
"""

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def advance(p, v, a, b, stiffness, damping, rest, weight, load, h, n_steps, force):
    n_springs, n_nodes = a.shape[0], p.shape[0]
    for _ in range(n_steps):
        for i in range(n_nodes):
            for k in range(3):
                force[i, k] = load[i, k]
        for j in range(n_springs):
            ia, ib = a[j], b[j]
            dx = p[ib, 0] - p[ia, 0]
            dy = p[ib, 1] - p[ia, 1]
            dz = p[ib, 2] - p[ia, 2]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            ux, uy, uz = dx / length, dy / length, dz / length
            closing = ((v[ib, 0] - v[ia, 0]) * ux + (v[ib, 1] - v[ia, 1]) * uy
                       + (v[ib, 2] - v[ia, 2]) * uz)
            magnitude = stiffness[j] * (length - rest[j]) + damping[j] * closing
            fx, fy, fz = magnitude * ux, magnitude * uy, magnitude * uz
            force[ia, 0] += fx
            force[ia, 1] += fy
            force[ia, 2] += fz
            force[ib, 0] -= fx
            force[ib, 1] -= fy
            force[ib, 2] -= fz
        for i in range(n_nodes):
            step = h * weight[i]
            for k in range(3):
                v[i, k] += step * force[i, k]
                p[i, k] += h * v[i, k]

@numba.njit(cache=True, nogil=True)
def frames(p, v, a, b, stiffness, damping, rest, weight, loads, h, n_frames, substeps,
           force, positions, velocities):
    positions[0] = p
    velocities[0] = v
    for t in range(1, n_frames):
        advance(p, v, a, b, stiffness, damping, rest, weight,
                loads[min(t - 1, loads.shape[0] - 1)], h, substeps, force)
        if not np.isfinite(p.sum()):
            positions[t:] = np.nan
            velocities[t:] = np.nan
            return
        positions[t] = p
        velocities[t] = v
