"""Compiled forward sensitivities (numba) of :class:`neurofuzzy.learn.Sensitivity`.

One call runs a whole experiment: every frame and substep of semi-implicit Euler for the
state and its tangents along every parameter direction, with the observation operator
applied at every frame, so no Python runs per time step. The arithmetic is that of the numpy
reference path (:meth:`neurofuzzy.forces.SpringForce.state_jvp`, ``parameter_templates`` and
:meth:`neurofuzzy.forces.TetrahedronForce.state_jvp`, ``parameter_jvp``; tested equal):

- springs ``f = (s (l - L0) + c ((v_b - v_a)·u)) u``, parameters ``log s`` and ``log c`` of
  the spring's tie group (columns ``stiffness_column[j]``, ``damping_column[j]``, -1 when
  not learned);
- tetrahedral elements ``S = 2μ (G + β Ġ) + π I`` (module :mod:`neurofuzzy.forces.tetrahedra`),
  parameters ``log E``, ``logit 2ν`` and ``log η`` of the element's tie group; the volumetric
  ``π`` per element or from the node averages (two passes over the elements).

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from ._numba_kernels import _deformation, _scatter_piola, _spring


@numba.njit(cache=True, nogil=True)
def _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, stiffness_column,
                     damping_column, force, d_force):
    n_params = tp.shape[1]
    for j in range(a.shape[0]):
        ia, ib = a[j], b[j]
        ux, uy, uz, length, closing, stretch, magnitude = _spring(
            p, v, ia, ib, stiffness[j], damping[j], rest[j], force)
        wx = v[ib, 0] - v[ia, 0]
        wy = v[ib, 1] - v[ia, 1]
        wz = v[ib, 2] - v[ia, 2]
        for q in range(n_params):
            ddx = tp[ib, q, 0] - tp[ia, q, 0]
            ddy = tp[ib, q, 1] - tp[ia, q, 1]
            ddz = tp[ib, q, 2] - tp[ia, q, 2]
            dl = ux * ddx + uy * ddy + uz * ddz
            dux = (ddx - ux * dl) / length
            duy = (ddy - uy * dl) / length
            duz = (ddz - uz * dl) / length
            d_closing = ((tv[ib, q, 0] - tv[ia, q, 0]) * ux + (tv[ib, q, 1] - tv[ia, q, 1]) * uy
                         + (tv[ib, q, 2] - tv[ia, q, 2]) * uz
                         + wx * dux + wy * duy + wz * duz)
            dm = stiffness[j] * dl + damping[j] * d_closing
            if q == stiffness_column[j]:
                dm += stiffness[j] * stretch
            if q == damping_column[j]:
                dm += damping[j] * closing
            fx = dm * ux + magnitude * dux
            fy = dm * uy + magnitude * duy
            fz = dm * uz + magnitude * duz
            d_force[ia, q, 0] += fx
            d_force[ia, q, 1] += fy
            d_force[ia, q, 2] += fz
            d_force[ib, q, 0] -= fx
            d_force[ib, q, 1] -= fy
            d_force[ib, q, 2] -= fz


@numba.njit(cache=True, nogil=True)
def _gradients(p, v, tp, tv, n0, n1, n2, n3, B, F, Fd, dF, dFd):
    """F, Ḟ and their tangents dF, dḞ (P, 3, 3) of one element."""
    n_params = tp.shape[1]
    _deformation(p, v, n0, n1, n2, n3, B, F, Fd)
    for r in range(3):
        for q in range(n_params):
            d1 = tp[n1, q, r] - tp[n0, q, r]
            d2 = tp[n2, q, r] - tp[n0, q, r]
            d3 = tp[n3, q, r] - tp[n0, q, r]
            w1 = tv[n1, q, r] - tv[n0, q, r]
            w2 = tv[n2, q, r] - tv[n0, q, r]
            w3 = tv[n3, q, r] - tv[n0, q, r]
            for c in range(3):
                dF[q, r, c] = d1 * B[0, c] + d2 * B[1, c] + d3 * B[2, c]
                dFd[q, r, c] = w1 * B[0, c] + w2 * B[1, c] + w3 * B[2, c]


@numba.njit(cache=True, nogil=True)
def _volumetric_tangent(F, Fd, dF, dFd, q):
    """Tangent ``q`` of the volumetric strain ``θ = tr G`` and of its rate."""
    d_theta = 0.0
    d_theta_rate = 0.0
    for r in range(3):
        for c in range(3):
            d_theta += F[r, c] * dF[q, r, c]
            d_theta_rate += dF[q, r, c] * Fd[r, c] + F[r, c] * dFd[q, r, c]
    return d_theta, d_theta_rate


@numba.njit(cache=True, nogil=True)
def _element_tangents(p, v, tp, tv, tets, inverse_rest, volume, shear, shear_rate, lam,
                      lam_rate, nodal, node_volume, node_lam, node_lam_rate, element_ptr,
                      element_column, d_shear, d_shear_rate, d_lam, d_lam_rate, d_node_lam,
                      d_node_lam_rate, kappa, kappa_column, node_strain, d_node_strain, force,
                      d_force):
    """Element forces and their tangents. ``S = shear G + shear_rate Ġ + π I
    + 2 κ (G:G) G`` (the last term: strain stiffening, ``kappa_column`` its parameter or -1);
    the element's parameter columns (CSR ``element_ptr``/``element_column``) carry the
    derivatives of its four constants, and with ``nodal`` those of the node averages
    (``d_node_lam*``)."""
    n_params = tp.shape[1]
    F = np.empty((3, 3))
    Fd = np.empty((3, 3))
    G = np.empty((3, 3))
    Gd = np.empty((3, 3))
    S = np.empty((3, 3))
    dF = np.empty((n_params, 3, 3))
    dFd = np.empty((n_params, 3, 3))
    dS = np.empty((n_params, 3, 3))
    d_pressure = np.empty(n_params)
    inner = np.empty(n_params)
    n_elements = tets.shape[0]
    if nodal:    # node averages of θ, θ̇ and their tangents → node pressures and tangents
        node_strain[:] = 0.0
        d_node_strain[:] = 0.0
        for e in range(n_elements):
            n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
            _gradients(p, v, tp, tv, n0, n1, n2, n3, inverse_rest[e], F, Fd, dF, dFd)
            theta = -1.5
            theta_rate = 0.0
            for r in range(3):
                for c in range(3):
                    theta += 0.5 * F[r, c] * F[r, c]
                    theta_rate += F[r, c] * Fd[r, c]
            corner = 0.25 * volume[e]
            for j in range(4):
                node = tets[e, j]
                node_strain[node, 0] += corner * theta
                node_strain[node, 1] += corner * theta_rate
            for q in range(n_params):
                d_theta, d_theta_rate = _volumetric_tangent(F, Fd, dF, dFd, q)
                for j in range(4):
                    node = tets[e, j]
                    d_node_strain[node, q, 0] += corner * d_theta
                    d_node_strain[node, q, 1] += corner * d_theta_rate
        for i in range(node_strain.shape[0]):
            if node_volume[i] > 0.0:
                theta = node_strain[i, 0] / node_volume[i]
                theta_rate = node_strain[i, 1] / node_volume[i]
                node_strain[i, 0] = node_lam[i] * theta + node_lam_rate[i] * theta_rate
                for q in range(n_params):
                    d_node_strain[i, q, 0] = (
                        (node_lam[i] * d_node_strain[i, q, 0]
                         + node_lam_rate[i] * d_node_strain[i, q, 1]) / node_volume[i]
                        + d_node_lam[i, q] * theta + d_node_lam_rate[i, q] * theta_rate)
    for e in range(n_elements):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        _gradients(p, v, tp, tv, n0, n1, n2, n3, B, F, Fd, dF, dFd)
        for i in range(3):
            for k in range(i, 3):
                g = 0.5 * (F[0, i] * F[0, k] + F[1, i] * F[1, k] + F[2, i] * F[2, k])
                gd = 0.5 * (F[0, i] * Fd[0, k] + F[1, i] * Fd[1, k] + F[2, i] * Fd[2, k]
                            + Fd[0, i] * F[0, k] + Fd[1, i] * F[1, k] + Fd[2, i] * F[2, k])
                if i == k:
                    g -= 0.5
                G[i, k] = g
                G[k, i] = g
                Gd[i, k] = gd
                Gd[k, i] = gd
        theta = G[0, 0] + G[1, 1] + G[2, 2]
        theta_rate = Gd[0, 0] + Gd[1, 1] + Gd[2, 2]
        if nodal:
            pressure = 0.25 * (node_strain[n0, 0] + node_strain[n1, 0] + node_strain[n2, 0]
                               + node_strain[n3, 0])
            for q in range(n_params):
                d_pressure[q] = 0.25 * (d_node_strain[n0, q, 0] + d_node_strain[n1, q, 0]
                                        + d_node_strain[n2, q, 0] + d_node_strain[n3, q, 0])
        else:
            pressure = lam[e] * theta + lam_rate[e] * theta_rate
            for q in range(n_params):
                d_theta, d_theta_rate = _volumetric_tangent(F, Fd, dF, dFd, q)
                d_pressure[q] = lam[e] * d_theta + lam_rate[e] * d_theta_rate
        squared = 0.0
        for i in range(3):
            for k in range(3):
                squared += G[i, k] * G[i, k]
        stiffening = 2.0 * kappa * squared
        for i in range(3):
            for k in range(3):
                S[i, k] = (shear[e] + stiffening) * G[i, k] + shear_rate[e] * Gd[i, k]
            S[i, i] += pressure
        scale = -volume[e]
        _scatter_piola(force, F, S, B, scale, n0, n1, n2, n3)
        if n_params == 0:
            continue
        # dS = shear dG + shear_rate dĠ + dπ I + 2κ (2 (G:dG) G + (G:G) dG): the state's
        # part for every direction...
        for q in range(n_params):
            inner[q] = 0.0
            for i in range(3):
                for k in range(i, 3):
                    dg = 0.5 * (F[0, i] * dF[q, 0, k] + F[1, i] * dF[q, 1, k]
                                + F[2, i] * dF[q, 2, k] + dF[q, 0, i] * F[0, k]
                                + dF[q, 1, i] * F[1, k] + dF[q, 2, i] * F[2, k])
                    dgd = 0.5 * (dF[q, 0, i] * Fd[0, k] + dF[q, 1, i] * Fd[1, k]
                                 + dF[q, 2, i] * Fd[2, k] + Fd[0, i] * dF[q, 0, k]
                                 + Fd[1, i] * dF[q, 1, k] + Fd[2, i] * dF[q, 2, k]
                                 + F[0, i] * dFd[q, 0, k] + F[1, i] * dFd[q, 1, k]
                                 + F[2, i] * dFd[q, 2, k] + dFd[q, 0, i] * F[0, k]
                                 + dFd[q, 1, i] * F[1, k] + dFd[q, 2, i] * F[2, k])
                    x = (shear[e] + stiffening) * dg + shear_rate[e] * dgd
                    dS[q, i, k] = x
                    dS[q, k, i] = x
                    inner[q] += dg * G[i, k] * (1.0 if i == k else 2.0)
                dS[q, i, i] += d_pressure[q]
            if kappa != 0.0:
                for i in range(3):
                    for k in range(3):
                        dS[q, i, k] += 4.0 * kappa * inner[q] * G[i, k]
        if kappa_column >= 0:
            for i in range(3):
                for k in range(3):
                    dS[kappa_column, i, k] += 2.0 * squared * G[i, k]
        # ...then the element's own constants by the parameters they depend on
        for entry in range(element_ptr[e], element_ptr[e + 1]):
            q = element_column[entry]
            extra = 0.0 if nodal else d_lam[entry] * theta + d_lam_rate[entry] * theta_rate
            for i in range(3):
                for k in range(3):
                    dS[q, i, k] += d_shear[entry] * G[i, k] + d_shear_rate[entry] * Gd[i, k]
                dS[q, i, i] += extra
        for q in range(n_params):
            for r in range(3):   # dP = dF S + F dS
                P0 = 0.0
                P1 = 0.0
                P2 = 0.0
                for m in range(3):
                    P0 += dF[q, r, m] * S[m, 0] + F[r, m] * dS[q, m, 0]
                    P1 += dF[q, r, m] * S[m, 1] + F[r, m] * dS[q, m, 1]
                    P2 += dF[q, r, m] * S[m, 2] + F[r, m] * dS[q, m, 2]
                f1 = scale * (P0 * B[0, 0] + P1 * B[0, 1] + P2 * B[0, 2])
                f2 = scale * (P0 * B[1, 0] + P1 * B[1, 1] + P2 * B[1, 2])
                f3 = scale * (P0 * B[2, 0] + P1 * B[2, 1] + P2 * B[2, 2])
                d_force[n1, q, r] += f1
                d_force[n2, q, r] += f2
                d_force[n3, q, r] += f3
                d_force[n0, q, r] -= f1 + f2 + f3


@numba.njit(cache=True, nogil=True)
def forward(p, v, a, b, stiffness, damping, rest, stiffness_column, damping_column, tets,
            inverse_rest, volume, shear, shear_rate, lam, lam_rate, nodal, node_volume,
            node_lam, node_lam_rate, element_ptr, element_column, d_shear, d_shear_rate, d_lam,
            d_lam_rate, d_node_lam, d_node_lam_rate, kappa, kappa_column, drag, drag_column,
            force_direction,
            weight, loads, h, n_frames, substeps, n_params, start_index, start_p, start_v,
            rows_start, rows_node, rows_weight, seen, scale, tangents, positions, jacobian):
    """Positions (n_frames, N, 3) and, with ``tangents``, ``jacobian`` (n_frames - 1, rows,
    3, P) = H tp / length_unit at every measured (frame, row), 0 elsewhere.

    Effects: a node drag ``-drag v`` (its coefficient's column ``drag_column``, -1 when not
    learned), constant forces already in ``loads`` with their parameter columns in
    ``force_direction`` (N, P, 3) (gravity, unmodeled loads); inclusions of elements are in
    the element constants and their CSR columns; strain stiffening of the elements is
    ``kappa`` (its column ``kappa_column``).
    """
    n_nodes = p.shape[0]
    n_rows = rows_start.shape[0] - 1
    force = np.empty((n_nodes, 3))
    width = n_params if tangents else 0
    tp = np.zeros((n_nodes, width, 3))
    tv = np.zeros((n_nodes, width, 3))
    d_force = np.empty((n_nodes, width, 3))
    node_strain = np.zeros((n_nodes, 2))
    d_node_strain = np.zeros((n_nodes, width, 2))
    for t in range(n_frames):
        if start_index[t] >= 0:
            p[:] = start_p[start_index[t]]
            v[:] = start_v[start_index[t]]
            tp[:] = 0.0
            tv[:] = 0.0
            positions[t] = p
            if t > 0 and tangents:
                jacobian[t - 1] = 0.0
            continue
        load = loads[min(t - 1, loads.shape[0] - 1)]
        for _ in range(substeps):
            for i in range(n_nodes):
                for k in range(3):
                    force[i, k] = load[i, k] - drag * v[i, k]
                    for q in range(width):
                        d_force[i, q, k] = force_direction[i, q, k] - drag * tv[i, q, k]
                    if 0 <= drag_column < width:
                        d_force[i, drag_column, k] -= v[i, k]
            _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, stiffness_column,
                             damping_column, force, d_force)
            if tets.shape[0]:
                _element_tangents(p, v, tp, tv, tets, inverse_rest, volume, shear, shear_rate,
                                  lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate,
                                  element_ptr, element_column, d_shear, d_shear_rate, d_lam,
                                  d_lam_rate, d_node_lam, d_node_lam_rate, kappa,
                                  kappa_column, node_strain, d_node_strain, force, d_force)
            for i in range(n_nodes):
                step = h * weight[i]
                for k in range(3):
                    v[i, k] += step * force[i, k]
                    p[i, k] += h * v[i, k]
                    for q in range(width):
                        tv[i, q, k] += step * d_force[i, q, k]
                        tp[i, q, k] += h * tv[i, q, k]
        positions[t] = p
        if tangents:
            for row in range(n_rows):
                for k in range(3):
                    for q in range(width):
                        jacobian[t - 1, row, k, q] = 0.0
                if not seen[t, row]:
                    continue
                for entry in range(rows_start[row], rows_start[row + 1]):
                    node = rows_node[entry]
                    w = rows_weight[entry] * scale
                    for k in range(3):
                        for q in range(width):
                            jacobian[t - 1, row, k, q] += w * tp[node, q, k]
