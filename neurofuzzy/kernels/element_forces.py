"""The elements' forces of the compiled stepper (:func:`neurofuzzy.kernels.stepper.advance`),
on one thread or, for a large model, on several: each element's law (:mod:`.laws`), ``S =
S_law(G; 2μ, π) + 2μβ Ġ + π̇ I`` with ``π = λ θ``, ``π̇ = λβ tr Ġ`` (per element) or the means
of the node-averaged ``Λ θ̄`` and ``H θ̄̇`` over the element's corners (the nodal volumetric
form), with its Prony relaxation (:mod:`.relaxation`). The arithmetic is that of
:class:`neurofuzzy.forces.Tetrahedra` (tested equal), written with scalars (F, Ḟ, S in
registers). The implicit step's force (:mod:`.body`) is the same code.

An element adds into the nodes it shares with its neighbours, so the threaded passes
(:func:`_passes_parallel`) give thread ``c`` the ``c``-th run of consecutive elements and its
own buffer, summed per node after each pass; the forward sensitivities and the adjoint split
theirs the same way (:mod:`.element_jvp`, :mod:`.element_vjp`).
"""

import numba

from .laws import ST_VENANT_KIRCHHOFF, stress, volumetric
from .relaxation import relax, relaxed_stress


@numba.njit(cache=True, nogil=True, inline="always")
def _row(x, n0, n1, n2, n3, r, b00, b01, b02, b10, b11, b12, b20, b21, b22):
    """Row ``r`` of ``Dx B`` (``Dx`` columns: x1 - x0, x2 - x0, x3 - x0), as three scalars."""
    d1 = x[n1, r] - x[n0, r]
    d2 = x[n2, r] - x[n0, r]
    d3 = x[n3, r] - x[n0, r]
    return (d1 * b00 + d2 * b10 + d3 * b20, d1 * b01 + d2 * b11 + d3 * b21,
            d1 * b02 + d2 * b12 + d3 * b22)


@numba.njit(cache=True, nogil=True, inline="always")
def _green(f00, f01, f02, f10, f11, f12, f20, f21, f22, g00, g01, g02, g10, g11, g12, g20, g21,
           g22):
    """``(G, Ġ)``: the Green strain ``½(FᵀF - I)`` and its rate ``sym(FᵀḞ)`` (six entries
    each) of ``F`` and ``Ḟ`` given by their entries (row r = coordinate r)."""
    G = (0.5 * (f00 * f00 + f10 * f10 + f20 * f20 - 1.0),
         0.5 * (f01 * f01 + f11 * f11 + f21 * f21 - 1.0),
         0.5 * (f02 * f02 + f12 * f12 + f22 * f22 - 1.0),
         0.5 * (f00 * f01 + f10 * f11 + f20 * f21),
         0.5 * (f00 * f02 + f10 * f12 + f20 * f22),
         0.5 * (f01 * f02 + f11 * f12 + f21 * f22))
    Gd = (f00 * g00 + f10 * g10 + f20 * g20, f01 * g01 + f11 * g11 + f21 * g21,
          f02 * g02 + f12 * g12 + f22 * g22,
          0.5 * (f00 * g01 + f10 * g11 + f20 * g21 + g00 * f01 + g10 * f11 + g20 * f21),
          0.5 * (f00 * g02 + f10 * g12 + f20 * g22 + g00 * f02 + g10 * f12 + g20 * f22),
          0.5 * (f01 * g02 + f11 * g12 + f21 * g22 + g01 * f02 + g11 * f12 + g21 * f22))
    return G, Gd


@numba.njit(cache=True, nogil=True)
def _only_svk(law, kappa, relaxing):
    """True when every element is St. Venant–Kirchhoff with no strain stiffening and no
    relaxation (most models): its volumetric stress ``π`` multiplies ``I`` as the viscous
    ``π̇`` does (``N = I``), so their node averages add into one, and the law is a constant of
    the element loop (about 6 % of the step rate at 288 and at 10,368 tetrahedra)."""
    if kappa != 0.0 or relaxing:
        return False
    for e in range(law.shape[0]):
        if law[e] != ST_VENANT_KIRCHHOFF:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def element_forces(p, v, elements, node_strain, relaxation, kappa, force, buffers):
    """Element forces into ``force`` (``elements`` the
    :class:`~neurofuzzy.simulation.layout.ElementArrays`); with ``nodal`` the volumetric
    stresses from the node averages of ``θ`` and ``θ̇ = tr Ġ`` (a pass for the averages into
    ``node_strain`` (N, 2), one for the forces); with Prony terms (``relaxation = (g, a,
    history)``, ``g`` (n_elements, K), K > 0) :mod:`neurofuzzy.kernels.relaxation`, whose
    internal variables ``history`` it advances; ``kappa`` the strain stiffening (0: none).
    Written with scalars (F, Ḟ, S in registers): 1.6 times the rate of 3×3 work arrays.

    The passes are compiled twice (``general`` a constant at each call): for elements that
    are all St. Venant–Kirchhoff without stiffening ``κ`` or relaxation (:func:`_only_svk`) the law
    is a constant of the loop and ``θ = tr G``, and the loop has no branch for other laws or
    relaxation (7 % of the step rate at 10,368 tetrahedra).

    ``buffers`` None: one thread. Else (n_chunks - 1, n_nodes, 3): the elements split into
    ``n_chunks`` runs of consecutive elements, one per thread (:func:`_passes_parallel`)."""
    (tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam, lam_rate, nodal,
     node_volume, node_lam, node_lam_rate) = elements
    relax_g, relax_decay, history = relaxation
    general = not _only_svk(law, kappa, relax_g.shape[1] > 0)
    if buffers is None:
        _passes_one_thread(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate,
                           lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate,
                           node_strain, relax_g, relax_decay, history, kappa, force, general)
    else:
        _passes_parallel(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate,
                         lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate,
                         node_strain, relax_g, relax_decay, history, kappa, force, general,
                         buffers)


@numba.njit(cache=True, nogil=True, inline="always")
def _strains(p, v, e, tets, inverse_rest):
    """Element ``e``'s nodes, ``B`` (nine scalars), ``F`` (nine), ``G`` and ``Ġ``."""
    n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
    B = inverse_rest[e]
    b00, b01, b02 = B[0, 0], B[0, 1], B[0, 2]
    b10, b11, b12 = B[1, 0], B[1, 1], B[1, 2]
    b20, b21, b22 = B[2, 0], B[2, 1], B[2, 2]
    f00, f01, f02 = _row(p, n0, n1, n2, n3, 0, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    f10, f11, f12 = _row(p, n0, n1, n2, n3, 1, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    f20, f21, f22 = _row(p, n0, n1, n2, n3, 2, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    g00, g01, g02 = _row(v, n0, n1, n2, n3, 0, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    g10, g11, g12 = _row(v, n0, n1, n2, n3, 1, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    g20, g21, g22 = _row(v, n0, n1, n2, n3, 2, b00, b01, b02, b10, b11, b12, b20, b21, b22)
    G, Gd = _green(f00, f01, f02, f10, f11, f12, f20, f21, f22, g00, g01, g02, g10, g11, g12,
                   g20, g21, g22)
    return ((n0, n1, n2, n3), (b00, b01, b02, b10, b11, b12, b20, b21, b22),
            (f00, f01, f02, f10, f11, f12, f20, f21, f22), G, Gd)


@numba.njit(cache=True, nogil=True)
def _node_pressures(node_strain, node_volume, node_lam, node_lam_rate, lo, hi, general):
    """Nodes ``lo..hi - 1``: the sums of the first pass into their pressures ``Λ θ̄`` and
    ``H θ̄̇`` (for St. Venant–Kirchhoff alone both into column 0: ``π`` and ``π̇`` both
    multiply ``I``). A loop of its own: called once per node inside the one-thread step's
    loop, it cost that step 15 % of its rate at 10,368 tetrahedra."""
    for i in range(lo, hi):
        if node_volume[i] > 0.0 and not general:
            node_strain[i, 0] = (node_lam[i] * node_strain[i, 0]
                                 + node_lam_rate[i] * node_strain[i, 1]) / node_volume[i]
            node_strain[i, 1] = 0.0
        elif node_volume[i] > 0.0:
            node_strain[i, 0] *= node_lam[i] / node_volume[i]
            node_strain[i, 1] *= node_lam_rate[i] / node_volume[i]


@numba.njit(cache=True, nogil=True)
def _nodal_sums(p, v, tets, inverse_rest, volume, law, node_strain, general):
    """The nodal form's first pass: every element's ``V θ / 4`` and ``V θ̇ / 4`` added into
    columns 0 and 1 of its corners' rows of ``node_strain``."""
    n_elements = tets.shape[0]
    for e in range(n_elements):
        nodes, _, _, G, Gd = _strains(p, v, e, tets, inverse_rest)
        if general:
            theta = volumetric(law[e], G)[0]
        else:          # θ = tr G: the off-diagonal strains compile away
            theta = volumetric(ST_VENANT_KIRCHHOFF, G)[0]
        theta_rate = Gd[0] + Gd[1] + Gd[2]
        corner = 0.25 * volume[e]
        for n in nodes:
            node_strain[n, 0] += corner * theta
            node_strain[n, 1] += corner * theta_rate


@numba.njit(cache=True, nogil=True)
def _forces(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
            lam_rate, nodal, node_strain, relax_g, relax_decay, history, kappa, force,
            general):
    """The second pass: every element's nodal forces added into ``force``, its volumetric
    stresses from ``node_strain``'s node pressures (``nodal``) or its own ``λ θ``."""
    n_elements = tets.shape[0]
    for e in range(n_elements):
        (n0, n1, n2, n3), (b00, b01, b02, b10, b11, b12, b20, b21, b22), \
            (f00, f01, f02, f10, f11, f12, f20, f21, f22), G, Gd = _strains(
                p, v, e, tets, inverse_rest)
        if nodal:
            pressure = 0.25 * (node_strain[n0, 0] + node_strain[n1, 0] + node_strain[n2, 0]
                               + node_strain[n3, 0])
            pressure_rate = 0.0
            if general:
                pressure_rate = 0.25 * (node_strain[n0, 1] + node_strain[n1, 1]
                                        + node_strain[n2, 1] + node_strain[n3, 1])
        else:
            if general:
                pressure = lam[e] * volumetric(law[e], G)[0]
            else:
                pressure = lam[e] * volumetric(ST_VENANT_KIRCHHOFF, G)[0]
            pressure_rate = lam_rate[e] * (Gd[0] + Gd[1] + Gd[2])
        if general:
            S, S_el = relaxed_stress(law[e], G, Gd, shear[e], shear_rate[e], pressure,
                                     pressure_rate, kappa, law_constant[e], relax_g, history, e)
            if relax_g.shape[1] > 0:
                relax(S_el, relax_decay, history, e)
        else:
            S = stress(ST_VENANT_KIRCHHOFF, G, Gd, shear[e], shear_rate[e], pressure,
                       pressure_rate, 0.0, 0.0)
        s00, s11, s22, s01, s02, s12 = S
        # P = F S; node j + 1 gets column j of -V P Bᵀ, node 0 minus their sum
        scale = -volume[e]
        for r in range(3):
            if r == 0:
                fa, fb, fc = f00, f01, f02
            elif r == 1:
                fa, fb, fc = f10, f11, f12
            else:
                fa, fb, fc = f20, f21, f22
            P0 = fa * s00 + fb * s01 + fc * s02
            P1 = fa * s01 + fb * s11 + fc * s12
            P2 = fa * s02 + fb * s12 + fc * s22
            q1 = scale * (P0 * b00 + P1 * b01 + P2 * b02)
            q2 = scale * (P0 * b10 + P1 * b11 + P2 * b12)
            q3 = scale * (P0 * b20 + P1 * b21 + P2 * b22)
            force[n1, r] += q1
            force[n2, r] += q2
            force[n3, r] += q3
            force[n0, r] -= q1 + q2 + q3


@numba.njit(cache=True, nogil=True)
def _passes(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
            lam_rate, nodal, node_volume, node_lam, node_lam_rate, node_strain, relax_g,
            relax_decay, history, kappa, force, general):
    """:func:`element_forces`' two passes on one thread, for any laws (``general``) or St.
    Venant–Kirchhoff alone (``π`` and ``π̇`` both multiply ``I``, so their node averages add
    into one)."""
    if nodal:
        node_strain[:] = 0.0
        _nodal_sums(p, v, tets, inverse_rest, volume, law, node_strain, general)
        _node_pressures(node_strain, node_volume, node_lam, node_lam_rate, 0,
                        node_strain.shape[0], general)
    _forces(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
            lam_rate, nodal, node_strain, relax_g, relax_decay, history, kappa, force, general)


@numba.njit(cache=True, nogil=True)
def _passes_one_thread(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate,
                       lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate, node_strain,
                       relax_g, relax_decay, history, kappa, force, general):
    """:func:`_passes` on this thread (not inlined: numba kept it, inlined, in the threaded
    variant too, and compiled that for 130 s longer)."""
    if general:
        _passes(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
                lam_rate, nodal, node_volume, node_lam, node_lam_rate, node_strain, relax_g,
                relax_decay, history, kappa, force, True)
    else:
        _passes(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
                lam_rate, nodal, node_volume, node_lam, node_lam_rate, node_strain, relax_g,
                relax_decay, history, kappa, force, False)


@numba.njit(cache=True, nogil=True)
def _stage(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
           lam_rate, nodal, node_strain, relax_g, relax_decay, history, kappa, out, general,
           lo, hi, stage):
    """One thread's share of :func:`_passes_parallel`: the nodal sums (``stage`` 1,
    :func:`_nodal_sums`, into ``out``) or the forces (``stage`` 2, :func:`_forces`, into
    ``out``) of the elements ``lo..hi - 1`` (views of their arrays: a loop from ``lo`` to
    ``hi`` costs the passes 12 % of their rate), ``general`` a constant of each."""
    t, B, V, L, s, m, mr = (tets[lo:hi], inverse_rest[lo:hi], volume[lo:hi], law[lo:hi],
                            law_constant[lo:hi], shear[lo:hi], shear_rate[lo:hi])
    lm, lr, g, a, r = (lam[lo:hi], lam_rate[lo:hi], relax_g[lo:hi], relax_decay[lo:hi],
                       history[lo:hi])
    if stage == 1 and general:
        _nodal_sums(p, v, t, B, V, L, out, True)
    elif stage == 1:
        _nodal_sums(p, v, t, B, V, L, out, False)
    elif general:
        _forces(p, v, t, B, V, L, s, m, mr, lm, lr, nodal, node_strain, g, a, r, kappa, out,
                True)
    else:
        _forces(p, v, t, B, V, L, s, m, mr, lm, lr, nodal, node_strain, g, a, r, kappa, out,
                False)


@numba.njit(cache=True, nogil=True, parallel=True)
def _passes_parallel(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate,
                     lam, lam_rate, nodal, node_volume, node_lam, node_lam_rate, node_strain,
                     relax_g, relax_decay, history, kappa, force, general, buffers):
    """:func:`_passes` on ``len(buffers) + 1`` threads: thread ``c`` takes the ``c``-th run of
    consecutive elements and adds its nodal values into ``node_strain`` / ``force`` (the
    first) or its own buffer (zero on entry, left zero), summed per node after each pass: no
    two threads write one value."""
    n_elements, chunks = tets.shape[0], buffers.shape[0] + 1
    for stage in (1, 2):
        if stage == 1 and not nodal:
            continue
        if stage == 1:
            node_strain[:] = 0.0
        total = node_strain if stage == 1 else force
        for c in numba.prange(chunks):
            lo, hi = c * n_elements // chunks, (c + 1) * n_elements // chunks
            _stage(p, v, tets, inverse_rest, volume, law, law_constant, shear, shear_rate, lam,
                   lam_rate, nodal, node_strain, relax_g, relax_decay, history, kappa,
                   total if c == 0 else buffers[c - 1], general, lo, hi, stage)
        for i in numba.prange(total.shape[0]):
            for c in range(1, chunks):
                for k in range(total.shape[1]):
                    total[i, k] += buffers[c - 1, i, k]
                    buffers[c - 1, i, k] = 0.0
            if stage == 1:
                _node_pressures(node_strain, node_volume, node_lam, node_lam_rate, i, i + 1,
                                general)
