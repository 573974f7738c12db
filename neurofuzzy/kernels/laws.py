"""The elements' material laws in the compiled kernels, each written once, and the stress they
make with Kelvin–Voigt viscosity and (optionally) strain stiffening, as the second
Piola–Kirchhoff stress of the Green strain ``G`` and its rate ``Ġ``
(:mod:`neurofuzzy.forces.tetrahedra` is the numpy reference)::

    S = S_law(G; 2μ, π) + 2κ (G:G) G + 2μβ Ġ + π̇ I

A **law** is one function ``law(G, shear, pressure, law_constant) -> (S_elastic, θ)`` of the
strain, the shear constant ``2μ``, the volumetric stress ``π`` and the law's own
constant ``law_constant`` (per element; laws without one ignore it): the elastic stress and
the law's volumetric strain ``θ(G)``, whose derivative ``∂θ/∂G`` is the stress of unit ``π``
(``law(G, 0, 1, 0)``). The stress is linear in ``shear`` and in ``π``. The callers form
``π = λ θ`` per element, or the node average of ``Λ θ̄`` (the nodal volumetric form), and
``π̇ = λβ tr Ġ`` likewise: the viscosity is the Kelvin–Voigt stress of the small-strain
elasticity tensor times ``β = η/E`` for every law, as FEBio's and sfepy's Kelvin–Voigt solids
write it.

- :func:`st_venant_kirchhoff`: ``S = 2μ G + π I``, ``θ = tr G`` (energy ``μ G:G + ½ λ θ²``).
- :func:`neo_hookean`: the coupled compressible neo-Hookean solid (Bonet & Wood, eq. 6.27;
  FEBio's ``neo-Hookean``), ``S = μ (I - C⁻¹) + π C⁻¹``, ``θ = ln J``
  (energy ``μ/2 (I₁ - 3) - μ ln J + ½ λ (ln J)²``). Its energy grows without bound as an
  element is squeezed flat (J → 0), where SVK's falls back to zero, and it is SVK at small
  strain (the same E, ν).
- :func:`yeoh`: Yeoh's strain-stiffening solid in the uncoupled form of Abaqus, ANSYS, COMSOL
  and sfepy, ``Ψ = C₁₀ (Ī₁ - 3) + C₂₀ (Ī₁ - 3)² + K/2 (J - 1)²`` (``Ī₁ = J^(-2/3) I₁``) with
  ``C₁₀ = μ/2``, ``C₂₀ = c C₁₀`` (``c`` the element's ``law_constant``, dimensionless) and
  ``K = λ + 2μ/3``: ``θ = J - 1``, and the law adds the shear's share ``2μ/3 θ`` to the
  caller's ``π = λ θ``. Linear elasticity with the same E, ν at small strain for any ``c``
  (``(Ī₁ - 3)²`` is of fourth order in the strain); stiffer than neo-Hookean in compression
  and tension alike as ``c`` grows (why Yeoh: :class:`neurofuzzy.validation.nonlinear.Yeoh`).

- :func:`mooney_rivlin`: the uncoupled Mooney–Rivlin solid of FEBio (``Mooney-Rivlin``),
  SOFA (``MooneyRivlin``), Abaqus and FElupe, ``Ψ = C₁₀ (Ī₁ - 3) + C₀₁ (Ī₂ - 3) + K/2 (J - 1)²``
  (``Ī₂ = J^(-4/3) I₂``) with ``C₁₀ + C₀₁ = μ/2``, ``C₀₁ = r C₁₀`` (``r`` the element's
  ``law_constant``, its own constant ``C01/C10``) and ``K = λ + 2μ/3`` as Yeoh's: linear
  elasticity with the same E, ν at small strain for any ``r``; ``r = 0`` is the uncoupled
  neo-Hookean solid.

- :func:`corotational`: corotational linear elasticity, the element of SOFA's
  ``TetrahedronFEMForceField`` (``method="polar"``) and of many real-time engines: the
  small-strain stress of the stretch ``U - I`` in the element's own rotated frame, ``P = R
  (2μ (U - I) + λ tr(U - I) I)`` with ``F = R U`` (McAdams et al. 2011's energy ``Ψ = μ |F -
  R|² + λ/2 (tr(U - I))²``). As a stress of ``G``: ``S = 2μ (I - U⁻¹) + π U⁻¹``, ``θ = tr U
  - 3``, ``U = √C`` by Newton's or the Denman–Beavers iteration (:func:`_root`). Exact under
  rigid rotation, linear elasticity at small strain; the stretch it sees grows linearly with
  the displacement where Green's strain grows quadratically, so it neither softens nor
  stiffens much under strong compression (SVK softens, neo-Hookean stiffens).

Adding a law: write its function here, name it in :data:`KERNEL_LAWS` (the next number) with a
branch in :func:`elastic`, and give it a record in :data:`neurofuzzy.forces.laws.LAW_RECORDS`
(its names, its constant, its FEBio material); its forward and reverse derivatives then come
from it by complex step (below), and ``tests/test_kernels_law.py`` checks them, ``∂θ/∂G``, the
small-strain limit and its constant for every entry of :data:`LAWS`; the force, stiffness and
adjoint checks of ``tests/test_terms_registry.py`` run for every law too.

Derivatives: :func:`stress_jvp` (the sensitivities) and :func:`stress_vjp` (the adjoint) are
generated from :func:`stress` by complex-step differentiation: numba compiles it for complex
arguments too, and ``Im S(x + i h d) / h`` is the exact directional derivative (to round-off;
no difference is taken, so no step-size error). The reverse derivative uses the symmetry of a
law with a strain energy (at fixed ``π``) and a dissipation potential of the strain rate.

Symmetric 3×3 matrices are tuples of six entries ``(00, 11, 22, 01, 02, 12)``.
"""

import numba
import numpy as np

#: The laws of the kernels in the order of their numbers (``model.elements.law``): their name
#: and whether the stress depends on the element's own constant (``law_constant``).
KERNEL_LAWS = (("st-venant-kirchhoff", False), ("neo-hookean", False), ("yeoh", True),
               ("mooney-rivlin", True), ("corotational", False))
#: Law numbers: name → number.
LAWS = {name: number for number, (name, _) in enumerate(KERNEL_LAWS)}
ST_VENANT_KIRCHHOFF = LAWS["st-venant-kirchhoff"]
NEO_HOOKEAN = LAWS["neo-hookean"]
YEOH = LAWS["yeoh"]
MOONEY_RIVLIN = LAWS["mooney-rivlin"]
COROTATIONAL = LAWS["corotational"]
#: Per law number: its stress depends on its own constant.
OWN_CONSTANT = tuple(own for _, own in KERNEL_LAWS)


@numba.njit(cache=True, nogil=True, inline="always")
def _inner(a, b):
    """``a : b`` of two symmetric matrices given by their six entries."""
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
            + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]))


# -- the laws ----------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, inline="always")
def _adjugate(m):
    """The cofactors ``(k00, k11, k22, k01, k02, k12)`` of the symmetric matrix of six
    entries ``m`` and its determinant; a zero determinant (an element squeezed flat) becomes
    NaN: no stress exists there, and the run turns NaN rather than raise."""
    k00 = m[1] * m[2] - m[5] * m[5]
    k11 = m[0] * m[2] - m[4] * m[4]
    k22 = m[0] * m[1] - m[3] * m[3]
    k01 = m[4] * m[5] - m[3] * m[2]
    k02 = m[3] * m[5] - m[4] * m[1]
    k12 = m[3] * m[4] - m[0] * m[5]
    det = m[0] * k00 + m[3] * k01 + m[4] * k02
    if det == 0.0:
        det = det + np.nan
    return (k00, k11, k22, k01, k02, k12), det


@numba.njit(cache=True, nogil=True, inline="always")
def _right_cauchy_green(G):
    """``C = I + 2G`` (six entries)."""
    return (1.0 + 2.0 * G[0], 1.0 + 2.0 * G[1], 1.0 + 2.0 * G[2], 2.0 * G[3], 2.0 * G[4],
            2.0 * G[5])


@numba.njit(cache=True, nogil=True, inline="always")
def _cofactors(G):
    """The cofactors of ``C = I + 2G`` and ``det C`` (:func:`_adjugate`)."""
    return _adjugate(_right_cauchy_green(G))


@numba.njit(cache=True, nogil=True, inline="always")
def st_venant_kirchhoff(G, shear, pressure):
    """``S = shear G + π I`` and ``θ = tr G``."""
    return ((shear * G[0] + pressure, shear * G[1] + pressure, shear * G[2] + pressure,
             shear * G[3], shear * G[4], shear * G[5]), G[0] + G[1] + G[2])


@numba.njit(cache=True, nogil=True, inline="always")
def neo_hookean(G, shear, pressure):
    """``S = ½ shear (I - C⁻¹) + π C⁻¹`` and ``θ = ln J = ½ ln det C`` (``C = I + 2G``)."""
    k, det = _cofactors(G)
    half = 0.5 * shear
    scale = (pressure - half) / det                   # (π - ½ shear) C⁻¹
    return ((half + scale * k[0], half + scale * k[1], half + scale * k[2], scale * k[3],
             scale * k[4], scale * k[5]), 0.5 * np.log(det))


@numba.njit(cache=True, nogil=True, inline="always")
def yeoh(G, shear, pressure, stiffening):
    """``S = ½ shear (1 + 2c x) J^(-2/3) (I - I₁/3 C⁻¹) + (π + shear θ/3) J C⁻¹`` with
    ``x = Ī₁ - 3``, ``c = stiffening``, and ``θ = J - 1``."""
    k, det = _cofactors(G)
    i1 = 3.0 + 2.0 * (G[0] + G[1] + G[2])
    j = np.sqrt(det)
    j23 = np.exp(np.log(det) / -3.0)                  # J^(-2/3) = (det C)^(-1/3)
    x = j23 * i1 - 3.0
    theta = j - 1.0
    deviatoric = 0.5 * shear * (1.0 + 2.0 * stiffening * x) * j23
    # S = d (I - I₁/3 C⁻¹) + (π + shear θ/3) J C⁻¹, C⁻¹ = k / det
    scale = ((pressure + shear * theta / 3.0) * j - deviatoric * i1 / 3.0) / det
    return ((deviatoric + scale * k[0], deviatoric + scale * k[1], deviatoric + scale * k[2],
             scale * k[3], scale * k[4], scale * k[5]), theta)


@numba.njit(cache=True, nogil=True, inline="always")
def mooney_rivlin(G, shear, pressure, ratio):
    """``S = 2C₁₀ J^(-2/3) (I - I₁/3 C⁻¹) + 2C₀₁ J^(-4/3) (I₁ I - C - 2/3 I₂ C⁻¹)
    + (π + shear θ/3) J C⁻¹`` with ``2C₁₀ = ½ shear / (1 + r)``, ``C₀₁ = r C₁₀``
    (``r = ratio``) and ``θ = J - 1``."""
    k, det = _cofactors(G)
    c00, c11, c22, c01, c02, c12 = _right_cauchy_green(G)
    i1 = c00 + c11 + c22
    i2 = 0.5 * (i1 * i1 - (c00 * c00 + c11 * c11 + c22 * c22
                           + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)))
    j = np.sqrt(det)
    j23 = np.exp(np.log(det) / -3.0)                  # J^(-2/3) = (det C)^(-1/3)
    theta = j - 1.0
    first = 0.5 * shear / (1.0 + ratio) * j23          # 2 C₁₀ J^(-2/3)
    second = ratio * first * j23                       # 2 C₀₁ J^(-4/3)
    diagonal = first + second * i1                     # times I
    # … - second C + scale C⁻¹, C⁻¹ = k / det
    scale = ((pressure + shear * theta / 3.0) * j - first * i1 / 3.0
             - second * 2.0 * i2 / 3.0) / det
    return ((diagonal - second * c00 + scale * k[0], diagonal - second * c11 + scale * k[1],
             diagonal - second * c22 + scale * k[2], -second * c01 + scale * k[3],
             -second * c02 + scale * k[4], -second * c12 + scale * k[5]), theta)


@numba.njit(cache=True, nogil=True, inline="always")
def _inverse(m):
    """The inverse of the symmetric matrix of six entries ``m`` (NaN where it is singular)."""
    k, det = _adjugate(m)
    r = 1.0 / det                                     # one division, not six
    return (k[0] * r, k[1] * r, k[2] * r, k[3] * r, k[4] * r, k[5] * r)


@numba.njit(cache=True, nogil=True, inline="always")
def _halfway(a, b):
    """``(a + b) / 2`` of six entries."""
    return (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]),
            0.5 * (a[3] + b[3]), 0.5 * (a[4] + b[4]), 0.5 * (a[5] + b[5]))


#: Iterations :func:`_root` may take (a stretch of 100 or 1/100 takes 12)
ROOT_ITERATIONS = 40


@numba.njit(cache=True, nogil=True, inline="always")
def _symmetric_product(a, b):
    """``sym(a b)`` of two symmetric matrices of six entries (``a b`` itself where they
    commute)."""
    return (a[0] * b[0] + a[3] * b[3] + a[4] * b[4],
            a[3] * b[3] + a[1] * b[1] + a[5] * b[5],
            a[4] * b[4] + a[5] * b[5] + a[2] * b[2],
            0.5 * (a[0] * b[3] + a[3] * b[1] + a[4] * b[5] + a[3] * b[0] + a[1] * b[3]
                   + a[5] * b[4]),
            0.5 * (a[0] * b[4] + a[3] * b[5] + a[4] * b[2] + a[4] * b[0] + a[5] * b[3]
                   + a[2] * b[4]),
            0.5 * (a[3] * b[4] + a[1] * b[5] + a[5] * b[2] + a[4] * b[3] + a[5] * b[1]
                   + a[2] * b[5]))


@numba.njit(cache=True, nogil=True, inline="always")
def _moved(old, new):
    """The largest change of the real parts of six entries, and the size it is measured by."""
    change = max(abs((new[0] - old[0]).real), abs((new[1] - old[1]).real),
                 abs((new[2] - old[2]).real), abs((new[3] - old[3]).real),
                 abs((new[4] - old[4]).real), abs((new[5] - old[5]).real))
    return change, max(abs(old[0].real), abs(old[1].real), abs(old[2].real), 1.0)


@numba.njit(cache=True, nogil=True)
def _root(G):
    """``(U, U⁻¹)`` with ``U = √C``, ``C = I + 2G``, six entries each (Higham, *Functions of
    Matrices*, ch. 6). Where every strain entry is below 0.2, Newton's iteration ``U ← ½ (U +
    sym(U⁻¹ C))`` from the series ``I + G - G²/2`` (one step at strains of a few 1e-3, two at
    a few per cent; Newton's iteration for the root is stable while ``C``'s condition number
    is below 9, as it is there). Beyond, the Denman–Beavers iteration ``Y ← ½ (Y + Z⁻¹)``,
    ``Z ← ½ (Z + Y⁻¹)`` from ``Y = C``, ``Z = I``, stable at any strain. Each stops once a
    step moves the root by less than 1e-10 of its size (quadratic: the step after is at
    round-off) and, where the strain carries a complex step, takes one step more for the
    derivative's part: every operation is analytic. A singular ``C`` (an element squeezed
    flat) gives NaN."""
    c = _right_cauchy_green(G)
    extra = 0
    if (G[0].imag != 0.0 or G[1].imag != 0.0 or G[2].imag != 0.0 or G[3].imag != 0.0
            or G[4].imag != 0.0 or G[5].imag != 0.0):
        extra = 1
    if max(abs(G[0].real), abs(G[1].real), abs(G[2].real), abs(G[3].real), abs(G[4].real),
           abs(G[5].real)) < 0.2:
        g2 = _symmetric_product(G, G)
        u = (1.0 + G[0] - 0.5 * g2[0], 1.0 + G[1] - 0.5 * g2[1], 1.0 + G[2] - 0.5 * g2[2],
             G[3] - 0.5 * g2[3], G[4] - 0.5 * g2[4], G[5] - 0.5 * g2[5])
        for _ in range(ROOT_ITERATIONS):
            q = _symmetric_product(_inverse(u), c)
            change, size = _moved(u, q)
            u = _halfway(u, q)
            if change <= 1e-10 * size:
                if extra == 0:
                    break
                extra -= 1
        return u, _inverse(u)
    y = c
    zero = G[0] * 0.0
    z = (zero + 1.0, zero + 1.0, zero + 1.0, zero, zero, zero)
    for _ in range(ROOT_ITERATIONS):
        yi, zi = _inverse(y), _inverse(z)
        change, size = _moved(y, zi)
        y, z = _halfway(y, zi), _halfway(z, yi)
        if y[0].real != y[0].real:       # NaN: an element squeezed flat
            break
        if change <= 1e-10 * size:
            if extra == 0:
                break
            extra -= 1
    return y, z


@numba.njit(cache=True, nogil=True, inline="always")
def corotational(G, shear, pressure):
    """``S = shear (I - U⁻¹) + π U⁻¹`` and ``θ = tr U - 3`` (``U = √(I + 2G)``)."""
    u, ui = _root(G)
    scale = pressure - shear
    return ((shear + scale * ui[0], shear + scale * ui[1], shear + scale * ui[2],
             scale * ui[3], scale * ui[4], scale * ui[5]), u[0] + u[1] + u[2] - 3.0)


@numba.njit(cache=True, nogil=True, inline="always")
def elastic(law, G, shear, pressure, law_constant):
    """``(S_elastic, θ)`` of element law number ``law`` (:data:`LAWS`) with the law's own
    constant ``law_constant`` (ignored by laws without one)."""
    if law == NEO_HOOKEAN:
        return neo_hookean(G, shear, pressure)
    if law == YEOH:
        return yeoh(G, shear, pressure, law_constant)
    if law == MOONEY_RIVLIN:
        return mooney_rivlin(G, shear, pressure, law_constant)
    if law == COROTATIONAL:
        return corotational(G, shear, pressure)
    return st_venant_kirchhoff(G, shear, pressure)


@numba.njit(cache=True, nogil=True, inline="always")
def volumetric(law, G):
    """``(θ, ∂θ/∂G)``: the law's volumetric strain and its gradient (six entries, the stress
    of unit ``π``)."""
    zero = G[0] * 0.0
    N, theta = elastic(law, G, zero, zero + 1.0, zero)
    return theta, N


@numba.njit(cache=True, nogil=True, inline="always")
def with_rates(S, G, Gd, shear_rate, pressure_rate, kappa):
    """``S + 2κ (G:G) G + shear_rate Ġ + π̇ I``: a law's elastic stress ``S`` (six entries)
    with strain stiffening and Kelvin–Voigt viscosity added, as :func:`stress` adds them."""
    stiff = 0.0 * kappa
    if kappa != 0.0:                   # most models have none: skip its G:G
        stiff = 2.0 * kappa * _inner(G, G)
    return (S[0] + stiff * G[0] + shear_rate * Gd[0] + pressure_rate,
            S[1] + stiff * G[1] + shear_rate * Gd[1] + pressure_rate,
            S[2] + stiff * G[2] + shear_rate * Gd[2] + pressure_rate,
            S[3] + stiff * G[3] + shear_rate * Gd[3], S[4] + stiff * G[4] + shear_rate * Gd[4],
            S[5] + stiff * G[5] + shear_rate * Gd[5])


@numba.njit(cache=True, nogil=True, inline="always")
def stress(law, G, Gd, shear, shear_rate, pressure, pressure_rate, kappa, law_constant):
    """``S = S_law(G; shear, π, c) + 2κ (G:G) G + shear_rate Ġ + π̇ I`` (six entries).

    Parameters
    ----------
    law : int
        The law's number (:data:`LAWS`).
    G, Gd : 6-tuples of float
        Green strain ``½(FᵀF - I)`` and its rate ``sym(FᵀḞ)``.
    shear, shear_rate : float
        ``2μ`` (Pa) and ``2μβ`` (Pa·s).
    pressure, pressure_rate : float
        The elastic volumetric stress ``π`` (``λ θ``, Pa) and the viscous one ``π̇``
        (``λβ tr Ġ``, Pa).
    kappa : float
        Strain stiffening ``κ`` (Pa) of the ``nonlinear_stiffening`` effect; 0 for none.
    law_constant : float
        The law's own constant ``c`` (Yeoh's ``C₂₀/C₁₀``, Mooney–Rivlin's ``C₀₁/C₁₀``;
        ignored by the others).
    """
    return with_rates(elastic(law, G, shear, pressure, law_constant)[0], G, Gd, shear_rate,
                      pressure_rate, kappa)


# -- the derivatives, by complex step ----------------------------------------------------------
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
def stress_jvp(law, G, Gd, dG, dGd, shear, shear_rate, pressure, pressure_rate, kappa,
               law_constant, d_shear, d_shear_rate, d_pressure, d_pressure_rate, d_kappa,
               d_law_constant):
    """Forward derivative of :func:`stress` (exact to round-off): ``dS`` for changes ``dG``,
    ``dĠ`` of the strains and ``d_*`` of the constants (six entries)."""
    return _slope(stress(law, _lift(G, dG), _lift(Gd, dGd), complex(shear, STEP * d_shear),
                         complex(shear_rate, STEP * d_shear_rate),
                         complex(pressure, STEP * d_pressure),
                         complex(pressure_rate, STEP * d_pressure_rate),
                         complex(kappa, STEP * d_kappa),
                         complex(law_constant, STEP * d_law_constant)))


@numba.njit(cache=True, nogil=True, inline="always")
def stress_vjp(law, G, Gd, LS, shear, shear_rate, pressure, pressure_rate, kappa, law_constant):
    """Reverse derivative of :func:`stress` for the cotangent ``L_S`` (six entries, the
    symmetric part): ``(L_G, L_Ġ, l_shear, l_shear_rate, l_pressure, l_pressure_rate,
    l_kappa, l_law_constant)`` with ``L_G``, ``L_Ġ`` six entries each (``π`` and ``π̇`` held:
    their own
    dependence on the strains is the caller's, through ``θ``).

    The elastic stress derives from a strain energy (``S = ∂ψ/∂G`` at fixed ``π``) and the
    viscous one from a dissipation potential of ``Ġ`` alone, so ``∂S/∂G`` and ``∂S/∂Ġ`` are
    self-adjoint and ``L_G``, ``L_Ġ`` are the forward derivatives along ``L_S``; a
    constant's cotangent is ``L_S : ∂S/∂c`` (the law's own constant's by one forward
    derivative). (A law that breaks this symmetry fails
    ``tests/test_kernels_law.py``.)"""
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    LG = stress_jvp(law, G, Gd, LS, zero, shear, shear_rate, pressure, pressure_rate, kappa,
                    law_constant, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    LGd = stress_jvp(law, G, Gd, zero, LS, shear, shear_rate, pressure, pressure_rate, kappa,
                     law_constant, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    N = volumetric(law, G)[1]
    # S is linear in shear_rate, π̇ and κ, and in shear and π: their cotangents in closed form
    # from the law (S_law(G; 1, 0, c) is the shear's part, N the pressure's)
    unit_shear = elastic(law, G, 1.0, 0.0, law_constant)[0]
    l_law_constant = 0.0
    if OWN_CONSTANT[law]:
        l_law_constant = _inner(LS, stress_jvp(law, G, Gd, zero, zero, shear, shear_rate,
                                             pressure, pressure_rate, kappa, law_constant,
                                             0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    return (LG, LGd, _inner(LS, unit_shear), _inner(LS, Gd), _inner(LS, N),
            LS[0] + LS[1] + LS[2], 2.0 * _inner(G, G) * _inner(LS, G), l_law_constant)
