"""Each member of a model as one per-item function of its nodes, and the derivatives generated
from it: a tetrahedron's four nodal forces (:func:`element_force`), a spring's two
(:func:`spring_force`), each a function of the item's node positions and velocities as tuples
of scalars, and their stiffness ``-∂f/∂x`` and damping ``-∂f/∂v`` matrices by complex step
(:func:`element_matrices`, :func:`spring_matrices`): numba compiles the same function for
complex arguments, and ``Im f(x + i h eₖ) / h`` is column ``k`` of the Jacobian to round-off
(no difference is taken, so no step size to tune; :data:`neurofuzzy.kernels.laws.STEP`).

The element's arithmetic is that of :mod:`neurofuzzy.kernels.stepper` (tested equal through
the model's force): ``F = Ds B``, ``G = ½(FᵀF - I)``, ``Ġ = sym(FᵀḞ)``, the stress of the
element's law (:func:`neurofuzzy.kernels.laws.stress`) with ``π = λ θ + π̄`` and
``π̇ = λβ tr Ġ + π̄̇`` (``π̄``, ``π̄̇`` the node averages of the nodal volumetric form, held
by the per-element function; the form's coupling through the nodes is the assembly's,
:mod:`neurofuzzy.kernels.stiffness`), Prony relaxation with its internal variables held
(``S += g S_e + r``, ``g = Σ gᵢ``, ``r = Σ gᵢ rᵢ``), and the nodal forces
``[f1 f2 f3] = -V P Bᵀ``, ``f0 = -(f1 + f2 + f3)``, ``P = F S``.

Node values are tuples in node-major order: ``(x0, y0, z0, x1, y1, z1, …)``.
"""

import numba
import numpy as np

from .laws import STEP, elastic, volumetric, with_rates
from .springs import magnitude
from .tuples import _full, _green, _mul


@numba.njit(cache=True, nogil=True, inline="always")
def deformation(x, B):
    """``Dx B`` (row-major, nine entries) of an element's node values ``x`` (12-tuple):
    ``F`` of positions, ``Ḟ`` of velocities."""
    d = (x[3] - x[0], x[6] - x[0], x[9] - x[0],
         x[4] - x[1], x[7] - x[1], x[10] - x[1],
         x[5] - x[2], x[8] - x[2], x[11] - x[2])
    return _mul(d, (B[0, 0], B[0, 1], B[0, 2], B[1, 0], B[1, 1], B[1, 2], B[2, 0], B[2, 1],
                    B[2, 2]))


@numba.njit(cache=True, nogil=True, inline="always")
def nodal_forces(P, B, scale):
    """``scale P Bᵀ``'s columns at nodes 1..3 and minus their sum at node 0 (12-tuple)."""
    a0, a1, a2 = _row(P, 0, B, scale)
    b0, b1, b2 = _row(P, 1, B, scale)
    c0, c1, c2 = _row(P, 2, B, scale)
    return (-(a0 + a1 + a2), -(b0 + b1 + b2), -(c0 + c1 + c2),
            a0, b0, c0, a1, b1, c1, a2, b2, c2)


@numba.njit(cache=True, nogil=True, inline="always")
def _row(P, r, B, scale):
    """Row ``r`` of ``scale P Bᵀ`` (three scalars: nodes 1, 2, 3)."""
    p0, p1, p2 = P[3 * r], P[3 * r + 1], P[3 * r + 2]
    return (scale * (p0 * B[0, 0] + p1 * B[0, 1] + p2 * B[0, 2]),
            scale * (p0 * B[1, 0] + p1 * B[1, 1] + p2 * B[1, 2]),
            scale * (p0 * B[2, 0] + p1 * B[2, 1] + p2 * B[2, 2]))


@numba.njit(cache=True, nogil=True)
def element_force(x, xd, B, volume, law, law_constant, shear, shear_rate, lam, lam_rate,
                  pressure, pressure_rate, kappa, relax_g, relax_r):
    """The one definition of a tetrahedron's force: its four nodal forces (12-tuple).

    Parameters
    ----------
    x, xd : 12-tuples
        The element's node positions and velocities (node-major).
    B : (3, 3) float
        Its inverse rest edge matrix; ``volume`` its rest volume.
    law, law_constant, shear, shear_rate, kappa
        As :func:`neurofuzzy.kernels.laws.stress`.
    lam, lam_rate : float
        The element's own ``λ`` and ``λβ`` (0 in the nodal volumetric form).
    pressure, pressure_rate : float
        The volumetric stresses added from outside the element (the nodal form's ``π̄``,
        ``π̄̇``; 0 in the element form).
    relax_g : float
        ``Σᵢ gᵢ`` of its Prony terms (0 for none); ``relax_r`` (six entries) ``Σᵢ gᵢ rᵢ``.
    """
    F = deformation(x, B)
    G, Gd = _green(F, deformation(xd, B))
    pi = lam * volumetric(law, G)[0] + pressure
    pi_rate = lam_rate * (Gd[0] + Gd[1] + Gd[2]) + pressure_rate
    S_el = elastic(law, G, shear, pi, law_constant)[0]
    S = with_rates(S_el, G, Gd, shear_rate, pi_rate, kappa)
    if relax_g != 0.0:
        S = (S[0] + relax_g * S_el[0] + relax_r[0], S[1] + relax_g * S_el[1] + relax_r[1],
             S[2] + relax_g * S_el[2] + relax_r[2], S[3] + relax_g * S_el[3] + relax_r[3],
             S[4] + relax_g * S_el[4] + relax_r[4], S[5] + relax_g * S_el[5] + relax_r[5])
    return nodal_forces(_mul(F, _full(S)), B, -volume)


@numba.njit(cache=True, nogil=True)
def volumetric_gradients(x, xd, B, law):
    """``(∂θ/∂x, ∂(tr G)/∂x, ∂(tr Ġ)/∂x)`` of an element (12-tuples each): the gradients the
    nodal volumetric form couples its elements through (``F N Bᵀ``, ``F Bᵀ``, ``Ḟ Bᵀ``,
    since ``dθ = N : dG`` with ``N`` the law's :func:`~neurofuzzy.kernels.laws.volumetric`
    gradient)."""
    F = deformation(x, B)
    Fd = deformation(xd, B)
    G, _ = _green(F, Fd)
    N = volumetric(law, G)[1]
    return (nodal_forces(_mul(F, _full(N)), B, 1.0), nodal_forces(F, B, 1.0),
            nodal_forces(Fd, B, 1.0))


@numba.njit(cache=True, nogil=True, inline="always")
def _lift(x, k):
    """The 12 entries of ``x`` as complex numbers, entry ``k`` moved by ``i h``."""
    return (complex(x[0], STEP if k == 0 else 0.0), complex(x[1], STEP if k == 1 else 0.0),
            complex(x[2], STEP if k == 2 else 0.0), complex(x[3], STEP if k == 3 else 0.0),
            complex(x[4], STEP if k == 4 else 0.0), complex(x[5], STEP if k == 5 else 0.0),
            complex(x[6], STEP if k == 6 else 0.0), complex(x[7], STEP if k == 7 else 0.0),
            complex(x[8], STEP if k == 8 else 0.0), complex(x[9], STEP if k == 9 else 0.0),
            complex(x[10], STEP if k == 10 else 0.0), complex(x[11], STEP if k == 11 else 0.0))


@numba.njit(cache=True, nogil=True)
def element_matrices(x, xd, B, volume, law, law_constant, shear, shear_rate, lam, lam_rate,
                     pressure, pressure_rate, kappa, relax_g, relax_r, K, C):
    """The element's force (returned, 12-tuple) and, generated from :func:`element_force` by
    complex step, its stiffness ``-∂f/∂x`` into ``K`` (12, 12) and damping ``-∂f/∂v`` into
    ``C`` (12, 12; none when ``C`` is (0, 12)) (the constants, ``π̄`` and ``π̄̇`` held)."""
    none = -1
    xc, xdc = _lift(x, none), _lift(xd, none)
    r = (complex(relax_r[0]), complex(relax_r[1]), complex(relax_r[2]), complex(relax_r[3]),
         complex(relax_r[4]), complex(relax_r[5]))
    args = (complex(shear), complex(shear_rate), complex(lam), complex(lam_rate),
            complex(pressure), complex(pressure_rate), complex(kappa), complex(law_constant))
    for k in range(12):
        f = element_force(_lift(x, k), xdc, B, volume, law, args[7], args[0], args[1],
                          args[2], args[3], args[4], args[5], args[6], relax_g, r)
        for i in range(12):
            K[i, k] = -f[i].imag / STEP
        if C.shape[0] == 0:                         # the stiffness alone (a static solve)
            continue
        f = element_force(xc, _lift(xd, k), B, volume, law, args[7], args[0], args[1],
                          args[2], args[3], args[4], args[5], args[6], relax_g, r)
        for i in range(12):
            C[i, k] = -f[i].imag / STEP
    f = element_force(xc, xdc, B, volume, law, args[7], args[0], args[1], args[2], args[3],
                      args[4], args[5], args[6], relax_g, r)
    return (f[0].real, f[1].real, f[2].real, f[3].real, f[4].real, f[5].real, f[6].real,
            f[7].real, f[8].real, f[9].real, f[10].real, f[11].real)


@numba.njit(cache=True, nogil=True, inline="always")
def spring_force(x, xd, stiffness, damping, rest, cubic):
    """The one definition of a spring's force (paper eqs. 3.4–3.6 with the stiffening's
    ``q x³``): node a's and node b's (6-tuple) of the ends' positions and velocities
    ``x``, ``xd`` (6-tuples, a then b)."""
    dx, dy, dz = x[3] - x[0], x[4] - x[1], x[5] - x[2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    closing = (xd[3] - xd[0]) * ux + (xd[4] - xd[1]) * uy + (xd[5] - xd[2]) * uz
    m = magnitude(stiffness, damping, cubic, length - rest, closing)[0]
    return (m * ux, m * uy, m * uz, -m * ux, -m * uy, -m * uz)


@numba.njit(cache=True, nogil=True, inline="always")
def _lift6(x, k):
    return (complex(x[0], STEP if k == 0 else 0.0), complex(x[1], STEP if k == 1 else 0.0),
            complex(x[2], STEP if k == 2 else 0.0), complex(x[3], STEP if k == 3 else 0.0),
            complex(x[4], STEP if k == 4 else 0.0), complex(x[5], STEP if k == 5 else 0.0))


@numba.njit(cache=True, nogil=True)
def spring_matrices(x, xd, stiffness, damping, rest, cubic, K, C):
    """The spring's force (returned, 6-tuple) and its stiffness ``-∂f/∂x`` and damping
    ``-∂f/∂v`` (6, 6) into ``K``, ``C``, generated from :func:`spring_force` by complex
    step."""
    xc, xdc = _lift6(x, -1), _lift6(xd, -1)
    s, c, l0, q = complex(stiffness), complex(damping), complex(rest), complex(cubic)
    for k in range(6):
        f = spring_force(_lift6(x, k), xdc, s, c, l0, q)
        for i in range(6):
            K[i, k] = -f[i].imag / STEP
        f = spring_force(xc, _lift6(xd, k), s, c, l0, q)
        for i in range(6):
            C[i, k] = -f[i].imag / STEP
    f = spring_force(xc, xdc, s, c, l0, q)
    return (f[0].real, f[1].real, f[2].real, f[3].real, f[4].real, f[5].real)
