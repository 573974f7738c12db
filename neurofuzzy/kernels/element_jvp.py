"""The element part of the compiled forward sensitivities
(:func:`neurofuzzy.kernels.sensitivity.forward`): every tetrahedron's nodal forces and their
tangents along the parameter directions, on one thread or, for a large model, on several.

Each element's law (:mod:`.laws`), with strain stiffening ``2 κ (G:G) G`` and Prony relaxation
(:mod:`.relaxation`), parameters ``log E``, ``logit 2ν`` and ``log η`` of the element's tie
group (:mod:`neurofuzzy.forces.tetrahedra`); the volumetric ``π``, ``π̇`` per element or from
the node averages (the nodal form: a pass for the node sums, one for the forces).

An element adds into the nodes it shares with its neighbours, so the passes split over threads
as the stepper's do (:func:`.element_forces._passes_parallel`): thread ``c`` takes
the ``c``-th run of consecutive elements and adds into its own buffers, summed per node after
each pass. One function does a run of elements (:func:`_stage`); the one-thread sweep calls it
on all of them, so its code is compiled once for both.
"""

import numba
import numpy as np

from .laws import ST_VENANT_KIRCHHOFF, stress_jvp, volumetric
from .relaxation import relax, relaxation_tangent, relaxed_stress
from .element_forces import _only_svk
from .tuples import (_differences, _dot, _edges_of_tangent, _element_strains, _full, _mul,
                     _scatter, _sym_dot, _sym_t_mul)

#: the tangents' arithmetic may fuse a multiply and an add (one rounding instead of two: FMA,
#: about 10 % of a tangent sweep of the 10,368-tetrahedron block); nothing else of fast math
#: (NaN and infinity keep their meaning: a run that leaves the finite numbers is still seen)
CONTRACT = {"contract"}


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _node_sums(p, v, tp, tv, tets, inverse_rest, volume, law, node_strain, d_node_strain,
               general):
    """The nodal form's first pass: every element's ``V θ / 4`` and ``V θ̇ / 4`` (the law's
    ``θ``, ``θ̇ = tr Ġ``) and their tangents added into its corners' rows of ``node_strain``
    (N, 2) and ``d_node_strain`` (N, P, 2)."""
    n_params = tp.shape[2]
    for e in range(tets.shape[0]):
        n0, n1, n2, n3, B, F, Fd, G, Gd = _element_strains(p, v, tets, inverse_rest, e)
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


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _node_pressures(node_strain, d_node_strain, node_arrays, first, lo, hi):
    """Nodes ``lo..hi - 1``: their sums into the node pressures ``Λ θ̄``, ``H θ̄̇`` and their
    tangents (tangent ``q`` that of parameter ``first + q``)."""
    node_volume, node_lam, node_lam_rate, d_node_lam, d_node_lam_rate = node_arrays
    n_params = d_node_strain.shape[1]
    for i in range(lo, hi):
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
def _forces(p, v, tp, tv, arrays, constants, nodal, columns, law_constant_column, relaxation,
            learned, node_strain, d_node_strain, force, d_force, general):
    """The second pass: every element's nodal forces into ``force`` and their tangents into
    ``d_force``, for any laws (``general``) or St. Venant–Kirchhoff alone."""
    tets, inverse_rest, volume, law, law_constant = arrays
    shear, shear_rate, lam, lam_rate = constants
    element_ptr, element_column, d_shear, d_shear_rate, d_lam, d_lam_rate = columns
    relax_g, relax_decay, relax_column, history, d_history = relaxation
    kappa, kappa_column, first = learned
    n_params = tp.shape[2]
    # St. Venant–Kirchhoff alone: no strain stiffening, no relaxation
    n_terms = relax_g.shape[1] if general else 0
    strain_stiffening = kappa if general else 0.0
    for e in range(tets.shape[0]):
        own = law[e] if general else ST_VENANT_KIRCHHOFF
        n0, n1, n2, n3, B, F, Fd, G, Gd = _element_strains(p, v, tets, inverse_rest, e)
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
                                  pressure_rate, strain_stiffening, law_constant[e], relax_g,
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
            d_law_constant = law_constant[e] if first + q == law_constant_column[e] else 0.0
            dS6 = stress_jvp(own, G, Gd, dG, dGd, shear[e], shear_rate[e], pressure,
                             pressure_rate, strain_stiffening, law_constant[e], shear_part,
                             rate_part, d_pressure, d_pressure_rate, d_kappa, d_law_constant)
            if n_terms:
                dS6 = relaxation_tangent(dS6, own, G, Gd, dG, dGd, shear[e], pressure,
                                         law_constant[e], shear_part, d_pressure, d_law_constant,
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


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _stage(p, v, tp, tv, arrays, constants, nodal, columns, law_constant_column, relaxation,
           learned, node_strain, d_node_strain, out, d_out, general, lo, hi, stage):
    """The elements ``lo..hi - 1`` (views of their arrays: the loops run from 0) of one pass:
    the node sums (``stage`` 1, :func:`_node_sums`, into ``out`` (N, 2) and ``d_out``
    (N, P, 2)) or the forces (``stage`` 2, :func:`_forces`, into ``out`` (N, 3) and
    ``d_out`` (N, 3, P)), ``general`` a constant of each (not inlined: the one-thread sweep
    and every thread's run share its code)."""
    tets, inverse_rest, volume, law, law_constant = arrays
    shear, shear_rate, lam, lam_rate = constants
    element_ptr, element_column, d_shear, d_shear_rate, d_lam, d_lam_rate = columns
    relax_g, relax_decay, relax_column, history, d_history = relaxation
    t, B, V, L = tets[lo:hi], inverse_rest[lo:hi], volume[lo:hi], law[lo:hi]
    if stage == 1 and general:
        _node_sums(p, v, tp, tv, t, B, V, L, out, d_out, True)
        return
    if stage == 1:
        _node_sums(p, v, tp, tv, t, B, V, L, out, d_out, False)
        return
    mine = (t, B, V, L, law_constant[lo:hi])
    own = (shear[lo:hi], shear_rate[lo:hi], lam[lo:hi], lam_rate[lo:hi])
    # the CSR's pointers of these elements (its entries stay whole)
    entries = (element_ptr[lo:hi + 1], element_column, d_shear, d_shear_rate, d_lam,
               d_lam_rate)
    memory = (relax_g[lo:hi], relax_decay[lo:hi], relax_column[lo:hi], history[lo:hi],
              d_history[lo:hi])
    if general:
        _forces(p, v, tp, tv, mine, own, nodal, entries, law_constant_column[lo:hi], memory,
                learned, node_strain, d_node_strain, out, d_out, True)
    else:
        _forces(p, v, tp, tv, mine, own, nodal, entries, law_constant_column[lo:hi], memory,
                learned, node_strain, d_node_strain, out, d_out, False)


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT, parallel=True)
def _parallel(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns, law_constant_column,
              relaxation, learned, node_strain, d_node_strain, force, d_force, general,
              buffers):
    """The passes on ``len(buffers[0]) + 1`` threads: thread ``c`` takes the ``c``-th run of
    consecutive elements and adds into ``node_strain`` / ``force`` and their tangents (the
    first) or its own buffers (``buffers``: sums, their tangents, forces, theirs; zero on
    entry, left zero), summed per node after each pass: no two threads write one value."""
    sums, d_sums, forces, d_forces = buffers
    n_elements, chunks = arrays[0].shape[0], forces.shape[0] + 1
    first = learned[2]
    for stage in (1, 2):
        if stage == 1 and not nodal:
            continue
        if stage == 1:
            node_strain[:] = 0.0
            d_node_strain[:] = 0.0
        for c in numba.prange(chunks):
            lo, hi = c * n_elements // chunks, (c + 1) * n_elements // chunks
            out = (node_strain if stage == 1 else force) if c == 0 else (
                sums[c - 1] if stage == 1 else forces[c - 1])
            d_out = (d_node_strain if stage == 1 else d_force) if c == 0 else (
                d_sums[c - 1] if stage == 1 else d_forces[c - 1])
            _stage(p, v, tp, tv, arrays, constants, nodal, columns, law_constant_column,
                   relaxation, learned, node_strain, d_node_strain, out, d_out, general, lo,
                   hi, stage)
        total, d_total = (node_strain, d_node_strain) if stage == 1 else (force, d_force)
        part, d_part = (sums, d_sums) if stage == 1 else (forces, d_forces)
        for i in numba.prange(total.shape[0]):
            for c in range(chunks - 1):
                for k in range(total.shape[1]):
                    total[i, k] += part[c, i, k]
                    part[c, i, k] = 0.0
                d_row, d_buffer = d_total[i], d_part[c, i]
                for k in range(d_row.shape[0]):
                    for q in range(d_row.shape[1]):
                        d_row[k, q] += d_buffer[k, q]
                        d_buffer[k, q] = 0.0
            if stage == 1:
                _node_pressures(node_strain, d_node_strain, node_arrays, first, i, i + 1)


@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def element_jvp(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns, kappa,
                kappa_column, law_constant_column, relaxation, first, node_strain, d_node_strain,
                force, d_force, buffers):
    """Element forces into ``force`` and their tangents into ``d_force`` (N, 3, P); tangent
    ``q`` is that of parameter ``first + q``.

    ``arrays`` ``(tets, inverse_rest, volume, law, law_constant)``; ``constants`` ``(shear,
    shear_rate, lam, lam_rate)`` per element; ``node_arrays`` ``(node_volume, node_lam,
    node_lam_rate, d_node_lam, d_node_lam_rate)`` of the nodal form (``nodal``);
    ``columns`` the CSR of the elements' parameter columns (``element_ptr``,
    ``element_column``, columns ascending) with the derivatives of the four constants there
    (``d_shear``, ``d_shear_rate``, ``d_lam``, ``d_lam_rate``); ``kappa`` the strain
    stiffening ``2 κ (G:G) G`` (``kappa_column`` its parameter or -1); ``law_constant[e]`` the
    law's own constant (``law_constant_column[e]`` the column of its logarithm or -1);
    ``relaxation`` ``(relax_g, relax_decay, relax_column, history, d_history)``: the Prony
    terms (``relax_column[e, k]`` the columns of term k's ``log g`` and ``log τ``, -1 when not
    learned) and their internal variables and tangents (n_elements, K, 6[, P]), advanced here.
    ``buffers`` ``(sums, d_sums, forces, d_forces)``, each ``(threads - 1, …)`` shaped as
    ``node_strain``, ``d_node_strain``, ``force``, ``d_force``: none (length 0) for one
    thread.

    The passes are compiled for two cases (``general`` a constant in each), as the stepper's
    (:func:`neurofuzzy.kernels.element_forces.element_forces`): for elements that are all
    St. Venant–Kirchhoff without stiffening ``κ`` or relaxation the law is a constant of the
    loop."""
    relax_g = relaxation[0]
    general = not _only_svk(arrays[3], kappa, relax_g.shape[1] > 0)
    learned = (kappa, kappa_column, first)
    if buffers[2].shape[0] > 0:
        _parallel(p, v, tp, tv, arrays, constants, nodal, node_arrays, columns,
                  law_constant_column, relaxation, learned, node_strain, d_node_strain, force,
                  d_force, general, buffers)
        return
    # (the bounds and stages as np.intp: a literal 0, 1 or 2 would compile _stage once more
    # for each, 50 s apiece)
    everything = (np.intp(0), np.intp(arrays[0].shape[0]))
    if nodal:
        node_strain[:] = 0.0
        d_node_strain[:] = 0.0
        _stage(p, v, tp, tv, arrays, constants, nodal, columns, law_constant_column, relaxation,
               learned, node_strain, d_node_strain, node_strain, d_node_strain, general,
               *everything, np.intp(1))
        _node_pressures(node_strain, d_node_strain, node_arrays, first, 0,
                        node_strain.shape[0])
    _stage(p, v, tp, tv, arrays, constants, nodal, columns, law_constant_column, relaxation,
           learned, node_strain, d_node_strain, force, d_force, general, *everything,
           np.intp(2))
