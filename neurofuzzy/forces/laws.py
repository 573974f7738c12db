"""The tetrahedral elements' material laws, by name, and their stress for the numpy force path
(:class:`ElementStress`), computed by the compiled stress of :mod:`neurofuzzy.kernels.laws`:
each law, and the Kelvin–Voigt and volumetric stresses around it, is written once, there (the
tests check it against closed forms, Bonet & Wood's stress, a Yeoh solid written apart and
central differences).

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
``mooney-rivlin``         see below           ``J - 1``    ``J C⁻¹``
``corotational``          ``I - U⁻¹``         ``tr U - 3`` ``U⁻¹``
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
:class:`neurofuzzy.validation.nonlinear.Yeoh`.

The ``mooney-rivlin`` law is the uncoupled Mooney–Rivlin solid of FEBio, SOFA, Abaqus and
FElupe, ``Ψ = C₁₀ (Ī₁ - 3) + C₀₁ (Ī₂ - 3) + K/2 (J - 1)²`` with ``C₁₀ + C₀₁ = μ/2`` and
``C₀₁ = r C₁₀`` for the element's own constant ``r`` (its ``stiffening``, ``C01/C10``): the
same E and ν at small strain for every ``r``. The ``corotational`` law is SOFA's
``TetrahedronFEMForceField`` (``method="polar"``), ``P = R (2μ (U - I) + λ tr(U - I) I)``
with ``F = R U`` (``U = √C``). Every law's names, constant and FEBio material are one
record, :data:`LAW_RECORDS`. The derivatives of the stress (:meth:`ElementStress.jvp`,
:meth:`ElementStress.vjp`, :meth:`ElementStress.partials`) and ``∂D/∂c``
(:func:`stiffening_slope`) are the kernels' complex-step derivatives of it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, closest_name


def _elastic_moduli(E: float, nu: float, c: float) -> str:
    return f"<E>{E!r}</E><v>{nu!r}</v>"


def _uncoupled(c1: float, c2: float, E: float, nu: float) -> str:
    """FEBio's uncoupled solid's ``c1``, ``c2`` with ``K = λ + 2μ/3 = E / (3 (1 - 2ν))`` and
    Abaqus' volumetric energy ``U = K/2 (J - 1)²`` (``pressure_model`` 2), ours."""
    return (f"<c1>{c1!r}</c1><c2>{c2!r}</c2><k>{E / (3 * (1 - 2 * nu))!r}</k>"
            "<pressure_model>2</pressure_model>")


@dataclass(frozen=True)
class Law:
    """One material law of the elements: what the toolkit reads, says and writes about it.

    Its stress is the kernels' (:mod:`neurofuzzy.kernels.laws`, the same name and number);
    this record is everything else: the names a user may type, its own constant, whether the
    diagnosis offers a switch to it, and its material in FEBio.

    Attributes
    ----------
    name : str
        As in model files, ``--law`` and the kernels' :data:`~neurofuzzy.kernels.laws.LAWS`.
    summary : str
        One line for ``--help`` and the docs.
    aliases : tuple of str
        Short names accepted for it (compared without hyphens).
    constant : str or None
        The name of the element's own constant of the law (``element_stiffening``, fitted
        per region as ``log_stiffening``), None for a law without one.
    quantity : str or None
        The rule base's quantity its constant is in words (``strain_stiffening`` for Yeoh's
        C20/C10: words of it make elements of this law, and the fitted constant comes back
        as those words); None for a constant that has no words.
    switch : bool
        The load-step diagnosis offers a switch to it (a law that one mode of deformation can
        tell apart from the others).
    febio : callable
        ``(E, ν, c) -> (type, parameters)``: FEBio's material and its parameters' XML.
    stall : str
        What a static solve that stalls says of a body of this law (:func:`stall_note`).
    febio_note : str
        What the FEBio file says where ``febio`` is not this law but the nearest FEBio has
        ("" where it is this law).
    """

    name: str
    summary: str
    aliases: tuple[str, ...] = ()
    constant: str | None = None
    quantity: str | None = None
    switch: bool = True
    febio: Callable = field(default=lambda E, nu, c: ("isotropic elastic",
                                                     _elastic_moduli(E, nu, c)))
    stall: str = ""
    febio_note: str = ""


#: The laws in the order of their numbers (``model.elements.law``, the kernels' numbers).
LAW_RECORDS = (
    # measured: a sphere of radius 1 cm pressed 3 mm into a 2 cm block, 6 cells a side
    Law("st-venant-kirchhoff", "SVK; softens beyond about 30 % compression",
        aliases=("svk", "stvk"), stall="St. Venant–Kirchhoff softens under strong "
        "compression, and a deep press often stalls it where a neo-Hookean body converges "
        "(--law neo-hookean)"),
    Law("neo-hookean", "stiffens as it is squeezed", aliases=("neohookean", "nh"),
        febio=lambda E, nu, c: ("neo-Hookean", _elastic_moduli(E, nu, c))),
    # C10 = μ/2, C20 = c C10
    Law("yeoh", "stiffens more, by a fitted C20/C10", constant="C20/C10",
        quantity="strain_stiffening",
        febio=lambda E, nu, c: ("Yeoh", _uncoupled(E / (4 * (1 + nu)),
                                                   c * E / (4 * (1 + nu)), E, nu))),
    # C10 + C01 = μ/2, C01 = r C10: one mode of deformation (a compression, an indentation)
    # cannot split the I1 and I2 parts, so the diagnosis does not switch to it by itself
    Law("mooney-rivlin", "the second invariant too, by a fitted C01/C10 (SOFA's and FEBio's "
        "MooneyRivlin)", aliases=("mr",), constant="C01/C10", switch=False,
        febio=lambda E, nu, c: ("Mooney-Rivlin", _uncoupled(
            E / (4 * (1 + nu) * (1 + c)), c * E / (4 * (1 + nu) * (1 + c)), E, nu))),
    # SOFA's TetrahedronFEMForceField ("polar"); an engine's element, not a diagnosis' finding
    Law("corotational", "linear in each element's stretch rotated back, the element of "
        "SOFA's TetrahedronFEMForceField and of real-time engines",
        aliases=("corot", "corotated"), switch=False,
        febio_note="FEBio has no corotational linear solid: written as its isotropic elastic "
        "(St. Venant-Kirchhoff), the same E and nu at small strain, not at large strain"),
)
#: The laws by name; a law's number (``model.elements.law``) is its position here, the same in
#: the compiled kernels (:mod:`neurofuzzy.kernels.laws`, checked by the tests).
LAWS = tuple(law.name for law in LAW_RECORDS)
#: Short names accepted for the laws.
ALIASES = {alias: law.name for law in LAW_RECORDS for alias in law.aliases}
#: Yeoh's law, whose elements carry a stiffening constant (``element_stiffening``).
YEOH = LAWS.index("yeoh")
#: The laws whose elements carry their own constant (``element_stiffening``, learned as
#: ``log_stiffening``), with its name (from :data:`LAW_RECORDS`): the learner, files, exports,
#: words and report treat every such constant alike (elements of the other laws keep theirs
#: unused).
STIFFENING_CONSTANT = {number: law.constant for number, law in enumerate(LAW_RECORDS)
                       if law.constant}
#: The laws whose constant is a quantity of the rule base's words: quantity → law number.
LAW_OF_QUANTITY = {law.quantity: number for number, law in enumerate(LAW_RECORDS)
                   if law.quantity}


def stall_note(elements) -> str:
    """What a stalled static solve adds for the laws of ``elements`` (an ``Elements`` or
    None): each law's :attr:`Law.stall`, as another thing to try."""
    used = set() if elements is None else set(np.unique(np.asarray(elements.law)).tolist())
    return "".join(f"; or another law: {record.stall}" for k, record in enumerate(LAW_RECORDS)
                   if k in used and record.stall)


def stiffens(law) -> np.ndarray:
    """bool, the shape of ``law`` (law numbers): which elements' law has its own stiffening
    constant (:data:`STIFFENING_CONSTANT`)."""
    return np.isin(law, tuple(STIFFENING_CONSTANT))
#: The law's own constant of an element when none is given. Yeoh's ``C₂₀/C₁₀`` 1: in
#: uniaxial stress (ν = 0.45) 1.65 times as stiff as neo-Hookean at 30 % compression, 2.2
#: times at 40 %, 1.35 times at 30 % extension. Mooney–Rivlin's ``C₀₁/C₁₀`` 1: ``C₁₀ = C₀₁``
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
    """(n,) the law's own constant (Yeoh's ``C₂₀/C₁₀``, Mooney–Rivlin's ``C₀₁/C₁₀``) of n
    elements: ``None`` for :data:`DEFAULT_STIFFENING`, one value for all, or one per element.
    Elements of the other laws keep theirs unused (so a model whose elements later become
    Yeoh's starts from it, the default unless given).

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
        raise InputError(f"element {first} has stiffening {array[first]:g}; the law's own "
                         "constant (Yeoh's C20/C10, Mooney-Rivlin's C01/C10) must be a number "
                         ">= 0 (0 is the neo-Hookean solid; a negative one can lose "
                         "stability)", key="element_stiffening")
    return array


@dataclass(frozen=True)
class ElementStress:
    """The elements' second Piola–Kirchhoff stress at one state, and its derivatives, for the
    numpy force path: every number comes from the compiled :func:`neurofuzzy.kernels.laws.stress`
    (each element's law with Kelvin–Voigt viscosity and the volumetric stresses, written once),
    over arrays (:func:`~neurofuzzy.kernels.law_arrays.stress_arrays` and its neighbours).

    Attributes
    ----------
    law : (K,) int
    G, Gd : (K, 1, 3, 3) float
        Green strain and its rate (symmetric).
    shear, shear_rate, pressure, pressure_rate, stiffening : (K,) float
        ``2μ``, ``2μβ``, ``π``, ``π̇`` and the law's own constant of every element.
    kappa : float
        The strain stiffening ``κ`` of the ``nonlinear_stiffening`` effect (0: none).
    theta : (K,) float
        The law's volumetric strain ``θ(G)``.
    N : (K, 3, 3) float
        Its gradient ``∂θ/∂G`` (the stress of unit ``π``).
    """

    law: np.ndarray
    G: np.ndarray
    Gd: np.ndarray
    shear: np.ndarray
    shear_rate: np.ndarray
    pressure: np.ndarray
    pressure_rate: np.ndarray
    stiffening: np.ndarray
    theta: np.ndarray
    N: np.ndarray
    kappa: float = 0.0

    @classmethod
    def strains(cls, law: np.ndarray, G: np.ndarray):
        """``(θ, N)`` of every element's law at its Green strain ``G`` (K, 3, 3): what the
        volumetric stresses ``π``, ``π̇`` (the caller's) are formed from (the kernels'
        :func:`~neurofuzzy.kernels.laws.volumetric`; no law's ``θ`` depends on its own
        constant). An element squeezed flat gives NaN (the run diverges and says so)."""
        # imported on use, here and below: the model imports this module for the laws' names
        from ..kernels.law_arrays import volumetric_arrays

        K = len(G)
        law, strains, _ = _compiled_arguments(law, G, None)
        N, theta = np.empty((K, 1, 3, 3)), np.empty(K)
        volumetric_arrays(law, strains, theta, N)
        return theta.astype(G.dtype, copy=False), N[:, 0].astype(G.dtype, copy=False)

    @classmethod
    def at(cls, law, G, Gd, shear, shear_rate, pressure, pressure_rate, stiffening=None,
           volumetric=None, kappa: float = 0.0):
        """The stress of elements of laws ``law`` (K,) at ``G``, ``Gd`` (K, 3, 3) with
        their constants (K,) and the strain stiffening ``kappa``; ``volumetric`` is ``(θ,
        N)`` from :meth:`strains` when the caller has it."""
        theta, N = volumetric if volumetric is not None else cls.strains(law, G)
        law, G6, c = _compiled_arguments(law, G, stiffening)
        K = len(law)

        def per_element(x):
            return np.ascontiguousarray(np.broadcast_to(np.asarray(x, float), (K,)))

        return cls(law, G6, np.ascontiguousarray(np.asarray(Gd, float).reshape(K, 1, 3, 3)),
                   per_element(shear), per_element(shear_rate), per_element(pressure),
                   per_element(pressure_rate), c, theta, N, float(kappa))

    @property
    def constants(self) -> tuple:
        """The constants as :mod:`neurofuzzy.kernels.law_arrays` takes them."""
        return (self.shear, self.shear_rate, self.pressure, self.pressure_rate, self.kappa,
                self.stiffening)

    def stress(self) -> np.ndarray:
        """(K, 3, 3): ``S``."""
        from ..kernels.law_arrays import stress_arrays

        out = np.empty_like(self.G)
        stress_arrays(self.law, self.G, self.Gd, self.constants, out)
        return out[:, 0].astype(self.N.dtype, copy=False)

    def jvp(self, dG, dGd, d_pressure, d_pressure_rate) -> np.ndarray:
        """(K, P, 3, 3): ``dS`` along P symmetric strain changes ``dG``, ``dGd`` (K, P, 3, 3)
        with the volumetric stresses' changes ``d_pressure``, ``d_pressure_rate`` (K, P)."""
        from ..kernels.law_arrays import stress_jvp_arrays

        K, P = dG.shape[:2]
        out = np.empty((K, P, 3, 3))
        stress_jvp_arrays(self.law, self.G, self.Gd, self.constants,
                          (_batch(dG, K), _batch(dGd, K), _batch(d_pressure, K),
                           _batch(d_pressure_rate, K)), out)
        return out.astype(self.N.dtype, copy=False)

    def vjp(self, LS) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(L_G, L_Ġ, l_π, l_π̇)`` for the symmetric cotangent ``LS`` (K, 3, 3) of ``S``:
        (K, 3, 3) twice and (K,) twice (``π``, ``π̇`` held; their own dependence on the
        strains is the caller's)."""
        from ..kernels.law_arrays import stress_vjp_arrays

        K = len(self.law)
        LG, LGd, l_pressure = np.empty((K, 1, 3, 3)), np.empty((K, 1, 3, 3)), np.empty((K, 2))
        stress_vjp_arrays(self.law, self.G, self.Gd, self.constants, _batch(LS, K),
                          (LG, LGd, l_pressure))
        dtype = self.N.dtype
        return (LG[:, 0].astype(dtype, copy=False), LGd[:, 0].astype(dtype, copy=False),
                l_pressure[:, 0].astype(dtype, copy=False),
                l_pressure[:, 1].astype(dtype, copy=False))

    def partials(self) -> dict[str, np.ndarray]:
        """``∂S`` (K, 3, 3) by each of ``shear``, ``shear_rate``, ``pressure`` and
        ``pressure_rate`` (``S`` is linear in each, and the strain stiffening's term depends
        on none of them)."""
        from ..kernels.law_arrays import stress_partials

        out = np.empty((len(self.law), 4, 3, 3))
        stress_partials(self.law, self.G, self.Gd, self.constants, out)
        out = out.astype(self.N.dtype, copy=False)
        return {name: out[:, k] for k, name in enumerate(("shear", "shear_rate", "pressure",
                                                           "pressure_rate"))}


def _batch(x, K: int) -> np.ndarray:
    """``x`` (K, ...) as the compiled functions' contiguous float (K, P, ...) arrays."""
    x = np.asarray(x, float)
    return np.ascontiguousarray(x.reshape((K, -1) + x.shape[-2:] if x.ndim > 2 else (K, -1)))


def stiffening_slope(law: np.ndarray, G: np.ndarray, stiffening) -> np.ndarray:
    """(K, 3, 3): ``∂D/∂c`` of every element at its Green strain ``G`` (K, 3, 3), ``c`` the
    law's own constant (:data:`STIFFENING_CONSTANT`; zero for the laws without one), exact
    (the compiled law's complex-step derivative)."""
    from ..kernels.law_arrays import law_constant_slopes

    law, strains, c = _compiled_arguments(law, G, stiffening)
    out = np.empty_like(strains)
    law_constant_slopes(law, strains, c, out)
    return out[:, 0].astype(np.asarray(G).dtype, copy=False)


def _compiled_arguments(law, G, stiffening):
    """``law``, ``G`` and the constants as the compiled laws take them."""
    K = len(G)
    return (np.ascontiguousarray(law, np.intp),
            np.ascontiguousarray(np.asarray(G, float).reshape(K, 1, 3, 3)),
            np.ascontiguousarray(np.broadcast_to(
                np.asarray(0.0 if stiffening is None else stiffening, float), (K,))))


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
        law, c = np.array([number]), [stiffening]
        theta, N = ElementStress.strains(law, G[None])
        return ElementStress.at(law, G[None], np.zeros((1, 3, 3)), 2 * mu, 0.0, lam * theta,
                                0.0, c, (theta, N)).stress()[0]

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
