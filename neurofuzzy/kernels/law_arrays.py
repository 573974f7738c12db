"""The elements' stress of :mod:`.laws` over arrays of elements, for the numpy force path
(:class:`neurofuzzy.forces.laws.ElementStress`): each function loops the one compiled
:func:`~.laws.stress` (or its derivatives) over K elements, reading and writing symmetric
3×3 matrices (K, M, 3, 3)."""

import numba

from .laws import stress, stress_jvp, stress_vjp, volumetric

@numba.njit(cache=True, nogil=True, inline="always")
def _entries(M, e, m):
    """Six entries of the symmetric 3×3 matrix ``M[e, m]``."""
    return (M[e, m, 0, 0], M[e, m, 1, 1], M[e, m, 2, 2], M[e, m, 0, 1], M[e, m, 0, 2],
            M[e, m, 1, 2])


@numba.njit(cache=True, nogil=True, inline="always")
def _write(out, e, m, S):
    """The symmetric 3×3 matrix of six entries ``S`` into ``out[e, m]``."""
    out[e, m, 0, 0], out[e, m, 1, 1], out[e, m, 2, 2] = S[0], S[1], S[2]
    out[e, m, 0, 1] = out[e, m, 1, 0] = S[3]
    out[e, m, 0, 2] = out[e, m, 2, 0] = S[4]
    out[e, m, 1, 2] = out[e, m, 2, 1] = S[5]


@numba.njit(cache=True, nogil=True)
def volumetric_arrays(law, G, theta, N):
    """:func:`volumetric` of K elements of laws ``law`` (K,) at symmetric Green strains ``G``
    (K, 1, 3, 3): ``θ`` into ``theta`` (K,), ``∂θ/∂G`` into ``N`` (K, 1, 3, 3)."""
    for e in range(law.shape[0]):
        t, n = volumetric(law[e], _entries(G, e, 0))
        theta[e] = t
        _write(N, e, 0, n)


@numba.njit(cache=True, nogil=True)
def law_constant_slopes(law, G, law_constant, out):
    """``out[e, 0]`` (K, 1, 3, 3): the derivative of element ``e``'s stress of unit shear
    constant by the law's own constant (:func:`stress_jvp` along ``law_constant``)."""
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for e in range(law.shape[0]):
        _write(out, e, 0, stress_jvp(law[e], _entries(G, e, 0), zero, zero, zero, 1.0, 0.0,
                                     0.0, 0.0, 0.0, law_constant[e], 0.0, 0.0, 0.0, 0.0, 0.0,
                                     1.0))


@numba.njit(cache=True, nogil=True)
def stress_arrays(law, G, Gd, constants, out):
    """``out[e, 0]`` (K, 1, 3, 3): :func:`stress` of K elements at symmetric ``G``, ``Gd``
    (K, 1, 3, 3) with their ``constants = (shear, shear_rate, pressure, pressure_rate, kappa,
    law_constant)`` ((K,) each but the strain stiffening ``kappa``)."""
    shear, shear_rate, pressure, pressure_rate, kappa, law_constant = constants
    for e in range(law.shape[0]):
        _write(out, e, 0, stress(law[e], _entries(G, e, 0), _entries(Gd, e, 0), shear[e],
                                 shear_rate[e], pressure[e], pressure_rate[e], kappa,
                                 law_constant[e]))


@numba.njit(cache=True, nogil=True)
def stress_jvp_arrays(law, G, Gd, constants, changes, out):
    """``out[e, m]`` (K, M, 3, 3): :func:`stress_jvp` of element ``e`` (``constants`` as in
    :func:`stress_arrays`) along ``changes = (dG, dGd, d_pressure, d_pressure_rate)``: the
    symmetric strain changes ``dG[e, m]``, ``dGd[e, m]`` and the volumetric stresses' changes
    ``d_pressure[e, m]``, ``d_pressure_rate[e, m]`` (the other constants held)."""
    shear, shear_rate, pressure, pressure_rate, kappa, law_constant = constants
    dG, dGd, d_pressure, d_pressure_rate = changes
    for e in range(law.shape[0]):
        g, gd = _entries(G, e, 0), _entries(Gd, e, 0)
        for m in range(dG.shape[1]):
            _write(out, e, m, stress_jvp(law[e], g, gd, _entries(dG, e, m), _entries(dGd, e, m),
                                         shear[e], shear_rate[e], pressure[e],
                                         pressure_rate[e], kappa, law_constant[e], 0.0, 0.0,
                                         d_pressure[e, m], d_pressure_rate[e, m], 0.0, 0.0))


@numba.njit(cache=True, nogil=True)
def stress_vjp_arrays(law, G, Gd, constants, LS, out):
    """:func:`stress_vjp` of K elements (``constants`` as in :func:`stress_arrays`) for the
    symmetric cotangents ``LS`` (K, 1, 3, 3), into ``out = (LG, LGd, l_pressure)``: ``L_G``,
    ``L_Ġ`` (K, 1, 3, 3) and the cotangents of ``π`` and ``π̇`` (K, 2)."""
    shear, shear_rate, pressure, pressure_rate, kappa, law_constant = constants
    LG, LGd, l_pressure = out
    for e in range(law.shape[0]):
        lg, lgd, _, _, lp, lpr, _, _ = stress_vjp(law[e], _entries(G, e, 0), _entries(Gd, e, 0),
                                                  _entries(LS, e, 0), shear[e], shear_rate[e],
                                                  pressure[e], pressure_rate[e], kappa,
                                                  law_constant[e])
        _write(LG, e, 0, lg)
        _write(LGd, e, 0, lgd)
        l_pressure[e, 0] = lp
        l_pressure[e, 1] = lpr


@numba.njit(cache=True, nogil=True)
def stress_partials(law, G, Gd, constants, out):
    """``out[e, 0..3]`` (K, 4, 3, 3): the derivatives of :func:`stress` of element ``e``
    (``constants`` as in :func:`stress_arrays`; the strain stiffening's term depends on none
    of the four) by its ``shear``, ``shear_rate``, ``π`` and ``π̇`` (it is linear in each)."""
    shear, shear_rate, pressure, pressure_rate, _, law_constant = constants
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for e in range(law.shape[0]):
        g, gd = _entries(G, e, 0), _entries(Gd, e, 0)
        for k in range(4):
            _write(out, e, k, stress_jvp(law[e], g, gd, zero, zero, shear[e], shear_rate[e],
                                         pressure[e], pressure_rate[e], 0.0, law_constant[e],
                                         1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0,
                                         1.0 if k == 2 else 0.0, 1.0 if k == 3 else 0.0, 0.0,
                                         0.0))
