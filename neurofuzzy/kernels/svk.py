"""The elements' material law in the compiled kernels, in one place: St. Venant–Kirchhoff
elasticity with Kelvin–Voigt viscosity and (optionally) strain stiffening, as the second
Piola–Kirchhoff stress of the Green strain ``G`` and its rate ``Ġ``
(:mod:`neurofuzzy.forces.tetrahedra`, :mod:`neurofuzzy.effects.stiffening`)::

    S = (2μ + 2κ G:G) G + 2μβ Ġ + π I

with ``shear = 2μ``, ``shear_rate = 2μβ``, ``π`` the volumetric stress (per element
``λ θ + λβ θ̇``, or the nodal average: the callers form it) and ``κ`` the stiffening.

:func:`stress` is the law; :func:`stress_jvp` its forward derivative (the sensitivities) and
:func:`stress_vjp` its reverse derivative (the adjoint), written beside it. The stepper
(:mod:`neurofuzzy.kernels.stepper`), the forward sensitivities
(:mod:`neurofuzzy.kernels.sensitivity`) and the adjoint (:mod:`neurofuzzy.kernels.adjoint`)
all take the stress from here; ``tests/test_terms_registry.py`` checks the derivatives through
the kernels against the numpy reference, which is checked against central differences.

Symmetric 3×3 matrices are tuples of six entries ``(00, 11, 22, 01, 02, 12)``.
"""

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def _inner(a, b):
    """``a : b`` of two symmetric matrices given by their six entries."""
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
            + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]))


@numba.njit(cache=True, nogil=True, inline="always")
def stress(G, Gd, shear, shear_rate, pressure, kappa):
    """``S = (shear + 2κ G:G) G + shear_rate Ġ + π I`` (six entries).

    Parameters
    ----------
    G, Gd : 6-tuples of float
        Green strain ``½(FᵀF - I)`` and its rate ``sym(FᵀḞ)``.
    shear, shear_rate : float
        ``2μ`` (Pa) and ``2μβ`` (Pa·s).
    pressure : float
        The volumetric stress ``π`` (Pa).
    kappa : float
        Strain stiffening ``κ`` (Pa); 0 for plain St. Venant–Kirchhoff.
    """
    elastic = shear
    if kappa != 0.0:
        elastic = shear + 2.0 * kappa * _inner(G, G)
    return (elastic * G[0] + shear_rate * Gd[0] + pressure,
            elastic * G[1] + shear_rate * Gd[1] + pressure,
            elastic * G[2] + shear_rate * Gd[2] + pressure,
            elastic * G[3] + shear_rate * Gd[3], elastic * G[4] + shear_rate * Gd[4],
            elastic * G[5] + shear_rate * Gd[5])


@numba.njit(cache=True, nogil=True, inline="always")
def stress_jvp(G, Gd, dG, dGd, shear, shear_rate, kappa, d_elastic, d_shear_rate,
               d_pressure):
    """Forward derivative of :func:`stress`: ``dS`` for changes ``dG``, ``dĠ`` of the strains
    and ``d_elastic`` (of ``shear + 2κ G:G`` at fixed ``G``: ``d shear + 2 G:G dκ``),
    ``d_shear_rate``, ``d_pressure`` of the constants (six entries)."""
    squared = _inner(G, G)
    elastic = shear + 2.0 * kappa * squared
    coefficient = 4.0 * kappa * _inner(G, dG) + d_elastic
    return (elastic * dG[0] + shear_rate * dGd[0] + coefficient * G[0] + d_shear_rate * Gd[0]
            + d_pressure,
            elastic * dG[1] + shear_rate * dGd[1] + coefficient * G[1] + d_shear_rate * Gd[1]
            + d_pressure,
            elastic * dG[2] + shear_rate * dGd[2] + coefficient * G[2] + d_shear_rate * Gd[2]
            + d_pressure,
            elastic * dG[3] + shear_rate * dGd[3] + coefficient * G[3] + d_shear_rate * Gd[3],
            elastic * dG[4] + shear_rate * dGd[4] + coefficient * G[4] + d_shear_rate * Gd[4],
            elastic * dG[5] + shear_rate * dGd[5] + coefficient * G[5] + d_shear_rate * Gd[5])


@numba.njit(cache=True, nogil=True, inline="always")
def stress_vjp(G, Gd, LS, shear, shear_rate, kappa):
    """Reverse derivative of :func:`stress` for the cotangent ``L_S`` (six entries, the
    symmetric part): ``(L_G, L_Ġ, l_shear, l_shear_rate, l_pressure, l_kappa)`` with ``L_G``,
    ``L_Ġ`` six entries each (the volumetric part of ``L_G`` is the caller's: ``π`` depends
    on the strains through its volumetric form)."""
    squared = _inner(G, G)
    elastic = shear + 2.0 * kappa * squared
    along = _inner(G, LS)
    extra = 4.0 * kappa * along
    LG = (elastic * LS[0] + extra * G[0], elastic * LS[1] + extra * G[1],
          elastic * LS[2] + extra * G[2], elastic * LS[3] + extra * G[3],
          elastic * LS[4] + extra * G[4], elastic * LS[5] + extra * G[5])
    LGd = (shear_rate * LS[0], shear_rate * LS[1], shear_rate * LS[2], shear_rate * LS[3],
           shear_rate * LS[4], shear_rate * LS[5])
    return LG, LGd, along, _inner(Gd, LS), LS[0] + LS[1] + LS[2], 2.0 * squared * along
