"""Prony-series relaxation in the compiled kernels, written once for the stepper and the
forward sensitivities (:mod:`neurofuzzy.forces.relaxation` is the numpy reference and says
what it is)::

    S = S_rest + Σᵢ gᵢ (S_e + rᵢ),      rᵢ' = aᵢ rᵢ - (1 - aᵢ) S_e,     aᵢ = exp(-h/τᵢ)

:func:`relaxation_tangent` is their forward derivative (the sensitivities). ``S_rest`` is the
rest of the element's stress (its law's ``S_e``, Kelvin–Voigt viscosity,
strain stiffening); ``g`` (n_elements, K) the relative moduli, ``decay`` (n_elements, K) the ``aᵢ``
of the step, ``history`` (n_elements, K, 6) the internal variables ``rᵢ`` (six entries of a
symmetric matrix, ``(00, 11, 22, 01, 02, 12)``). K = 0: no relaxation, nothing computed.
"""

import numba
import numpy as np

from .laws import elastic, stress_jvp, with_rates


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
def relaxed_stress(law, G, Gd, shear, shear_rate, pressure, pressure_rate, kappa, law_constant,
                   g, history, e):
    """``(S, S_e)``: element ``e``'s stress (:func:`~neurofuzzy.kernels.laws.stress`'s, with
    :func:`relaxed`'s Prony terms where ``g`` has any) and its law's elastic stress ``S_e``,
    the law evaluated once for both."""
    S_el = elastic(law, G, shear, pressure, law_constant)[0]
    S = with_rates(S_el, G, Gd, shear_rate, pressure_rate, kappa)
    if g.shape[1] == 0:
        return S, S_el
    return relaxed(S, S_el, g, history, e), S_el


@numba.njit(cache=True, nogil=True, inline="always")
def relax(S_el, decay, history, e):
    """In place, element ``e``'s step: ``rᵢ ← aᵢ rᵢ - (1 - aᵢ) S_e``."""
    for k in range(decay.shape[1]):
        a = decay[e, k]
        r = history[e, k]
        for i in range(6):
            r[i] = a * r[i] - (1.0 - a) * S_el[i]


@numba.njit(cache=True, nogil=True, inline="always")
def relaxation_tangent(dS, law, G, Gd, dG, dGd, shear, pressure, law_constant, d_shear,
                       d_pressure, d_law_constant, S_el, g, decay, column, history, d_history,
                       e, parameter, q):
    """``dS`` plus the tangent of element ``e``'s relaxation along tangent ``q``
    (parameter ``parameter``), ``Σᵢ gᵢ (dS_e + drᵢ) + dgᵢ (S_e + rᵢ)``; advances the
    internal variables' tangent, ``drᵢ' = aᵢ drᵢ - (1 - aᵢ) dS_e + daᵢ (rᵢ + S_e)``
    (``da/d log τ = -a ln a``, ``dg/d log g = g``)."""
    dS_el = stress_jvp(law, G, Gd, dG, dGd, shear, 0.0, pressure, 0.0, 0.0, law_constant,
                       d_shear, 0.0, d_pressure, 0.0, 0.0, d_law_constant)
    d0, d1, d2, d3, d4, d5 = dS
    for k in range(g.shape[1]):
        gk, a = g[e, k], decay[e, k]
        r, dr = history[e, k], d_history[e, k]
        dg = gk if column[e, k, 0] == parameter else 0.0
        da = -a * np.log(a) if column[e, k, 1] == parameter and a > 0.0 else 0.0
        d0 += gk * (dS_el[0] + dr[0, q]) + dg * (S_el[0] + r[0])
        d1 += gk * (dS_el[1] + dr[1, q]) + dg * (S_el[1] + r[1])
        d2 += gk * (dS_el[2] + dr[2, q]) + dg * (S_el[2] + r[2])
        d3 += gk * (dS_el[3] + dr[3, q]) + dg * (S_el[3] + r[3])
        d4 += gk * (dS_el[4] + dr[4, q]) + dg * (S_el[4] + r[4])
        d5 += gk * (dS_el[5] + dr[5, q]) + dg * (S_el[5] + r[5])
        for i in range(6):
            dr[i, q] = a * dr[i, q] - (1.0 - a) * dS_el[i] + da * (r[i] + S_el[i])
    return d0, d1, d2, d3, d4, d5
