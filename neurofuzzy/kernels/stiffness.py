"""The model's force with its stiffness and damping matrices, per item, from the per-item
functions of :mod:`.element` (the static solve's and the implicit step's Jacobians).

:func:`element_tangents` and :func:`spring_tangents` write each element's (spring's) force
into the node forces and its 12 × 12 (6 × 6) stiffness ``-∂f/∂x`` and damping ``-∂f/∂v``
into per-item arrays, which the caller assembles (``neurofuzzy.simulation.tangents``). The
nodal volumetric form couples an element to its neighbours through the node averages
``Θ_a = Σ_e (V_e/4) θ_e`` and ``Θ̇_a = Σ_e (V_e/4) tr Ġ_e``: its elastic force is
``-Σ_a (Λ_a/V_a) Θ_a ∂Θ_a/∂x`` (the energy ``Σ_a Λ_a Θ_a² / (2 V_a)``) and its viscous one
``-Σ_a (H_a/V_a) Θ̇_a ∂(Σ_e (V_e/4) tr G_e)/∂x``. The per-element matrices hold the node
pressures fixed; what their change adds, ``Σ_a (Λ_a/V_a) ∂Θ_a ∂Θ_aᵀ`` and its viscous
kin, is written by the caller as sparse products of the gradients this kernel gives per element
and corner (``gradients`` (n_elements, 3, 12): ``(V_e/4) ∂θ_e/∂x``, ``(V_e/4) ∂tr G_e/∂x``,
``(V_e/4) ∂tr Ġ_e/∂x``).

``elements`` is the elements as every kernel reads them
(:class:`neurofuzzy.simulation.layout.ElementArrays`), ``node_strain`` (n_nodes, 2) the
nodal form's node pressures (:func:`node_pressures` writes them) and ``relaxation = (g, a,
history)`` their Prony terms with the internal variables, as the stepper takes them.
"""

import numba

from .element import (deformation, element_force, element_matrices, spring_force,
                      spring_matrices, volumetric_gradients)
from .laws import volumetric
from .tuples import _green


@numba.njit(cache=True, nogil=True, inline="always")
def _gather(x, n0, n1, n2, n3):
    """The 12 node values of an element (node-major)."""
    return (x[n0, 0], x[n0, 1], x[n0, 2], x[n1, 0], x[n1, 1], x[n1, 2],
            x[n2, 0], x[n2, 1], x[n2, 2], x[n3, 0], x[n3, 1], x[n3, 2])


@numba.njit(cache=True, nogil=True)
def node_pressures(p, v, elements, node_strain):
    """The nodal volumetric form's node pressures ``(Λ_a Θ_a / V_a, H_a Θ̇_a / V_a)`` into
    ``node_strain`` (n_nodes, 2) (zero at nodes of no element)."""
    (tets, inverse_rest, volume, law, _, _, _, _, _, _, node_volume, node_lam,
     node_lam_rate) = elements
    node_strain[:] = 0.0
    for e in range(tets.shape[0]):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        B = inverse_rest[e]
        G, Gd = _green(deformation(_gather(p, n0, n1, n2, n3), B),
                       deformation(_gather(v, n0, n1, n2, n3), B))
        theta = volumetric(law[e], G)[0]
        corner = 0.25 * volume[e]
        for n in (n0, n1, n2, n3):
            node_strain[n, 0] += corner * theta
            node_strain[n, 1] += corner * (Gd[0] + Gd[1] + Gd[2])
    for i in range(node_strain.shape[0]):
        if node_volume[i] > 0.0:
            node_strain[i, 0] *= node_lam[i] / node_volume[i]
            node_strain[i, 1] *= node_lam_rate[i] / node_volume[i]


@numba.njit(cache=True, nogil=True, inline="always")
def _prony_sums(relax_g, history, e):
    """``(Σᵢ gᵢ, Σᵢ gᵢ rᵢ)`` of element ``e``'s Prony terms (six entries; zeros without)."""
    g = r0 = r1 = r2 = r3 = r4 = r5 = 0.0
    for k in range(relax_g.shape[1]):
        gk = relax_g[e, k]
        g += gk
        r0 += gk * history[e, k, 0]
        r1 += gk * history[e, k, 1]
        r2 += gk * history[e, k, 2]
        r3 += gk * history[e, k, 3]
        r4 += gk * history[e, k, 4]
        r5 += gk * history[e, k, 5]
    return g, (r0, r1, r2, r3, r4, r5)


@numba.njit(cache=True, nogil=True)
def element_tangents(p, v, elements, node_strain, relaxation, kappa, force, out):
    """Every element's force added to ``force`` (n_nodes, 3) and into ``out = (K, C,
    gradients)`` its stiffness and damping (n_elements, 12, 12) and, in the nodal
    volumetric form, its weighted volumetric gradients (n_elements, 3, 12) (module
    docstring); the force alone when ``K`` is empty, no damping when ``C`` is
    (n_elements, 0, 12)."""
    if elements.nodal:
        node_pressures(p, v, elements, node_strain)
    element_tangents_of(p, v, elements, node_strain, relaxation, kappa, force, out, 0,
                        elements.tets.shape[0])


@numba.njit(cache=True, nogil=True)
def element_tangents_of(p, v, elements, node_strain, relaxation, kappa, force, out, lo, hi):
    """:func:`element_tangents` of elements ``lo..hi - 1`` alone, the nodal form's node
    pressures (:func:`node_pressures`) already in ``node_strain``: runs of elements on
    threads of their own, each adding into a ``force`` of its own."""
    (tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam, lam_rate, nodal,
     _, _, _) = elements
    relax_g, _, history = relaxation
    K, C, gradients = out
    for e in range(lo, hi):
        n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
        x, xd = _gather(p, n0, n1, n2, n3), _gather(v, n0, n1, n2, n3)
        B = inverse_rest[e]
        if nodal:
            own, own_rate = 0.0, 0.0
            pressure = 0.25 * (node_strain[n0, 0] + node_strain[n1, 0] + node_strain[n2, 0]
                               + node_strain[n3, 0])
            pressure_rate = 0.25 * (node_strain[n0, 1] + node_strain[n1, 1]
                                    + node_strain[n2, 1] + node_strain[n3, 1])
        else:
            own, own_rate, pressure, pressure_rate = lam[e], lam_rate[e], 0.0, 0.0
        g, r6 = _prony_sums(relax_g, history, e)
        if K.shape[0] == 0:
            f = element_force(x, xd, B, volume[e], law[e], law_constant[e], shear[e],
                              shear_rate[e], own, own_rate, pressure, pressure_rate, kappa, g,
                              r6)
        else:
            f = element_matrices(x, xd, B, volume[e], law[e], law_constant[e], shear[e],
                                 shear_rate[e], own, own_rate, pressure, pressure_rate, kappa,
                                 g, r6, K[e], C[e])
        for c, n in enumerate((n0, n1, n2, n3)):
            for k in range(3):
                force[n, k] += f[3 * c + k]
        if nodal and K.shape[0]:
            a, b, d = volumetric_gradients(x, xd, B, law[e])
            corner = 0.25 * volume[e]
            for i in range(12):
                gradients[e, 0, i] = corner * a[i]
                gradients[e, 1, i] = corner * b[i]
                gradients[e, 2, i] = corner * d[i]


@numba.njit(cache=True, nogil=True)
def spring_tangents(p, v, springs, force, K, C):
    """Every spring's force added to ``force``, its stiffness and damping into ``K``, ``C``
    (n_springs, 6, 6), or the force alone when ``K`` is empty; ``springs = (a, b, stiffness,
    damping, rest, cubic)``, ``cubic`` the ``q`` of the last ``len(cubic)`` springs (as the
    stepper's :func:`~neurofuzzy.kernels.stepper._springs`)."""
    a, b, stiffness, damping, rest, cubic = springs
    plain = a.shape[0] - cubic.shape[0]
    for j in range(a.shape[0]):
        ia, ib = a[j], b[j]
        x = (p[ia, 0], p[ia, 1], p[ia, 2], p[ib, 0], p[ib, 1], p[ib, 2])
        xd = (v[ia, 0], v[ia, 1], v[ia, 2], v[ib, 0], v[ib, 1], v[ib, 2])
        q = cubic[j - plain] if j >= plain else 0.0
        if K.shape[0] == 0:
            f = spring_force(x, xd, stiffness[j], damping[j], rest[j], q)
        else:
            f = spring_matrices(x, xd, stiffness[j], damping[j], rest[j], q, K[j], C[j])
        for k in range(3):
            force[ia, k] += f[k]
            force[ib, k] += f[3 + k]
