"""The elements' material law in the compiled kernels, in one place: St. Venant–Kirchhoff
elasticity with Kelvin–Voigt viscosity and (optionally) strain stiffening, as the second
Piola–Kirchhoff stress of the Green strain ``G`` and its rate ``Ġ``
(:mod:`neurofuzzy.forces.tetrahedra`, :mod:`neurofuzzy.effects.stiffening`)::

    S = (2μ + 2κ G:G) G + 2μβ Ġ + π I

with ``shear = 2μ``, ``shear_rate = 2μβ``, ``π`` the volumetric stress (per element
``λ θ + λβ θ̇``, or the nodal average: the callers form it) and ``κ`` the stiffening.

:func:`stress` is the law, the one place it is written for the kernels. Its forward derivative
(:func:`stress_jvp`, the sensitivities) and reverse derivative (:func:`stress_vjp`, the adjoint)
are generated from it by complex-step differentiation: numba compiles :func:`stress` for
complex arguments too, and ``Im S(x + i h d) / h`` is the exact directional derivative (to
round-off; no difference is taken, so no step-size error). The reverse derivative uses the
symmetry of a law with a strain energy and a dissipation potential of the strain rate. The
stepper (:mod:`neurofuzzy.kernels.stepper`), the forward sensitivities
(:mod:`neurofuzzy.kernels.sensitivity`) and the adjoint (:mod:`neurofuzzy.kernels.adjoint`)
all take the stress from here; ``tests/test_terms_registry.py`` and
``tests/test_learn_compiled.py`` check the derivatives through the kernels against the numpy
reference, which is checked against central differences.

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


#: the complex step: ``Im f(x + i h d) / h`` is the derivative of an analytic ``f`` along ``d``
#: to round-off (no difference is taken), for any ``h`` far below ``x`` and far above underflow
STEP = 1e-30


@numba.njit(cache=True, nogil=True, inline="always")
def _lift(x, d):
    """Six entries ``x + i h d``."""
    return (complex(x[0], STEP * d[0]), complex(x[1], STEP * d[1]), complex(x[2], STEP * d[2]),
            complex(x[3], STEP * d[3]), complex(x[4], STEP * d[4]), complex(x[5], STEP * d[5]))


@numba.njit(cache=True, nogil=True, inline="always")
def _slope(S):
    """Six entries ``Im S / h``."""
    return (S[0].imag / STEP, S[1].imag / STEP, S[2].imag / STEP, S[3].imag / STEP,
            S[4].imag / STEP, S[5].imag / STEP)


@numba.njit(cache=True, nogil=True, inline="always")
def stress_jvp(G, Gd, dG, dGd, shear, shear_rate, kappa, d_elastic, d_shear_rate,
               d_pressure):
    """Forward derivative of :func:`stress` by complex step (exact to round-off): ``dS`` for
    changes ``dG``, ``dĠ`` of the strains and ``d_elastic`` (of ``shear + 2κ G:G`` at fixed
    ``G``: ``d shear + 2 G:G dκ``), ``d_shear_rate``, ``d_pressure`` of the constants (six
    entries)."""
    return _slope(stress(_lift(G, dG), _lift(Gd, dGd), complex(shear, STEP * d_elastic),
                         complex(shear_rate, STEP * d_shear_rate), complex(0.0, STEP * d_pressure),
                         complex(kappa, 0.0)))


@numba.njit(cache=True, nogil=True, inline="always")
def stress_vjp(G, Gd, LS, shear, shear_rate, kappa):
    """Reverse derivative of :func:`stress` for the cotangent ``L_S`` (six entries, the
    symmetric part): ``(L_G, L_Ġ, l_shear, l_shear_rate, l_pressure, l_kappa)`` with ``L_G``,
    ``L_Ġ`` six entries each (the volumetric part of ``L_G`` is the caller's: ``π`` depends
    on the strains through its volumetric form).

    From the law by complex step: the elastic stress derives from a strain energy
    (``S = ∂ψ/∂G``) and the viscous one from a dissipation potential of ``Ġ`` alone, so
    ``∂S/∂G`` and ``∂S/∂Ġ`` are self-adjoint and ``L_G``, ``L_Ġ`` are the forward derivatives
    along ``L_S``; a constant's cotangent is ``L_S : ∂S/∂c``. (A law that breaks this
    symmetry fails the compiled-against-numpy gradient tests.)"""
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    LG = _slope(stress(_lift(G, LS), _lift(Gd, zero), complex(shear, 0.0),
                       complex(shear_rate, 0.0), complex(0.0, 0.0), complex(kappa, 0.0)))
    LGd = _slope(stress(_lift(G, zero), _lift(Gd, LS), complex(shear, 0.0),
                        complex(shear_rate, 0.0), complex(0.0, 0.0), complex(kappa, 0.0)))
    return (LG, LGd, _along(G, Gd, LS, shear, shear_rate, kappa, 1.0, 0.0, 0.0, 0.0),
            _along(G, Gd, LS, shear, shear_rate, kappa, 0.0, 1.0, 0.0, 0.0),
            _along(G, Gd, LS, shear, shear_rate, kappa, 0.0, 0.0, 1.0, 0.0),
            _along(G, Gd, LS, shear, shear_rate, kappa, 0.0, 0.0, 0.0, 1.0))


@numba.njit(cache=True, nogil=True, inline="always")
def _along(G, Gd, LS, shear, shear_rate, kappa, d_shear, d_rate, d_pressure, d_kappa):
    """``L_S : ∂S/∂c`` along one direction of the constants (shear, rate, pressure, κ)."""
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return _inner(LS, _slope(stress(_lift(G, zero), _lift(Gd, zero),
                                    complex(shear, STEP * d_shear),
                                    complex(shear_rate, STEP * d_rate),
                                    complex(0.0, STEP * d_pressure),
                                    complex(kappa, STEP * d_kappa))))
