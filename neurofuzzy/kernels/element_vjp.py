"""The element part of the compiled adjoint (:func:`neurofuzzy.kernels.adjoint.pull_back`):
every tetrahedron's ``λ · ∂F`` by the state and by its constants, on one thread or, for a
large model, on several.

For the cotangent ``λ`` of the nodal forces, ``λ · ∂F/∂p`` and ``λ · ∂F/∂v`` per node, and
``λ · ∂F`` by every element's constants (shear ``2μ``, its rate ``2μβ``, ``λ`` and ``λβ``; for
the nodal volumetric form by the node averages of the last two), by the law's own constant,
by the strain stiffening ``κ`` and, with Prony terms (:mod:`.relaxation`), by their ``log g``
and ``log τ``, turning the internal variables' cotangents back one step. Three passes for
the nodal form (the node averages ``θ̄``, ``θ̄̇``; the elements; the node pressures' cotangents
back to every element's ``θ`` and ``θ̇``), one for the element form.

An element adds into the nodes it shares with its neighbours, so the passes split over threads
as the stepper's do (:func:`.element_forces._passes_parallel`): thread ``c`` takes
the ``c``-th run of consecutive elements and adds into its own buffers, summed per node after
each pass; what belongs to an element alone (its constants' cotangents, its internal
variables) it writes in place. One function does a run of elements (:func:`_stage`); the
one-thread sweep calls it on all of them, so its code is compiled once for both.
"""

import numba
import numpy as np

from .laws import stress_vjp, volumetric
from .relaxation import relaxed_stress
from .tuples import _element_strains, _full, _mul, _sym_dot, _sym_t_mul


@numba.njit(cache=True, nogil=True, inline="always")
def _pull_columns(out, L, B, n0, n1, n2, n3):
    """The adjoint of ``F = Ds B``: ``L Bᵀ``, column j to node j + 1, minus their sum to
    node 0, added to ``out`` (N, 3)."""
    for r in range(3):
        c1 = L[3 * r] * B[0, 0] + L[3 * r + 1] * B[0, 1] + L[3 * r + 2] * B[0, 2]
        c2 = L[3 * r] * B[1, 0] + L[3 * r + 1] * B[1, 1] + L[3 * r + 2] * B[1, 2]
        c3 = L[3 * r] * B[2, 0] + L[3 * r + 1] * B[2, 1] + L[3 * r + 2] * B[2, 2]
        out[n1, r] += c1
        out[n2, r] += c2
        out[n3, r] += c3
        out[n0, r] -= c1 + c2 + c3


@numba.njit(cache=True, nogil=True)
def _stress_vjp(law, G, Gd, LS, shear, shear_rate, pressure, pressure_rate, kappa, law_constant):
    """:func:`~neurofuzzy.kernels.laws.stress_vjp`, compiled once as a function of its own and
    called by both places of :func:`_pull`: inlined there twice, every law's
    complex-step stress was inlined ten times over and the adjoint's first compilation took
    twice as long."""
    return stress_vjp(law, G, Gd, LS, shear, shear_rate, pressure, pressure_rate, kappa,
                      law_constant)


@numba.njit(cache=True, nogil=True)
def _node_sums(p, v, tets, inverse_rest, volume, law, node_strain):
    """The nodal form's first pass: every element's ``V θ / 4`` and ``V θ̇ / 4`` added into its
    corners' rows of ``node_strain`` (N, 2)."""
    for e in range(tets.shape[0]):
        n0, n1, n2, n3, _, _, _, G, Gd = _element_strains(p, v, tets, inverse_rest, e)
        corner = 0.25 * volume[e]
        theta = corner * volumetric(law[e], G)[0]
        rate = corner * (Gd[0] + Gd[1] + Gd[2])
        for node in (n0, n1, n2, n3):
            node_strain[node, 0] += theta
            node_strain[node, 1] += rate


@numba.njit(cache=True, nogil=True)
def _node_averages(node_strain, node_volume, node_adjoint, lo, hi):
    """Nodes ``lo..hi - 1``: their sums into the averages ``θ̄``, ``θ̄̇``; their pressures'
    cotangents to zero."""
    for i in range(lo, hi):
        if node_volume[i] > 0.0:
            node_strain[i, 0] /= node_volume[i]
            node_strain[i, 1] /= node_volume[i]
        node_adjoint[i, 0] = 0.0
        node_adjoint[i, 1] = 0.0


@numba.njit(cache=True, nogil=True)
def _pull(p, v, elements, kappa, lam_force, d_p, d_v, gradients, node_strain, node_adjoint,
          relaxation):
    """The elements' pass: ``λ · ∂F/∂p``, ``λ · ∂F/∂v`` into ``d_p``, ``d_v``, by the constants
    into ``gradients`` (per element; ``g_lam``, ``g_lam_rate`` only for the element form), the
    node pressures' cotangents into ``node_adjoint`` (the nodal form); returns ``λ · ∂F/∂κ``."""
    (tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam, lam_rate, nodal,
     node_volume, node_lam, node_lam_rate) = elements
    g_shear, g_shear_rate, g_lam, g_lam_rate, g_law_constant = gradients
    relax_g, relax_decay, history, lam_history, g_relax = relaxation
    total_kappa = 0.0
    for e in range(tets.shape[0]):
        n0, n1, n2, n3, B, F, Fd, G, Gd = _element_strains(p, v, tets, inverse_rest, e)
        theta, N = volumetric(law[e], G)
        theta_rate = Gd[0] + Gd[1] + Gd[2]
        if nodal:
            pressure = 0.0
            pressure_rate = 0.0
            for node in (n0, n1, n2, n3):
                pressure += 0.25 * node_lam[node] * node_strain[node, 0]
                pressure_rate += 0.25 * node_lam_rate[node] * node_strain[node, 1]
        else:
            pressure = lam[e] * theta
            pressure_rate = lam_rate[e] * theta_rate
        # the relaxed stress: its P = F S is the force's
        S6, S_el = relaxed_stress(law[e], G, Gd, shear[e], shear_rate[e], pressure,
                                  pressure_rate, kappa, law_constant[e], relax_g, history, e)
        S = _full(S6)
        # forces: columns of -V P Bᵀ (node j + 1), node 0 minus their sum; P = F S
        scale = -volume[e]
        Lc = (lam_force[n1, 0] - lam_force[n0, 0], lam_force[n2, 0] - lam_force[n0, 0],
              lam_force[n3, 0] - lam_force[n0, 0], lam_force[n1, 1] - lam_force[n0, 1],
              lam_force[n2, 1] - lam_force[n0, 1], lam_force[n3, 1] - lam_force[n0, 1],
              lam_force[n1, 2] - lam_force[n0, 2], lam_force[n2, 2] - lam_force[n0, 2],
              lam_force[n3, 2] - lam_force[n0, 2])
        LB = _mul(Lc, (B[0, 0], B[0, 1], B[0, 2], B[1, 0], B[1, 1], B[1, 2], B[2, 0], B[2, 1],
                       B[2, 2]))
        LP = (scale * LB[0], scale * LB[1], scale * LB[2], scale * LB[3], scale * LB[4],
              scale * LB[5], scale * LB[6], scale * LB[7], scale * LB[8])
        LS = _sym_t_mul(F, LP)                           # sym(Fᵀ L_P), six entries
        LG, LGd, l_shear, l_shear_rate, l_pressure, l_pressure_rate, l_kappa, l_law_constant = (
            _stress_vjp(law[e], G, Gd, LS, shear[e], shear_rate[e], pressure, pressure_rate,
                        kappa, law_constant[e]))
        total_kappa += l_kappa
        if relax_g.shape[1]:
            # S = S_rest + Σ g (S_e + r), r' = a r - (1 - a) S_e: the elastic stress' own
            # cotangent, the internal variables' and the terms' constants'
            L_el = _relaxation_vjp(LS, S_el, relax_g, relax_decay, history, lam_history,
                                   g_relax, e)
            LG2, _, l_shear2, _, l_pressure2, _, _, l_law_constant2 = _stress_vjp(
                law[e], G, Gd, L_el, shear[e], 0.0, pressure, 0.0, 0.0, law_constant[e])
            LG = (LG[0] + LG2[0], LG[1] + LG2[1], LG[2] + LG2[2], LG[3] + LG2[3],
                  LG[4] + LG2[4], LG[5] + LG2[5])
            l_shear += l_shear2
            l_pressure += l_pressure2
            l_law_constant += l_law_constant2
        g_shear[e] += l_shear
        g_law_constant[e] += l_law_constant
        g_shear_rate[e] += l_shear_rate
        if nodal:
            l_theta = 0.0
            l_theta_rate = 0.0
            for node in (n0, n1, n2, n3):
                node_adjoint[node, 0] += 0.25 * l_pressure
                node_adjoint[node, 1] += 0.25 * l_pressure_rate
        else:
            l_theta = lam[e] * l_pressure
            l_theta_rate = lam_rate[e] * l_pressure_rate
            g_lam[e] += l_pressure * theta
            g_lam_rate[e] += l_pressure_rate * theta_rate
        # the volumetric part of the strains' cotangents: π = λ θ(G), π̇ = λβ tr Ġ
        LG = _full((LG[0] + l_theta * N[0], LG[1] + l_theta * N[1], LG[2] + l_theta * N[2],
                    LG[3] + l_theta * N[3], LG[4] + l_theta * N[4], LG[5] + l_theta * N[5]))
        LGd = _full((LGd[0] + l_theta_rate, LGd[1] + l_theta_rate, LGd[2] + l_theta_rate,
                     LGd[3], LGd[4], LGd[5]))
        # L_F = L_P S + F L_G + Ḟ L_Ġ, L_Ḟ = F L_Ġ
        LPS = _mul(LP, S)
        FLG = _mul(F, LG)
        FdLGd = _mul(Fd, LGd)
        LF = (LPS[0] + FLG[0] + FdLGd[0], LPS[1] + FLG[1] + FdLGd[1],
              LPS[2] + FLG[2] + FdLGd[2], LPS[3] + FLG[3] + FdLGd[3],
              LPS[4] + FLG[4] + FdLGd[4], LPS[5] + FLG[5] + FdLGd[5],
              LPS[6] + FLG[6] + FdLGd[6], LPS[7] + FLG[7] + FdLGd[7],
              LPS[8] + FLG[8] + FdLGd[8])
        _pull_columns(d_p, LF, B, n0, n1, n2, n3)
        _pull_columns(d_v, _mul(F, LGd), B, n0, n1, n2, n3)
    return total_kappa


@numba.njit(cache=True, nogil=True)
def _pull_nodal(p, v, elements, node_adjoint, d_p, d_v):
    """The nodal form's last pass: ``π_e = ¼ Σ_a Λ_a θ̄_a``, ``π̇_e = ¼ Σ_a H_a θ̄̇_a`` with
    ``θ̄_a = Σ_e (V_e/4) θ_e / V_a``: the node pressures' cotangents back to every element's
    ``θ`` and ``θ̇``, and through them to ``d_p``, ``d_v``."""
    (tets, inverse_rest, volume, law, _, _, _, _, _, _, node_volume, node_lam,
     node_lam_rate) = elements
    for e in range(tets.shape[0]):
        n0, n1, n2, n3, B, F, Fd, G, _ = _element_strains(p, v, tets, inverse_rest, e)
        corner = 0.25 * volume[e]
        l_theta = 0.0
        l_theta_rate = 0.0
        for node in (n0, n1, n2, n3):
            if node_volume[node] > 0.0:
                share = corner / node_volume[node]
                l_theta += share * node_adjoint[node, 0] * node_lam[node]
                l_theta_rate += share * node_adjoint[node, 1] * node_lam_rate[node]
        N = volumetric(law[e], G)[1]
        # ∂θ/∂F = F N (dG = sym(Fᵀ dF)), θ̇ = tr Ġ = F : Ḟ
        FN = _mul(F, _full(N))
        LF = (l_theta * FN[0] + l_theta_rate * Fd[0], l_theta * FN[1] + l_theta_rate * Fd[1],
              l_theta * FN[2] + l_theta_rate * Fd[2], l_theta * FN[3] + l_theta_rate * Fd[3],
              l_theta * FN[4] + l_theta_rate * Fd[4], l_theta * FN[5] + l_theta_rate * Fd[5],
              l_theta * FN[6] + l_theta_rate * Fd[6], l_theta * FN[7] + l_theta_rate * Fd[7],
              l_theta * FN[8] + l_theta_rate * Fd[8])
        LFd = (l_theta_rate * F[0], l_theta_rate * F[1], l_theta_rate * F[2],
               l_theta_rate * F[3], l_theta_rate * F[4], l_theta_rate * F[5],
               l_theta_rate * F[6], l_theta_rate * F[7], l_theta_rate * F[8])
        _pull_columns(d_p, LF, B, n0, n1, n2, n3)
        _pull_columns(d_v, LFd, B, n0, n1, n2, n3)


@numba.njit(cache=True, nogil=True)
def _stage(p, v, elements, kappa, lam_force, out, d_out, adjoint_out, gradients, node_strain,
           node_adjoint, relaxation, lo, hi, stage):
    """The elements ``lo..hi - 1`` (views of their arrays: the loops run from 0) of one pass:
    the node sums (``stage`` 1, :func:`_node_sums`, into ``out`` (N, 2)), the elements'
    (``stage`` 2, :func:`_pull`: ``d_p``, ``d_v`` into ``out``, ``d_out`` (N, 3), the node
    pressures' cotangents into ``adjoint_out`` (N, 2)) or the nodal form's last
    (``stage`` 3, :func:`_pull_nodal`, into ``out``, ``d_out``); returns ``λ · ∂F/∂κ`` of
    ``stage`` 2, else 0 (not inlined: the one-thread sweep and every thread's run share its
    code)."""
    (tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam, lam_rate, nodal,
     node_volume, node_lam, node_lam_rate) = elements
    mine = (tets[lo:hi], inverse_rest[lo:hi], volume[lo:hi], law[lo:hi], law_constant[lo:hi],
            shear[lo:hi], shear_rate[lo:hi], lam[lo:hi], lam_rate[lo:hi], nodal, node_volume,
            node_lam, node_lam_rate)
    if stage == 1:
        _node_sums(p, v, mine[0], mine[1], mine[2], mine[3], out)
        return 0.0
    if stage == 3:
        _pull_nodal(p, v, mine, node_adjoint, out, d_out)
        return 0.0
    g_shear, g_shear_rate, g_lam, g_lam_rate, g_law_constant = gradients
    # (g_lam, g_lam_rate: per element for the element form, per node, and unused here, for
    # the nodal one)
    own = (g_shear[lo:hi], g_shear_rate[lo:hi], g_lam[lo:hi], g_lam_rate[lo:hi],
           g_law_constant[lo:hi])
    relax_g, relax_decay, history, lam_history, g_relax = relaxation
    memory = (relax_g[lo:hi], relax_decay[lo:hi], history[lo:hi], lam_history[lo:hi],
              g_relax[lo:hi])
    return _pull(p, v, mine, kappa, lam_force, out, d_out, own, node_strain, adjoint_out,
                 memory)


@numba.njit(cache=True, nogil=True)
def _gather(total, parts, i):
    """Node ``i``'s rows of the other threads' buffers ``parts`` (threads - 1, N, k) added
    into ``total`` (N, k), and left zero."""
    for c in range(parts.shape[0]):
        for k in range(total.shape[1]):
            total[i, k] += parts[c, i, k]
            parts[c, i, k] = 0.0


@numba.njit(cache=True, nogil=True, parallel=True)
def _parallel(p, v, elements, kappa, lam_force, d_p, d_v, gradients, g_terms, node_strain,
              node_adjoint, relaxation, buffers):
    """The passes on ``len(buffers[0]) + 1`` threads: thread ``c`` takes the ``c``-th run of
    consecutive elements and adds into ``node_strain``, ``d_p``, ``d_v`` and ``node_adjoint``
    (the first) or its own buffers (``buffers``: the sums, the node pressures' cotangents,
    ``d_p``'s, ``d_v``'s; zero on entry, left zero), summed per node after each pass: no two
    threads write one value."""
    strain_part, adjoint_part, p_part, v_part = buffers
    n_elements, chunks = elements[0].shape[0], p_part.shape[0] + 1
    nodal, node_volume = elements[9], elements[10]
    g_lam, g_lam_rate = gradients[2], gradients[3]
    n_nodes = d_p.shape[0]
    if nodal:
        node_strain[:] = 0.0
        for c in numba.prange(chunks):
            lo, hi = c * n_elements // chunks, (c + 1) * n_elements // chunks
            _stage(p, v, elements, kappa, lam_force,
                   node_strain if c == 0 else strain_part[c - 1], d_p, node_adjoint,
                   gradients, node_strain, node_adjoint, relaxation, lo, hi, np.intp(1))
        for i in numba.prange(n_nodes):
            _gather(node_strain, strain_part, i)
            _node_averages(node_strain, node_volume, node_adjoint, i, i + 1)
    kappa_parts = np.zeros(chunks)
    for c in numba.prange(chunks):
        lo, hi = c * n_elements // chunks, (c + 1) * n_elements // chunks
        kappa_parts[c] = _stage(p, v, elements, kappa, lam_force,
                                d_p if c == 0 else p_part[c - 1],
                                d_v if c == 0 else v_part[c - 1],
                                node_adjoint if c == 0 else adjoint_part[c - 1], gradients,
                                node_strain, node_adjoint, relaxation, lo, hi, np.intp(2))
    g_terms[1] += kappa_parts.sum()
    for i in numba.prange(n_nodes):
        _gather(d_p, p_part, i)
        _gather(d_v, v_part, i)
        _gather(node_adjoint, adjoint_part, i)
        if nodal:
            g_lam[i] += node_adjoint[i, 0] * node_strain[i, 0]
            g_lam_rate[i] += node_adjoint[i, 1] * node_strain[i, 1]
    if not nodal:
        return
    for c in numba.prange(chunks):
        lo, hi = c * n_elements // chunks, (c + 1) * n_elements // chunks
        _stage(p, v, elements, kappa, lam_force, d_p if c == 0 else p_part[c - 1],
               d_v if c == 0 else v_part[c - 1], node_adjoint, gradients, node_strain,
               node_adjoint, relaxation, lo, hi, np.intp(3))
    for i in numba.prange(n_nodes):
        _gather(d_p, p_part, i)
        _gather(d_v, v_part, i)


@numba.njit(cache=True, nogil=True)
def element_vjp(p, v, elements, kappa, lam_force, d_p, d_v, gradients, g_terms, node_strain,
                node_adjoint, relaxation, buffers):
    """``λ · ∂F/∂p`` into ``d_p``, ``λ · ∂F/∂v`` into ``d_v`` and ``λ · ∂F`` by every
    element's constants into ``gradients`` ``(g_shear, g_shear_rate, g_lam, g_lam_rate,
    g_law_constant)`` (per element, the law's own constant's too; with the nodal form
    ``g_lam`` and ``g_lam_rate`` are per node, by ``Λ`` and ``H``), and by the strain
    stiffening ``kappa`` into ``g_terms[1]``, for the cotangent ``λ = lam_force``.

    ``relaxation`` ``(relax_g, relax_decay, history, lam_history, g_relax)``: with Prony terms
    (:mod:`.relaxation`; ``history`` the internal variables at the step's start)
    ``lam_history`` (n_elements, K, 6) holds the cotangents of the internal variables after
    the step and leaves holding those before it; ``g_relax[e, k]`` gains the step's
    derivatives by ``log g`` and ``log τ`` of element ``e``'s term ``k``. ``buffers``
    ``(sums, adjoints, d_p's, d_v's)``, each ``(threads - 1, N, …)``: none (length 0) for one
    thread."""
    if buffers[2].shape[0] > 0:
        _parallel(p, v, elements, kappa, lam_force, d_p, d_v, gradients, g_terms, node_strain,
                  node_adjoint, relaxation, buffers)
        return
    nodal, node_volume = elements[9], elements[10]
    # (the bounds and stages as np.intp: a literal would compile _stage once more for each)
    everything = (np.intp(0), np.intp(elements[0].shape[0]))
    if nodal:
        node_strain[:] = 0.0
        _stage(p, v, elements, kappa, lam_force, node_strain, d_p, node_adjoint, gradients,
               node_strain, node_adjoint, relaxation, *everything, np.intp(1))
        _node_averages(node_strain, node_volume, node_adjoint, 0, node_strain.shape[0])
    g_terms[1] += _stage(p, v, elements, kappa, lam_force, d_p, d_v, node_adjoint, gradients,
                         node_strain, node_adjoint, relaxation, *everything, np.intp(2))
    if not nodal:
        return
    g_lam, g_lam_rate = gradients[2], gradients[3]
    for i in range(node_strain.shape[0]):
        g_lam[i] += node_adjoint[i, 0] * node_strain[i, 0]
        g_lam_rate[i] += node_adjoint[i, 1] * node_strain[i, 1]
    _stage(p, v, elements, kappa, lam_force, d_p, d_v, node_adjoint, gradients, node_strain,
           node_adjoint, relaxation, *everything, np.intp(3))


@numba.njit(cache=True, nogil=True)
def _relaxation_vjp(LS, S_el, g, decay, history, lam_history, g_relax, e):
    """The adjoint of element ``e``'s relaxation (:mod:`.relaxation`) for the cotangent
    ``L_S`` of its stress: returns the cotangent of the elastic stress ``S_e`` beyond the
    ``L_S`` it gets as part of ``S``, ``Σᵢ gᵢ L_S - (1 - aᵢ) λ_rᵢ'``; turns ``lam_history[e]``
    from the cotangents after the step (``λ_rᵢ'``) into those before it
    (``aᵢ λ_rᵢ' + gᵢ L_S``) and adds ``∂/∂ log gᵢ = gᵢ L_S : (S_e + rᵢ)`` and
    ``∂/∂ log τᵢ = -aᵢ ln aᵢ λ_rᵢ' : (rᵢ + S_e)`` to ``g_relax[e, i]``."""
    l0 = l1 = l2 = l3 = l4 = l5 = 0.0
    for k in range(g.shape[1]):
        gk, a = g[e, k], decay[e, k]
        r, lr = history[e, k], lam_history[e, k]
        total = (S_el[0] + r[0], S_el[1] + r[1], S_el[2] + r[2], S_el[3] + r[3],
                 S_el[4] + r[4], S_el[5] + r[5])
        after = (lr[0], lr[1], lr[2], lr[3], lr[4], lr[5])
        g_relax[e, k, 0] += gk * _sym_dot(LS, total)
        if a > 0.0:
            g_relax[e, k, 1] += -a * np.log(a) * _sym_dot(after, total)
        l0 += gk * LS[0] - (1.0 - a) * after[0]
        l1 += gk * LS[1] - (1.0 - a) * after[1]
        l2 += gk * LS[2] - (1.0 - a) * after[2]
        l3 += gk * LS[3] - (1.0 - a) * after[3]
        l4 += gk * LS[4] - (1.0 - a) * after[4]
        l5 += gk * LS[5] - (1.0 - a) * after[5]
        for i in range(6):
            lr[i] = a * after[i] + gk * LS[i]
    return l0, l1, l2, l3, l4, l5


