"""Compiled discrete adjoint (numba) of :meth:`neurofuzzy.learn.Sensitivity.gradient` for
models of springs and tetrahedral elements: two calls per experiment, no Python per time step.

:func:`neurofuzzy.kernels.stepper.frames` (the driver of every forward run) runs
semi-implicit Euler over the frames and keeps the state at the start of every substep;
:func:`pull_back` runs the adjoint backwards over those states and sums, per
spring, ``λ · ∂F`` by its magnitude's bases (``x``, the closing speed, ``x³``), and per
element ``λ · ∂F`` by its four constants (shear ``2μ``, its rate ``2μβ``, ``λ`` and ``λβ``;
for the nodal volumetric form by the node averages of the last two). The caller turns them
into the gradient by the parameters with the forward kernel's CSR (``log s``, ``log c`` per
tie group, the spring effects' coefficients; for elements the same derivatives of the
constants as the forward kernel). The arithmetic is that of the numpy reference path
(:meth:`neurofuzzy.forces.Springs.vjp`, :func:`~neurofuzzy.forces.central.central_vjp`,
:meth:`neurofuzzy.forces.Tetrahedra.state_vjp` and ``parameter_vjp``; tested equal):
springs ``f = (s x + c ((v_b - v_a)·u) + q x³) u`` (``x = l - L0``, the spring effects'
extra stiffness in ``s``, their stiffening ``q = κ / L0²``), elements of each element's law
(:mod:`neurofuzzy.kernels.laws`), a node drag ``-drag v`` and constant loads.

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from .integrator import euler_update_transpose
from .springs import CLOSING, CUBIC, STRETCH, partial
from .stepper import spring_state
from .tuples import _edges, _full, _green, _mul, _sym_dot, _sym_t_mul
from .laws import stress_vjp, volumetric
from .relaxation import relaxed_stress


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
def _stress_vjp(law, G, Gd, LS, shear, shear_rate, pressure, pressure_rate, kappa, stiffening):
    """:func:`~neurofuzzy.kernels.laws.stress_vjp`, compiled once as a function of its own and
    called by both places of :func:`_element_vjp`: inlined there twice, every law's
    complex-step stress was inlined ten times over and the adjoint's first compilation took
    twice as long."""
    return stress_vjp(law, G, Gd, LS, shear, shear_rate, pressure, pressure_rate, kappa,
                      stiffening)


@numba.njit(cache=True, nogil=True)
def _element_vjp(p, v, elements, kappa, lam_force, d_p, d_v, g_shear, g_shear_rate, g_lam,
                 g_lam_rate, g_stiffening, g_terms, node_strain, node_adjoint, relax_g,
                 relax_decay, history, lam_history, g_relax):
    """``λ · ∂F/∂p`` into ``d_p``, ``λ · ∂F/∂v`` into ``d_v`` and ``λ · ∂F`` by every
    element's constants into ``g_*`` (per element, the law's stiffening constant's too; with
    the nodal form ``g_lam`` and ``g_lam_rate`` are per node, by ``Λ`` and ``H``), and by the
    strain stiffening ``kappa`` into ``g_terms[1]``, for the cotangent ``λ = lam_force``.

    With Prony terms (:mod:`.relaxation`; ``history`` the internal variables at the step's
    start) ``lam_history`` (n_elements, K, 6) holds the cotangents of the internal variables
    after the step and leaves holding those before it; ``g_relax[e, k]`` gains the step's
    derivatives by ``log g`` and ``log τ`` of element ``e``'s term ``k``."""
    (tets, inverse_rest, volume, law, stiffening, shear, shear_rate, lam, lam_rate, nodal,
     node_volume, node_lam, node_lam_rate) = elements
    if nodal:                      # the node averages θ̄, θ̄̇
        node_strain[:] = 0.0
        for e in range(tets.shape[0]):
            n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
            G, Gd = _green(_edges(p, n0, n1, n2, n3, inverse_rest[e]),
                           _edges(v, n0, n1, n2, n3, inverse_rest[e]))
            corner = 0.25 * volume[e]
            theta = corner * volumetric(law[e], G)[0]
            rate = corner * (Gd[0] + Gd[1] + Gd[2])
            for node in (n0, n1, n2, n3):
                node_strain[node, 0] += theta
                node_strain[node, 1] += rate
        for i in range(node_strain.shape[0]):
            if node_volume[i] > 0.0:
                node_strain[i, 0] /= node_volume[i]
                node_strain[i, 1] /= node_volume[i]
            node_adjoint[i, 0] = 0.0
            node_adjoint[i, 1] = 0.0
    for e in range(tets.shape[0]):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        F = _edges(p, n0, n1, n2, n3, B)
        Fd = _edges(v, n0, n1, n2, n3, B)
        G, Gd = _green(F, Fd)
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
                                  pressure_rate, kappa, stiffening[e], relax_g, history, e)
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
        LG, LGd, l_shear, l_shear_rate, l_pressure, l_pressure_rate, l_kappa, l_stiffening = (
            _stress_vjp(law[e], G, Gd, LS, shear[e], shear_rate[e], pressure, pressure_rate,
                        kappa, stiffening[e]))
        g_terms[1] += l_kappa
        if relax_g.shape[1]:
            # S = S_rest + Σ g (S_e + r), r' = a r - (1 - a) S_e: the elastic stress' own
            # cotangent, the internal variables' and the terms' constants'
            L_el = _relaxation_vjp(LS, S_el, relax_g, relax_decay, history, lam_history,
                                   g_relax, e)
            LG2, _, l_shear2, _, l_pressure2, _, _, l_stiffening2 = _stress_vjp(
                law[e], G, Gd, L_el, shear[e], 0.0, pressure, 0.0, 0.0, stiffening[e])
            LG = (LG[0] + LG2[0], LG[1] + LG2[1], LG[2] + LG2[2], LG[3] + LG2[3],
                  LG[4] + LG2[4], LG[5] + LG2[5])
            l_shear += l_shear2
            l_pressure += l_pressure2
            l_stiffening += l_stiffening2
        g_shear[e] += l_shear
        g_stiffening[e] += l_stiffening
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
    if not nodal:
        return
    # π_e = ¼ Σ_a Λ_a θ̄_a, π̇_e = ¼ Σ_a H_a θ̄̇_a, θ̄_a = Σ_e (V_e/4) θ_e / V_a: the node
    # pressures' cotangents to Λ, H and back to every element's θ and θ̇
    for i in range(node_strain.shape[0]):
        g_lam[i] += node_adjoint[i, 0] * node_strain[i, 0]
        g_lam_rate[i] += node_adjoint[i, 1] * node_strain[i, 1]
    for e in range(tets.shape[0]):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        corner = 0.25 * volume[e]
        l_theta = 0.0
        l_theta_rate = 0.0
        for node in (n0, n1, n2, n3):
            if node_volume[node] > 0.0:
                share = corner / node_volume[node]
                l_theta += share * node_adjoint[node, 0] * node_lam[node]
                l_theta_rate += share * node_adjoint[node, 1] * node_lam_rate[node]
        F = _edges(p, n0, n1, n2, n3, B)
        Fd = _edges(v, n0, n1, n2, n3, B)
        N = volumetric(law[e], _green(F, Fd)[0])[1]
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


@numba.njit(cache=True, nogil=True)
def pull_back(a, b, stiffness, damping, rest, cubic, elements, kappa, relax_g, relax_decay,
              drag, weight, h, n_frames, substeps, start_index, states_p, states_v, states_r,
              states_f, unit_mass_force, frame_adjoint, d_springs, d_elements, g_relax,
              g_mass, g_load, g_terms):
    """The backward sweep: ``frame_adjoint[t]`` (n_frames, N, 3) is ``∂L/∂p(t)``; adds
    ``Σ λ_F · ∂F/∂s_j``, ``Σ λ_F · ∂F/∂c_j`` and (when ``d_springs`` has a third row)
    ``Σ λ_F · ∂F/∂κ_j`` to ``d_springs[:, j]`` (the bases of
    :func:`.sensitivity._spring_tangents`; ``cubic`` the ``q`` of the last springs) over
    every substep (``λ_F = h W λ_v'``, the cotangent of the step's force), and those
    of the element constants to ``d_elements`` and of the Prony terms' ``log g``, ``log τ``
    to ``g_relax`` (n_elements, K, 2) (see :func:`_element_vjp`; the internal variables'
    cotangents run on across window starts, as their values do forwards). With the forces
    ``states_f`` of the forward sweep (learned masses), ``Σ λ_F · ∂(W F)/∂log m / W`` into
    ``g_mass`` (N,): ``-λ_F · (F - F_unit)``, ``unit_mass_force`` the forces proportional to
    the mass (gravity), which ``W F`` does not see. The effects' cotangents: ``Σ λ_F`` per
    node into ``g_load`` (N, 3; a constant force's direction takes it, empty when none is
    learned), ``Σ λ_F · ∂F/∂drag = -Σ λ_F · v`` into ``g_terms[0]`` (when ``g_load`` is not
    empty) and the elements' ``Σ λ_F · ∂F/∂κ`` into ``g_terms[1]``. ``elements`` None: a
    model without elements, which numba compiles without the element code (it prunes a
    branch on an argument that is None)."""
    n_nodes = frame_adjoint.shape[1]
    effects = g_load.shape[0] > 0
    g_shear, g_shear_rate, g_lam, g_lam_rate, g_stiffening = d_elements
    cubic_basis = d_springs.shape[0] > 2
    plain = a.shape[0] - cubic.shape[0]        # the last springs' q: cubic
    node_strain = np.zeros((n_nodes, 2))
    node_adjoint = np.zeros((n_nodes, 2))
    lam_p = np.zeros((n_nodes, 3))
    lam_v = np.zeros((n_nodes, 3))
    lam_force = np.empty((n_nodes, 3))
    lam_history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6))
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
            euler_update_transpose(lam_p, lam_v, weight, h, lam_force)
            if states_f.shape[0]:
                force = states_f[step]
                for i in range(n_nodes):
                    for k in range(3):
                        g_mass[i] -= lam_force[i, k] * (force[i, k] - unit_mass_force[i, k])
            for i in range(n_nodes):
                for k in range(3):
                    d_p[i, k] = 0.0
                    d_v[i, k] = -drag * lam_force[i, k]
            if effects:                # the constant forces' and the drag's parameters
                for i in range(n_nodes):
                    for k in range(3):
                        g_load[i, k] += lam_force[i, k]
                        g_terms[0] -= lam_force[i, k] * v[i, k]
            for j in range(a.shape[0]):
                ia, ib = a[j], b[j]
                ux, uy, uz, length, closing, stretch, magnitude, slope = spring_state(
                    p, v, ia, ib, stiffness[j], damping[j], rest[j],
                    cubic[j - plain] if j >= plain else 0.0)
                wx = v[ib, 0] - v[ia, 0]
                wy = v[ib, 1] - v[ia, 1]
                wz = v[ib, 2] - v[ia, 2]
                # node a gets +f, node b -f: the cotangent of f is λ_a - λ_b
                fx = lam_force[ia, 0] - lam_force[ib, 0]
                fy = lam_force[ia, 1] - lam_force[ib, 1]
                fz = lam_force[ia, 2] - lam_force[ib, 2]
                along = ux * fx + uy * fy + uz * fz
                d_springs[0, j] += partial(STRETCH, stretch, closing) * along
                d_springs[1, j] += partial(CLOSING, stretch, closing) * along
                if cubic_basis:                  # a learned stiffening
                    d_springs[2, j] += partial(CUBIC, stretch, closing) * along
                # central_vjp with ∂m/∂l = slope, ∂m/∂c = c
                ratio = magnitude / length
                rate = damping[j] * along / length
                lx = slope * along * ux + ratio * (fx - along * ux) + rate * (wx - closing * ux)
                ly = slope * along * uy + ratio * (fy - along * uy) + rate * (wy - closing * uy)
                lz = slope * along * uz + ratio * (fz - along * uz) + rate * (wz - closing * uz)
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
            if elements is not None:   # None: no elements, and no element code compiled
                _element_vjp(p, v, elements, kappa, lam_force, d_p, d_v, g_shear,
                             g_shear_rate, g_lam, g_lam_rate, g_stiffening, g_terms,
                             node_strain, node_adjoint, relax_g, relax_decay, states_r[step],
                             lam_history, g_relax)
            for i in range(n_nodes):
                for k in range(3):
                    lam_p[i, k] += d_p[i, k]
                    lam_v[i, k] += d_v[i, k]
