"""Compiled inner loops (numba) of :class:`neurofuzzy._steppers.NumbaStepper`.

Imported only when numba is installed; module-level so that ``cache=True`` keeps the machine
code between runs. The arithmetic is that of :class:`neurofuzzy.forces.SpringForce` and
:class:`neurofuzzy.forces.TetrahedronForce` (tested equal); the elements' stress is written
``S = π I + 2 μ X`` with ``X = G + (η/E) Ġ`` and ``π = λ tr X`` (per element) or the mean of
the node-averaged ``Λ θ̄ + H θ̄̇`` over the element's corners (nodal volumetric form).
"""

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _deformation(p, v, n0, n1, n2, n3, B, F, Fd):
    """F = Ds B and Ḟ = Ḋs B (Ds columns: x1 - x0, x2 - x0, x3 - x0)."""
    for r in range(3):
        d1 = p[n1, r] - p[n0, r]
        d2 = p[n2, r] - p[n0, r]
        d3 = p[n3, r] - p[n0, r]
        w1 = v[n1, r] - v[n0, r]
        w2 = v[n2, r] - v[n0, r]
        w3 = v[n3, r] - v[n0, r]
        for c in range(3):
            F[r, c] = d1 * B[0, c] + d2 * B[1, c] + d3 * B[2, c]
            Fd[r, c] = w1 * B[0, c] + w2 * B[1, c] + w3 * B[2, c]


@numba.njit(cache=True, nogil=True)
def _spring(p, v, ia, ib, stiffness, damping, rest, force):
    """One spring's force ``(s (l - L0) + c closing) u`` added to ``force`` (node a +,
    node b -); returns ``(ux, uy, uz, length, closing, stretch, magnitude)``."""
    dx = p[ib, 0] - p[ia, 0]
    dy = p[ib, 1] - p[ia, 1]
    dz = p[ib, 2] - p[ia, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    closing = ((v[ib, 0] - v[ia, 0]) * ux + (v[ib, 1] - v[ia, 1]) * uy
               + (v[ib, 2] - v[ia, 2]) * uz)
    stretch = length - rest
    magnitude = stiffness * stretch + damping * closing
    fx, fy, fz = magnitude * ux, magnitude * uy, magnitude * uz
    force[ia, 0] += fx
    force[ia, 1] += fy
    force[ia, 2] += fz
    force[ib, 0] -= fx
    force[ib, 1] -= fy
    force[ib, 2] -= fz
    return ux, uy, uz, length, closing, stretch, magnitude


@numba.njit(cache=True, nogil=True)
def _scatter_piola(force, F, S, B, scale, n0, n1, n2, n3):
    """``P = F S``; node j + 1 gets column j of ``scale P Bᵀ`` (``scale = -V``), node 0 minus
    their sum."""
    for r in range(3):
        P0 = F[r, 0] * S[0, 0] + F[r, 1] * S[1, 0] + F[r, 2] * S[2, 0]
        P1 = F[r, 0] * S[0, 1] + F[r, 1] * S[1, 1] + F[r, 2] * S[2, 1]
        P2 = F[r, 0] * S[0, 2] + F[r, 1] * S[1, 2] + F[r, 2] * S[2, 2]
        f1 = scale * (P0 * B[0, 0] + P1 * B[0, 1] + P2 * B[0, 2])
        f2 = scale * (P0 * B[1, 0] + P1 * B[1, 1] + P2 * B[1, 2])
        f3 = scale * (P0 * B[2, 0] + P1 * B[2, 1] + P2 * B[2, 2])
        force[n1, r] += f1
        force[n2, r] += f2
        force[n3, r] += f3
        force[n0, r] -= f1 + f2 + f3


@numba.njit(cache=True, nogil=True)
def _element_forces(p, v, tets, inverse_rest, volume, lam, mu, ratio, nodal, node_volume,
                    node_lam, node_lam_rate, node_strain, force):
    """Element forces into ``force``; with ``nodal`` the volumetric stress comes from the
    node averages of ``θ`` and ``θ̇`` (one pass for the averages, one for the forces)."""
    F = np.empty((3, 3))
    Fd = np.empty((3, 3))
    X = np.empty((3, 3))
    S = np.empty((3, 3))
    n_elements = tets.shape[0]
    if nodal:
        node_strain[:] = 0.0
        for e in range(n_elements):
            n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
            _deformation(p, v, n0, n1, n2, n3, inverse_rest[e], F, Fd)
            theta = 0.0
            theta_rate = 0.0
            for r in range(3):
                for c in range(3):
                    theta += F[r, c] * F[r, c]
                    theta_rate += F[r, c] * Fd[r, c]
            theta = 0.5 * theta - 1.5                  # tr G = ½ (|F|² - 3)
            corner = 0.25 * volume[e]
            for j in range(4):
                node_strain[tets[e, j], 0] += corner * theta
                node_strain[tets[e, j], 1] += corner * theta_rate
        for i in range(node_strain.shape[0]):
            if node_volume[i] > 0.0:
                node_strain[i, 0] = (node_lam[i] * node_strain[i, 0]
                                     + node_lam_rate[i] * node_strain[i, 1]) / node_volume[i]
    for e in range(n_elements):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        _deformation(p, v, n0, n1, n2, n3, B, F, Fd)
        # X = G + (η/E) Ġ with G = ½(FᵀF - I), Ġ = sym(FᵀḞ)
        for i in range(3):
            for k in range(i, 3):
                ff = F[0, i] * F[0, k] + F[1, i] * F[1, k] + F[2, i] * F[2, k]
                fd = (F[0, i] * Fd[0, k] + F[1, i] * Fd[1, k] + F[2, i] * Fd[2, k]
                      + Fd[0, i] * F[0, k] + Fd[1, i] * F[1, k] + Fd[2, i] * F[2, k])
                x = 0.5 * ff + 0.5 * ratio[e] * fd
                if i == k:
                    x -= 0.5
                X[i, k] = x
                X[k, i] = x
        if nodal:
            pressure = 0.25 * (node_strain[n0, 0] + node_strain[n1, 0] + node_strain[n2, 0]
                               + node_strain[n3, 0])
        else:
            pressure = lam[e] * (X[0, 0] + X[1, 1] + X[2, 2])
        for i in range(3):
            for k in range(3):
                S[i, k] = 2.0 * mu[e] * X[i, k]
            S[i, i] += pressure
        _scatter_piola(force, F, S, B, -volume[e], n0, n1, n2, n3)


@numba.njit(cache=True, nogil=True)
def advance(p, v, a, b, stiffness, damping, rest, tets, inverse_rest, volume, lam, mu, ratio,
            nodal, node_volume, node_lam, node_lam_rate, node_strain, weight, load, h,
            n_steps, force):
    n_springs, n_nodes = a.shape[0], p.shape[0]
    for _ in range(n_steps):
        for i in range(n_nodes):
            for k in range(3):
                force[i, k] = load[i, k]
        for j in range(n_springs):
            _spring(p, v, a[j], b[j], stiffness[j], damping[j], rest[j], force)
        if tets.shape[0]:
            _element_forces(p, v, tets, inverse_rest, volume, lam, mu, ratio, nodal,
                            node_volume, node_lam, node_lam_rate, node_strain, force)
        for i in range(n_nodes):
            step = h * weight[i]
            for k in range(3):
                v[i, k] += step * force[i, k]
                p[i, k] += h * v[i, k]


@numba.njit(cache=True, nogil=True)
def frames(p, v, a, b, stiffness, damping, rest, tets, inverse_rest, volume, lam, mu, ratio,
           nodal, node_volume, node_lam, node_lam_rate, node_strain, weight, loads, h,
           n_frames, substeps, force, positions, velocities):
    positions[0] = p
    velocities[0] = v
    for t in range(1, n_frames):
        advance(p, v, a, b, stiffness, damping, rest, tets, inverse_rest, volume, lam, mu,
                ratio, nodal, node_volume, node_lam, node_lam_rate, node_strain, weight,
                loads[min(t - 1, loads.shape[0] - 1)], h, substeps, force)
        if not np.isfinite(p.sum()):
            positions[t:] = np.nan
            velocities[t:] = np.nan
            return
        positions[t] = p
        velocities[t] = v
