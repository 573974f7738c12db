"""Compiled forward sensitivities (numba) of :class:`neurofuzzy.learn.Sensitivity`.

One call runs a whole experiment: every frame and substep of semi-implicit Euler for the
state and its tangents along every parameter direction, with the observation operator
applied at every frame, so no Python runs per time step. The arithmetic is that of the numpy
reference path (:meth:`neurofuzzy.forces.Springs.state_jvp`, ``parameter_templates`` and
:meth:`neurofuzzy.forces.Tetrahedra.state_jvp`, ``parameter_jvp``; tested equal):

- springs ``f = (s x + c ((v_b - v_a)·u) + q x³) u`` (``x = l - L0``; ``s`` with the
  spring inclusions' extra stiffness, ``q = κ / L0²`` the spring stiffening's, a second
  entry of the spring list), parameters ``log s`` and ``log c`` of the spring's tie group
  and the spring effects' coefficients (a CSR per spring, :func:`_spring_tangents`);
- tetrahedral elements of each element's law (:mod:`neurofuzzy.kernels.laws`; module
  :mod:`neurofuzzy.forces.tetrahedra`), parameters ``log E``, ``logit 2ν`` and ``log η`` of
  the element's tie group; the volumetric ``π``, ``π̇`` per element or from the node averages
  (two passes over the elements).

Layout for speed: the tangents are ``(N, 3, P)``, parameters last, so the loop over the
parameters of one spring reads and writes contiguous memory without a branch (it vectorises);
an element's 3×3 matrices (F, Ḟ, S and their tangents) are tuples of nine scalars that stay
in registers, as in the simulation kernel (:mod:`neurofuzzy.kernels.stepper`).

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from .integrator import euler_update
from .springs import partial
from .stepper import _only_svk, _spring
from .laws import ST_VENANT_KIRCHHOFF, stress_jvp, volumetric
from .relaxation import relax, relaxation_tangent, relaxed_stress
from .tuples import (_differences, _dot, _edges, _edges_of_tangent, _full, _green, _mul, _scatter,
                     _sym_dot, _sym_t_mul)


#: the tangents' arithmetic may fuse a multiply and an add (one rounding instead of two: FMA,
#: about 10 % of a tangent sweep of the 10,368-tetrahedron block); nothing else of fast math
#: (NaN and infinity keep their meaning: a run that leaves the finite numbers is still seen)
CONTRACT = {"contract"}


# -- springs -----------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, cubic, spring_ptr,
                     spring_column, spring_basis, spring_factor, first, force, d_force, work):
    """Spring forces into ``force`` and their tangents into ``d_force`` (N, 3, P), tangent
    ``q`` that of parameter ``first + q``; ``work`` (3, P) holds one spring's tangent
    force. The parameters' derivatives of spring ``j``'s magnitude are the CSR entries
    ``spring_ptr[j] .. spring_ptr[j + 1]``: ``factor · basis`` for parameter ``column``, basis
    0 the stretch ``x``, 1 the closing speed, 2 ``x³`` (:func:`.springs.partial`;
    ``log s`` has the factor ``s``, an inclusion's ``k`` the factor 1, a stiffening's ``κ``
    the factor ``1 / L0²`` of basis 2, ``x³``). ``cubic`` holds the ``q`` of the last
    springs, as in :func:`.stepper._springs`."""
    n_params = tp.shape[2]
    tx, ty, tz = work[0], work[1], work[2]     # the spring's tangent force
    plain = a.shape[0] - cubic.shape[0]        # the last springs' q: cubic
    for j in range(a.shape[0]):
        ia, ib = a[j], b[j]
        ux, uy, uz, length, closing, stretch, magnitude, slope = _spring(
            p, v, ia, ib, stiffness[j], damping[j], rest[j],
            cubic[j - plain] if j >= plain else 0.0, force)
        if n_params == 0:
            continue
        c = damping[j]
        inverse = 1.0 / length
        wx = v[ib, 0] - v[ia, 0]
        wy = v[ib, 1] - v[ia, 1]
        wz = v[ib, 2] - v[ia, 2]
        pax, pay, paz = tp[ia, 0], tp[ia, 1], tp[ia, 2]
        pbx, pby, pbz = tp[ib, 0], tp[ib, 1], tp[ib, 2]
        vax, vay, vaz = tv[ia, 0], tv[ia, 1], tv[ia, 2]
        vbx, vby, vbz = tv[ib, 0], tv[ib, 1], tv[ib, 2]
        for q in range(n_params):
            ddx = pbx[q] - pax[q]
            ddy = pby[q] - pay[q]
            ddz = pbz[q] - paz[q]
            dl = ux * ddx + uy * ddy + uz * ddz
            dux = (ddx - ux * dl) * inverse
            duy = (ddy - uy * dl) * inverse
            duz = (ddz - uz * dl) * inverse
            d_closing = ((vbx[q] - vax[q]) * ux + (vby[q] - vay[q]) * uy
                         + (vbz[q] - vaz[q]) * uz + wx * dux + wy * duy + wz * duz)
            dm = slope * dl + c * d_closing
            tx[q] = dm * ux + magnitude * dux
            ty[q] = dm * uy + magnitude * duy
            tz[q] = dm * uz + magnitude * duz
        # the parameters of the spring's magnitude, outside the vectorised loop
        for entry in range(spring_ptr[j], spring_ptr[j + 1]):
            column = spring_column[entry] - first
            if 0 <= column < n_params:
                extra = spring_factor[entry] * partial(spring_basis[entry], stretch, closing)
                tx[column] += extra * ux
                ty[column] += extra * uy
                tz[column] += extra * uz
        fax, fay, faz = d_force[ia, 0], d_force[ia, 1], d_force[ia, 2]
        fbx, fby, fbz = d_force[ib, 0], d_force[ib, 1], d_force[ib, 2]
        for q in range(n_params):
            fax[q] += tx[q]
            fay[q] += ty[q]
            faz[q] += tz[q]
            fbx[q] -= tx[q]
            fby[q] -= ty[q]
            fbz[q] -= tz[q]


# -- tetrahedral elements ----------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, fastmath=CONTRACT, inline="always")
def _node_pressures(p, v, tp, tv, tets, inverse_rest, volume, law, node_volume, node_lam,
                    node_lam_rate, d_node_lam, d_node_lam_rate, first, node_strain,
                    d_node_strain, general):
    """Nodal volumetric form: ``node_strain[:, 0]``, ``[:, 1]`` the node pressures ``Λ θ̄``
    and ``H θ̄̇`` and ``d_node_strain[:, q, :]`` their tangents (the node averages of the
    laws' ``θ`` and of ``θ̇ = tr Ġ`` and of their tangents first)."""
    n_params = tp.shape[2]
    node_strain[:] = 0.0
    d_node_strain[:] = 0.0
    for e in range(tets.shape[0]):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        F = _edges(p, n0, n1, n2, n3, B)
        Fd = _edges(v, n0, n1, n2, n3, B)
        G, Gd = _green(F, Fd)
        theta, N = volumetric(law[e] if general else ST_VENANT_KIRCHHOFF, G)
        theta_rate = Gd[0] + Gd[1] + Gd[2]
        corner = 0.25 * volume[e]
        for node in (n0, n1, n2, n3):
            node_strain[node, 0] += corner * theta
            node_strain[node, 1] += corner * theta_rate
        if n_params == 0:
            continue
        # dθ = N : dG with dG = sym(Fᵀ dF), so dθ = dF : (F N) = Σ dDs ∘ (F N Bᵀ);
        # dθ̇ = dF : Ḟ + F : dḞ likewise
        Bt = (B[0, 0], B[1, 0], B[2, 0], B[0, 1], B[1, 1], B[2, 1], B[0, 2], B[1, 2], B[2, 2])
        A = _mul(_mul(F, _full(N)), Bt)
        Ar = _mul(F, Bt)
        Ad = _mul(Fd, Bt)
        for q in range(n_params):
            D = _differences(tp, n0, n1, n2, n3, q)
            W = _differences(tv, n0, n1, n2, n3, q)
            d_theta = corner * _dot(D, A)
            d_theta_rate = corner * (_dot(D, Ad) + _dot(W, Ar))
            for node in (n0, n1, n2, n3):
                d_node_strain[node, q, 0] += d_theta
                d_node_strain[node, q, 1] += d_theta_rate
    for i in range(node_strain.shape[0]):
        if node_volume[i] > 0.0:
            theta = node_strain[i, 0] / node_volume[i]
            theta_rate = node_strain[i, 1] / node_volume[i]
            node_strain[i, 0] = node_lam[i] * theta
            node_strain[i, 1] = node_lam_rate[i] * theta_rate
            for q in range(n_params):
                d_node_strain[i, q, 0] = (node_lam[i] * d_node_strain[i, q, 0] / node_volume[i]
                                          + d_node_lam[i, first + q] * theta)
                d_node_strain[i, q, 1] = (node_lam_rate[i] * d_node_strain[i, q, 1]
                                          / node_volume[i]
                                          + d_node_lam_rate[i, first + q] * theta_rate)


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _element_tangents(p, v, tp, tv, tets, inverse_rest, volume, law, stiffening, shear,
                      shear_rate, lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate,
                      element_ptr, element_column, d_shear, d_shear_rate, d_lam, d_lam_rate,
                      d_node_lam, d_node_lam_rate, kappa, kappa_column, stiffening_column,
                      relax_g, relax_decay,
                      relax_column, history, d_history, first, node_strain, d_node_strain,
                      force, d_force):
    """Element forces and their tangents: each element's law (:mod:`.laws`) with strain
    stiffening ``2 κ (G:G) G`` (``kappa_column`` its parameter or -1), the law's own
    stiffening constant ``stiffening[e]`` (``stiffening_column[e]`` the column of its
    logarithm, -1 when not learned) and Prony relaxation
    (:mod:`.relaxation`; ``relax_column[e, k]`` the columns of term k's ``log g`` and
    ``log τ``, -1 when not learned), whose internal variables ``history`` and their tangents
    ``d_history`` (n_elements, K, 6, P) it advances; the element's parameter columns (CSR
    ``element_ptr``/``element_column``, columns ascending) carry the derivatives of its four
    constants, and with ``nodal`` those of the node averages (``d_node_lam*``). Tangent ``q``
    is that of parameter ``first + q``.

    The loop is compiled twice (``general`` a constant at each call), as the stepper's
    (:func:`neurofuzzy.kernels.stepper._element_forces`): for elements that are all
    St. Venant–Kirchhoff without stiffening or relaxation the law is a constant of the
    loop."""
    # (packed in tuples: a call of more than 30 arguments is a call with *args in
    # CPython 3.11's bytecode, which numba cannot inline)
    arrays = (tets, inverse_rest, volume, law, stiffening)
    constants = (shear, shear_rate, lam, lam_rate)
    node_arrays = (node_volume, node_lam, node_lam_rate, d_node_lam, d_node_lam_rate)
    columns = (element_ptr, element_column, d_shear, d_shear_rate, d_lam, d_lam_rate)
    relaxation = (relax_g, relax_decay, relax_column, history, d_history)
    if _only_svk(law, kappa, relax_g.shape[1] > 0):
        _tangent_passes(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns, kappa,
                        kappa_column, stiffening_column, relaxation, first, node_strain,
                        d_node_strain, force, d_force, False)
    else:
        _tangent_passes(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns, kappa,
                        kappa_column, stiffening_column, relaxation, first, node_strain,
                        d_node_strain, force, d_force, True)


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT, inline="always")
def _tangent_passes(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns, kappa,
                    kappa_column, stiffening_column, relaxation, first, node_strain,
                    d_node_strain, force, d_force, general):
    """:func:`_element_tangents`' passes, for any laws (``general``) or St. Venant–Kirchhoff
    alone."""
    tets, inverse_rest, volume, law, stiffening = arrays
    shear, shear_rate, lam, lam_rate = constants
    node_volume, node_lam, node_lam_rate, d_node_lam, d_node_lam_rate = node_arrays
    element_ptr, element_column, d_shear, d_shear_rate, d_lam, d_lam_rate = columns
    relax_g, relax_decay, relax_column, history, d_history = relaxation
    n_params = tp.shape[2]
    # St. Venant–Kirchhoff alone: no stiffening, no relaxation
    n_terms = relax_g.shape[1] if general else 0
    strain_stiffening = kappa if general else 0.0
    if nodal:
        _node_pressures(p, v, tp, tv, tets, inverse_rest, volume, law, node_volume, node_lam,
                        node_lam_rate, d_node_lam, d_node_lam_rate, first, node_strain,
                        d_node_strain, general)
    for e in range(tets.shape[0]):
        own = law[e] if general else ST_VENANT_KIRCHHOFF
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        F = _edges(p, n0, n1, n2, n3, B)
        Fd = _edges(v, n0, n1, n2, n3, B)
        G, Gd = _green(F, Fd)
        theta, N = volumetric(own, G)
        theta_rate = Gd[0] + Gd[1] + Gd[2]
        if nodal:
            pressure = 0.25 * (node_strain[n0, 0] + node_strain[n1, 0] + node_strain[n2, 0]
                               + node_strain[n3, 0])
            pressure_rate = 0.25 * (node_strain[n0, 1] + node_strain[n1, 1]
                                    + node_strain[n2, 1] + node_strain[n3, 1])
        else:
            pressure = lam[e] * theta
            pressure_rate = lam_rate[e] * theta_rate
        S6, S_el = relaxed_stress(own, G, Gd, shear[e], shear_rate[e], pressure,
                                  pressure_rate, strain_stiffening, stiffening[e], relax_g,
                                  history, e)
        S = _full(S6)
        scale = -volume[e]
        _scatter(force, _mul(F, S), B, scale, n0, n1, n2, n3, -1)
        if n_params == 0:
            if n_terms:
                relax(S_el, relax_decay, history, e)
            continue
        entry, stop = element_ptr[e], element_ptr[e + 1]
        while entry < stop and element_column[entry] < first:
            entry += 1
        for q in range(n_params):
            # the state's part: dG, dĠ and the pressures' changes through θ, θ̇
            dF = _edges_of_tangent(tp, n0, n1, n2, n3, B, q)
            dFd = _edges_of_tangent(tv, n0, n1, n2, n3, B, q)
            dG = _sym_t_mul(F, dF)
            dGa = _sym_t_mul(dF, Fd)
            dGb = _sym_t_mul(F, dFd)
            dGd = (dGa[0] + dGb[0], dGa[1] + dGb[1], dGa[2] + dGb[2], dGa[3] + dGb[3],
                   dGa[4] + dGb[4], dGa[5] + dGb[5])
            if nodal:
                d_pressure = 0.25 * (d_node_strain[n0, q, 0] + d_node_strain[n1, q, 0]
                                     + d_node_strain[n2, q, 0] + d_node_strain[n3, q, 0])
                d_pressure_rate = 0.25 * (d_node_strain[n0, q, 1] + d_node_strain[n1, q, 1]
                                          + d_node_strain[n2, q, 1] + d_node_strain[n3, q, 1])
            else:
                d_pressure = lam[e] * _sym_dot(N, dG)
                d_pressure_rate = lam_rate[e] * (dGd[0] + dGd[1] + dGd[2])
            shear_part = 0.0       # the element's own constants, when q is one of them
            rate_part = 0.0
            while entry < stop and element_column[entry] == first + q:
                shear_part += d_shear[entry]
                rate_part += d_shear_rate[entry]
                if not nodal:
                    d_pressure += d_lam[entry] * theta
                    d_pressure_rate += d_lam_rate[entry] * theta_rate
                entry += 1
            d_kappa = 1.0 if first + q == kappa_column else 0.0
            # the law's constant is learned by its logarithm: dc/d log c = c
            d_stiffening = stiffening[e] if first + q == stiffening_column[e] else 0.0
            dS6 = stress_jvp(own, G, Gd, dG, dGd, shear[e], shear_rate[e], pressure,
                             pressure_rate, strain_stiffening, stiffening[e], shear_part,
                             rate_part, d_pressure, d_pressure_rate, d_kappa, d_stiffening)
            if n_terms:
                dS6 = relaxation_tangent(dS6, own, G, Gd, dG, dGd, shear[e], pressure,
                                         stiffening[e], shear_part, d_pressure, d_stiffening,
                                         S_el, relax_g, relax_decay, relax_column, history,
                                         d_history, e, first + q, q)
            dS = _full(dS6)
            dFS = _mul(dF, S)                            # dP = dF S + F dS
            FdS = _mul(F, dS)
            dP = (dFS[0] + FdS[0], dFS[1] + FdS[1], dFS[2] + FdS[2], dFS[3] + FdS[3],
                  dFS[4] + FdS[4], dFS[5] + FdS[5], dFS[6] + FdS[6], dFS[7] + FdS[7],
                  dFS[8] + FdS[8])
            _scatter(d_force, dP, B, scale, n0, n1, n2, n3, q)
        if n_terms:
            relax(S_el, relax_decay, history, e)


# -- one experiment ----------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def forward(p, v, a, b, stiffness, damping, rest, cubic, spring_ptr, spring_column,
            spring_basis, spring_factor, tets, inverse_rest, volume, law, stiffening, shear,
            shear_rate, lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate, element_ptr,
            element_column, d_shear, d_shear_rate, d_lam, d_lam_rate, d_node_lam,
            d_node_lam_rate, kappa, kappa_column, stiffening_column, relax_g, relax_decay,
            relax_column, drag, drag_column, force_direction, weight, mass_column,
            unit_mass_force, loads, h, n_frames, substeps, first, width, start_index, start_p,
            start_v, rows_start, rows_node, rows_weight, seen, scale, positions, jacobian):
    """Positions (n_frames, N, 3) and columns ``first .. first + width - 1`` of ``jacobian``
    (n_frames - 1, rows, 3, P) = H tp / length_unit at every measured (frame, row), 0
    elsewhere (threads given disjoint columns of one array split an experiment's Jacobian).
    A run of the state alone takes the faster :func:`neurofuzzy.kernels.stepper.frames`.
    ``tets`` None: a model without elements, compiled without the element code (as there).

    Effects: a node drag ``-drag v`` (its coefficient's column ``drag_column``, -1 when not
    learned), constant forces already in ``loads`` with their parameter columns in
    ``force_direction`` (N, 3, width) (gravity, unmodeled loads; the columns computed);
    inclusions and stiffening of springs are in ``stiffness`` and ``cubic`` and the springs'
    CSR columns (:func:`_spring_tangents`); inclusions of elements are in the element
    constants and their CSR columns; strain stiffening of the elements is ``kappa`` (its
    column ``kappa_column``). The elements' law constants ``stiffening`` (per element) have
    the columns ``stiffening_column``. Learned node masses: ``mass_column`` (N,) the column
    of each node's ``log m`` (-1 when not learned; empty when no mass is),
    ``unit_mass_force`` (N, 3) the forces proportional to the mass (gravity), which ``W F``
    does not see: ``∂(W F)/∂log m = -W (F - F_unit)``.
    """
    n_nodes = p.shape[0]
    n_rows = rows_start.shape[0] - 1
    force = np.empty((n_nodes, 3))
    tp = np.zeros((n_nodes, 3, width))
    tv = np.zeros((n_nodes, 3, width))
    d_force = np.empty((n_nodes, 3, width))
    tp_flat = tp.reshape((n_nodes, 3 * width))
    tv_flat = tv.reshape((n_nodes, 3 * width))
    d_force_flat = d_force.reshape((n_nodes, 3 * width))
    work = np.empty((3, width))
    node_strain = np.zeros((n_nodes, 2))
    d_node_strain = np.zeros((n_nodes, width, 2))
    # the relaxation's internal variables and their tangents: from rest, carried over window
    # starts (a window starts from a measured state; the elements' history goes on)
    history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6))
    d_history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6, width))
    for t in range(n_frames):
        if start_index[t] >= 0:
            p[:] = start_p[start_index[t]]
            v[:] = start_v[start_index[t]]
            tp[:] = 0.0
            tv[:] = 0.0
            positions[t] = p
            if t > 0:
                jacobian[t - 1, :, :, first:first + width] = 0.0
            continue
        load = loads[min(t - 1, loads.shape[0] - 1)]
        for _ in range(substeps):
            for i in range(n_nodes):
                for k in range(3):
                    force[i, k] = load[i, k] - drag * v[i, k]
                    out, direction, speed = d_force[i, k], force_direction[i, k], tv[i, k]
                    for q in range(width):
                        out[q] = direction[q] - drag * speed[q]
                    if 0 <= drag_column - first < width:
                        out[drag_column - first] -= v[i, k]
            _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, cubic, spring_ptr,
                             spring_column, spring_basis, spring_factor, first, force, d_force,
                             work)
            if tets is not None:       # None: no elements, and no element code compiled
                _element_tangents(p, v, tp, tv, tets, inverse_rest, volume, law, stiffening,
                                  shear, shear_rate, lam, lam_rate, nodal, node_volume,
                                  node_lam, node_lam_rate, element_ptr, element_column,
                                  d_shear, d_shear_rate, d_lam, d_lam_rate, d_node_lam,
                                  d_node_lam_rate, kappa, kappa_column, stiffening_column,
                                  relax_g, relax_decay,
                                  relax_column, history, d_history, first, node_strain,
                                  d_node_strain, force, d_force)
            for i in range(mass_column.shape[0]):
                c = mass_column[i] - first
                if 0 <= c < width:
                    for k in range(3):
                        d_force[i, k, c] -= force[i, k] - unit_mass_force[i, k]
            euler_update(p, v, force, weight, h)
            # the update is linear: the tangents take the same one, (N, 3, P) seen as (N, 3P)
            euler_update(tp_flat, tv_flat, d_force_flat, weight, h)
        if not np.isfinite(p.sum()):
            # diverged (a trial step too far): the rest is not computed, as in the state's
            # own run (the caller reads the residuals as diverged and never the Jacobian)
            positions[t:] = np.nan
            jacobian[t - 1:, :, :, first:first + width] = 0.0
            return
        positions[t] = p
        for row in range(n_rows):
            out = jacobian[t - 1, row]
            for k in range(3):
                target = out[k]
                for q in range(width):
                    target[first + q] = 0.0
            if not seen[t, row]:
                continue
            for entry in range(rows_start[row], rows_start[row + 1]):
                node = rows_node[entry]
                w = rows_weight[entry] * scale
                for k in range(3):
                    target, source = out[k], tp[node, k]
                    for q in range(width):
                        target[first + q] += w * source[q]
