"""The tetrahedral elements' material laws, by name, and their numpy form (the oracle the
compiled laws of :mod:`neurofuzzy.kernels.laws` are tested against).

A law gives the elastic second Piola–Kirchhoff stress of the Green strain ``G`` as
``S = 2μ D(G) + π N(G)`` with ``π`` the volumetric stress (``λ θ`` per element, or the node
average: :class:`~neurofuzzy.forces.tetra_geometry.ElementConstants`), ``θ(G)`` the law's
volumetric strain and ``N = ∂θ/∂G``:

========================  ==================  ===========  ==============
law                       ``D(G)``            ``θ(G)``     ``N(G)``
========================  ==================  ===========  ==============
``st-venant-kirchhoff``   ``G``               ``tr G``     ``I``
``neo-hookean``           ``½ (I - C⁻¹)``     ``ln J``     ``C⁻¹``
``yeoh``                  see below           ``J - 1``    ``J C⁻¹``
========================  ==================  ===========  ==============

(``C = I + 2G = FᵀF``, ``J = det F``). The neo-Hookean law is the coupled compressible solid
``Ψ = μ/2 (I₁ - 3) - μ ln J + λ/2 (ln J)²`` (Bonet & Wood, *Nonlinear Continuum Mechanics for
Finite Element Analysis*, eq. 6.27; FEBio's ``neo-Hookean``, ArtiSynth's
``NeoHookeanMaterial``): its energy grows without bound as an element is squeezed flat, where
St. Venant–Kirchhoff's falls back to zero (SVK softens beyond about 30 % compression, under a
probe), and both are linear elasticity with the same E and ν at small strain. Kelvin–Voigt
viscosity (``2μβ Ġ + λβ tr Ġ I``, ``β = η/E``) is the same for every law.

The ``yeoh`` law is Yeoh's strain-stiffening solid, uncoupled as Abaqus, ANSYS, COMSOL and sfepy
write it, ``Ψ = C₁₀ (Ī₁ - 3) + C₂₀ (Ī₁ - 3)² + K/2 (J - 1)²`` (``Ī₁ = J^(-2/3) I₁``), with
``C₁₀ = μ/2``, ``C₂₀ = c C₁₀`` for the element's dimensionless ``stiffening`` ``c`` and the
bulk modulus ``K = λ + 2μ/3``: ``D = ½ (1 + 2c (Ī₁ - 3)) J^(-2/3) (I - I₁/3 C⁻¹) + θ/3 N``
(the shear's share of ``K``). At small strain it is linear elasticity with the same E and ν
for every ``c``; it stiffens with strain as ``c`` grows. Why Yeoh for tissue:
:class:`neurofuzzy.validation.nonlinear.Yeoh`. Its ``dD`` and ``dN`` here are complex-step
derivatives of ``D`` and ``N`` (the kernels generate theirs from their own stress function
alike); ``D`` is affine in ``c``, so the force's derivative by ``c`` is that of
``D(G; 1) - D(G; 0)`` (:meth:`~neurofuzzy.forces.TetrahedronForce.stiffening_forces`).

The derivatives ``dD`` and ``dN`` along a change ``dG`` are self-adjoint linear maps (the
second derivatives of an energy), so the same function serves the forward and the reverse
derivative.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError, closest_name

#: The laws by name; a law's number (``model.element_law``) is its position here, the same in
#: the compiled kernels (:mod:`neurofuzzy.kernels.laws`, checked by the tests).
LAWS = ("st-venant-kirchhoff", "neo-hookean", "yeoh")
#: Short names accepted for the laws.
ALIASES = {"svk": "st-venant-kirchhoff", "stvk": "st-venant-kirchhoff",
           "neohookean": "neo-hookean", "nh": "neo-hookean"}
#: Yeoh's law, whose elements carry a stiffening constant (``element_stiffening``).
YEOH = LAWS.index("yeoh")
#: The laws whose elements carry their own stiffening constant (``element_stiffening``,
#: learned as ``log_stiffening``), with its name: a law added with a constant is named here
#: once, and the learner, files, exports, words and report treat its elements' constant as
#: Yeoh's (elements of the other laws keep theirs unused).
STIFFENING_CONSTANT = {YEOH: "C20/C10"}


def stiffens(law) -> np.ndarray:
    """bool, the shape of ``law`` (law numbers): which elements' law has its own stiffening
    constant (:data:`STIFFENING_CONSTANT`)."""
    return np.isin(law, tuple(STIFFENING_CONSTANT))
#: Yeoh's ``C₂₀/C₁₀`` of an element when none is given: in uniaxial stress (ν = 0.45) 1.65
#: times as stiff as neo-Hookean at 30 % compression, 2.2 times at 40 %, 1.35 times at 30 %
#: extension
DEFAULT_STIFFENING = 1.0


def law_number(name) -> int:
    """The number of law ``name`` (a name of :data:`LAWS`, an alias, or already a number)."""
    if isinstance(name, (int, np.integer)):
        if not 0 <= int(name) < len(LAWS):
            raise InputError(f"got law number {int(name)}; expected 0..{len(LAWS) - 1} "
                             f"({', '.join(LAWS)})", key="law")
        return int(name)
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    key = ALIASES.get(key.replace("-", ""), key)
    if key not in LAWS:
        hint = closest_name(str(name), LAWS)
        raise InputError(f"unknown material law {name!r}; expected one of {list(LAWS)}"
                         + (f" (did you mean {hint!r}?)" if hint else ""), key="law")
    return LAWS.index(key)


def law_numbers(value, n: int) -> np.ndarray:
    """(n,) law numbers of ``value``: None (St. Venant–Kirchhoff), one name or number for all,
    or one per element."""
    if value is None:
        return np.zeros(n, np.intp)
    if isinstance(value, (str, int, np.integer)):
        return np.full(n, law_number(value), np.intp)
    values = np.asarray(value)
    if values.shape != (n,):
        raise InputError(f"got shape {values.shape}; expected one law for all elements or "
                         f"({n},), one per element", key="element_law")
    if np.issubdtype(values.dtype, np.integer):
        numbers = values.astype(np.intp)
        bad = (numbers < 0) | (numbers >= len(LAWS))
        if np.any(bad):
            law_number(int(numbers[np.flatnonzero(bad)[0]]))       # raises with the message
        return numbers
    names, index = np.unique(values.astype(str), return_inverse=True)
    return np.array([law_number(name) for name in names], np.intp)[index]


def stiffening_array(value, n: int) -> np.ndarray:
    """(n,) Yeoh ``C₂₀/C₁₀`` of n elements: ``None`` for :data:`DEFAULT_STIFFENING`, one value
    for all, or one per element. Elements of the other laws keep theirs unused (so a model
    whose elements later become Yeoh's starts from it, the default unless given).

    Raises
    ------
    InputError
        On a wrong shape, or a value that is negative, NaN or infinite.
    """
    array = np.asarray(DEFAULT_STIFFENING if value is None else value, float)
    if array.ndim > 1 or (array.ndim == 1 and array.shape != (n,)):
        raise InputError(f"got shape {array.shape}; expected one value for all elements or "
                         f"({n},), one per element", key="element_stiffening")
    array = np.ascontiguousarray(np.broadcast_to(array, (n,)))
    bad = ~(np.isfinite(array) & (array >= 0))
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        raise InputError(f"element {first} has stiffening {array[first]:g}; Yeoh's C20/C10 "
                         "must be a number >= 0 (0 is the neo-Hookean solid; a negative one "
                         "softens with strain and loses stability)", key="element_stiffening")
    return array


@dataclass(frozen=True)
class LawParts:
    """``D``, ``N`` (K, 3, 3), ``θ`` (K,) of every element and the maps ``dD``, ``dN`` of a
    change (K, ..., 3, 3) of ``G`` (self-adjoint: also the reverse derivatives)."""

    D: np.ndarray
    N: np.ndarray
    theta: np.ndarray
    dD: Callable[[np.ndarray], np.ndarray]
    dN: Callable[[np.ndarray], np.ndarray]


def _per_element(values: np.ndarray, like: np.ndarray) -> np.ndarray:
    """(K, 1, ..., 1, 3, 3) view of (K, 3, 3) ``values`` against (K, ..., 3, 3) ``like``."""
    return values.reshape(values.shape[:1] + (1,) * (like.ndim - 3) + values.shape[1:])


def _adjugate(C: np.ndarray) -> np.ndarray:
    """(K, 3, 3) adjugates (transposed cofactors) of (K, 3, 3) matrices."""
    rows = [[1, 2], [0, 2], [0, 1]]
    out = np.empty_like(C)
    for i in range(3):
        for j in range(3):
            minor = C[:, rows[j]][:, :, rows[i]]
            out[:, i, j] = (-1) ** (i + j) * (minor[:, 0, 0] * minor[:, 1, 1]
                                              - minor[:, 0, 1] * minor[:, 1, 0])
    return out


#: the complex step of the Yeoh law's derivatives (:func:`_yeoh_parts`)
STEP = 1e-30


def _yeoh_parts(G: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(D, N, θ)`` of the Yeoh law for Green strains (..., 3, 3) (real or complex) and
    stiffening constants broadcast against them (..., 1, 1): ``C⁻¹`` as the adjugate (rows the
    cross products of ``C``'s columns) over ``det C``."""
    C = np.eye(3) + 2.0 * G
    c0, c1, c2 = C[..., :, 0], C[..., :, 1], C[..., :, 2]
    adjugate = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=-2)
    det = np.sum(c0 * adjugate[..., 0, :], axis=-1)[..., None, None]
    inverse = adjugate / det
    j = np.sqrt(det)
    j23 = det ** (-1.0 / 3.0)
    i1 = np.trace(C, axis1=-2, axis2=-1)[..., None, None]
    theta = j - 1.0
    N = j * inverse
    D = 0.5 * (1.0 + 2.0 * c * (j23 * i1 - 3.0)) * j23 * (np.eye(3) - i1 / 3.0 * inverse) \
        + theta / 3.0 * N
    return D, N, theta[..., 0, 0]


def law_parts(law: np.ndarray, G: np.ndarray, stiffening=None) -> LawParts:
    """:class:`LawParts` of (K, 3, 3) Green strains for per-element law numbers (K,) and
    Yeoh's stiffening constants (K,) (default 0). The Yeoh law's ``dD`` and ``dN`` are its
    complex-step derivatives (``Im D(G + i h X) / h``: exact to round-off)."""
    K = len(G)
    law = np.asarray(law)
    eye = np.broadcast_to(np.eye(3), G.shape)
    neo = law == LAWS.index("neo-hookean")
    yeoh = law == YEOH
    if not (neo.any() or yeoh.any()):
        return LawParts(G, eye, np.trace(G, axis1=1, axis2=2), lambda X: X,
                        lambda X: np.zeros_like(X))
    C = np.where(neo[:, None, None], eye + 2.0 * G, eye)
    with np.errstate(invalid="ignore", divide="ignore"):
        # the adjugate over the determinant: an element squeezed flat gives inf/NaN (the run
        # diverges and says so), where np.linalg.inv would raise
        det = np.linalg.det(C)
        inverse = np.where(neo[:, None, None], _adjugate(C) / det[:, None, None], eye)
        log_j = 0.5 * np.log(det)
    D = np.where(neo[:, None, None], 0.5 * (eye - inverse), G)
    N = inverse
    theta = np.where(neo, log_j, np.trace(G, axis1=1, axis2=2))
    c = np.broadcast_to(np.asarray(0.0 if stiffening is None else stiffening, float), (K,))
    c = c.reshape(K, 1, 1)
    if yeoh.any():
        with np.errstate(invalid="ignore", divide="ignore"):
            yeoh_D, yeoh_N, yeoh_theta = _yeoh_parts(np.where(yeoh[:, None, None], G, 0.0), c)
        D = np.where(yeoh[:, None, None], yeoh_D, D)
        N = np.where(yeoh[:, None, None], yeoh_N, N)
        theta = np.where(yeoh, yeoh_theta, theta)
    neo_mask = neo.reshape(K, 1, 1)
    yeoh_mask = yeoh.reshape(K, 1, 1)

    def on(mask, X):
        return _per_element(np.broadcast_to(mask, (K, 3, 3)), X)

    def sandwich(X):
        """``C⁻¹ X C⁻¹`` on the neo-Hookean elements, 0 elsewhere."""
        inv = _per_element(inverse, X)
        return np.where(on(neo_mask, X), inv @ X @ inv, 0.0)

    def yeoh_slope(X, part):
        """The Yeoh elements' derivative of ``D`` (part 0) or ``N`` (part 1) along X."""
        if not yeoh.any():
            return np.zeros_like(X)
        lifted = _per_element(np.where(yeoh_mask, G, 0.0), X) + 1j * STEP * X
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = _yeoh_parts(lifted, _per_element(c, X))[part].imag / STEP
        return np.where(on(yeoh_mask, X), slope, 0.0)

    return LawParts(D, N, theta,
                    lambda X: np.where(on(neo_mask, X), sandwich(X),
                                       np.where(on(yeoh_mask, X), yeoh_slope(X, 0), X)),
                    lambda X: -2.0 * sandwich(X) + yeoh_slope(X, 1))


def uniaxial_stress(law, youngs_modulus: float, poisson_ratio: float, stretches,
                    stiffening: float = 0.0) -> np.ndarray:
    """Nominal (first Piola–Kirchhoff) stress (Pa) of a homogeneous block of one law pulled
    or pressed along one axis with free sides, at axial stretches ``stretches`` (1 is rest;
    NaN where the law has no state with free sides, as SVK beyond its compressive limit): the
    stress–strain curve a fitted material stands for, for the report (``stiffening``: Yeoh's
    ``C₂₀/C₁₀``)."""
    from scipy.optimize import brentq

    number = law_number(law)
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))

    def stress(axial, lateral):
        G = np.diag([0.5 * (axial**2 - 1), 0.5 * (lateral**2 - 1), 0.5 * (lateral**2 - 1)])
        parts = law_parts(np.array([number]), G[None], [stiffening])
        return 2 * mu * parts.D[0] + lam * parts.theta[0] * parts.N[0]

    out = []
    for axial in np.atleast_1d(np.asarray(stretches, float)):
        low, high = sorted((1.0, axial ** -0.5))
        low, high = 0.5 * low, 1.5 * high
        side = [stress(axial, s)[1, 1] for s in (low, high)]
        if not (np.all(np.isfinite(side)) and side[0] * side[1] <= 0):
            out.append(np.nan)
            continue
        lateral = brentq(lambda s: stress(axial, s)[1, 1], low, high, xtol=1e-14)
        out.append(axial * stress(axial, lateral)[0, 0])
    return np.array(out)
