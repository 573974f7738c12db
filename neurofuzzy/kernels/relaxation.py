"""Prony-series relaxation in the compiled kernels, written once for the stepper and the
forward sensitivities (:mod:`neurofuzzy.forces.relaxation` is the numpy reference and says
what it is)::

    S = S_rest + Σᵢ gᵢ (S_e + rᵢ),      rᵢ' = aᵢ rᵢ - (1 - aᵢ) S_e,     aᵢ = exp(-h/τᵢ)

``S_rest`` is the rest of the element's stress (its law's ``S_e``, Kelvin–Voigt viscosity,
stiffening); ``g`` (n_elements, K) the relative moduli, ``decay`` (n_elements, K) the ``aᵢ``
of the step, ``history`` (n_elements, K, 6) the internal variables ``rᵢ`` (six entries of a
symmetric matrix, ``(00, 11, 22, 01, 02, 12)``). K = 0: no relaxation, nothing computed.
"""

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def relaxed(S, S_el, g, history, e):
    """``S + Σᵢ gᵢ (S_e + rᵢ)`` of element ``e`` (six entries)."""
    s0, s1, s2, s3, s4, s5 = S
    for k in range(g.shape[1]):
        gk = g[e, k]
        r = history[e, k]
        s0 += gk * (S_el[0] + r[0])
        s1 += gk * (S_el[1] + r[1])
        s2 += gk * (S_el[2] + r[2])
        s3 += gk * (S_el[3] + r[3])
        s4 += gk * (S_el[4] + r[4])
        s5 += gk * (S_el[5] + r[5])
    return s0, s1, s2, s3, s4, s5


@numba.njit(cache=True, nogil=True, inline="always")
def relax(S_el, decay, history, e):
    """In place, element ``e``'s step: ``rᵢ ← aᵢ rᵢ - (1 - aᵢ) S_e``."""
    for k in range(decay.shape[1]):
        a = decay[e, k]
        r = history[e, k]
        for i in range(6):
            r[i] = a * r[i] - (1.0 - a) * S_el[i]
