"""Prony-series relaxation of the tetrahedral elements (quasi-linear viscoelasticity), on top of
any material law (:mod:`neurofuzzy.forces.laws`), in FEBio's convention (its ``viscoelastic``
material with ``g0 = 1``):

    S(t) = ∫ G(t - s) dS_e/ds ds,    G(t) = 1 + Σᵢ gᵢ exp(-t/τᵢ)

``S_e`` is the elastic stress of the element's law with its E and ν, the **long-term** (fully
relaxed) response; a sudden strain meets a ``1 + Σ gᵢ`` times stiffer material, which relaxes
to it with the times ``τᵢ``. One term (g, τ) is the standard linear solid: its long-term
modulus E, its instantaneous one ``(1 + g) E``, its relaxation time τ. Kelvin–Voigt viscosity
(η) stays beside it.

Internal variables: with the history stresses ``hᵢ`` (``ḣᵢ = Ṡ_e - hᵢ/τᵢ``, ``hᵢ(0) = 0``)
``S = S_e + Σᵢ gᵢ hᵢ``. The elements carry ``rᵢ = hᵢ - S_e`` instead, which needs no rate of
``S_e``: ``ṙᵢ = -(rᵢ + S_e)/τᵢ``, integrated exactly for the ``S_e`` of the step's start
(the time the step's forces are evaluated at, semi-implicit Euler)::

    S = (1 + Σᵢ gᵢ) S_e + Σᵢ gᵢ rᵢ,      rᵢ' = aᵢ rᵢ - (1 - aᵢ) S_e,     aᵢ = exp(-h/τᵢ)

(six entries of the symmetric ``rᵢ`` per element and term; zero at rest). This module holds
the per-element values (:func:`relaxation_arrays`) and the numpy reference of the two lines
above; the compiled kernels (:mod:`neurofuzzy.kernels.relaxation`) compute the same, tested
equal.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["MAX_TERMS", "relaxation_arrays", "relaxation_fields", "start_terms", "decay",
           "relaxed_stress", "relaxation_update"]

#: The most Prony terms an element can carry.
MAX_TERMS = 3


def relaxation_arrays(moduli, times, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(g, τ)`` as (n, K) float arrays: ``None`` for both (no relaxation, K = 0), one value
    or K values for every element, (n, K) per element, or (n,) one term per element (when
    n > :data:`MAX_TERMS`, so it cannot be K terms).

    Raises
    ------
    InputError
        When only one is given, the shapes differ or exceed :data:`MAX_TERMS` terms, a
        relative modulus is negative or a time is not positive (or either is NaN).
    """
    if moduli is None and times is None:
        return np.zeros((n, 0)), np.zeros((n, 0))
    if moduli is None or times is None:
        raise InputError("give both the relative moduli and the times of the Prony terms, or "
                         "neither", key="element_relaxation_moduli" if moduli is None
                         else "element_relaxation_times")
    out = []
    for key, value in (("element_relaxation_moduli", moduli),
                       ("element_relaxation_times", times)):
        array = np.asarray(value, float)
        if array.ndim == 1 and len(array) == n > MAX_TERMS:
            array = array[:, None]                       # one term, a value per element
        if array.ndim < 2:
            array = np.broadcast_to(np.atleast_1d(array), (n, max(np.atleast_1d(array).size, 1)))
        if array.ndim != 2 or array.shape[0] != n or array.shape[1] > MAX_TERMS:
            raise InputError(f"got shape {np.shape(value)}; expected one value per term "
                             f"(at most {MAX_TERMS} terms) or ({n}, K), per element", key=key)
        if np.any(np.isnan(array)) or np.any(array == -np.inf):
            # +inf is a limit a fit may step to (τ = ∞: a term that never relaxes)
            raise InputError("must be numbers, not NaN", key=key)
        out.append(np.ascontiguousarray(array))
    g, tau = out
    if g.shape != tau.shape:
        raise InputError(f"got {g.shape[1]} relative moduli and {tau.shape[1]} times per "
                         "element; a Prony term needs one of each", key="element_relaxation_times")
    if np.any(g < 0):
        raise InputError(f"relative modulus {g.min():g}; it must not be negative (g is the "
                         "share of stiffness that relaxes away, of the long-term modulus)",
                         key="element_relaxation_moduli")
    if np.any(tau <= 0):
        raise InputError(f"relaxation time {tau.min():g} s; it must be positive (s)",
                         key="element_relaxation_times")
    return g, tau


def relaxation_fields(terms) -> dict:
    """The elements' fields (:class:`~neurofuzzy.forces.Tetrahedra`) of Prony ``terms``, a
    sequence of ``(g, τ)`` pairs (empty for none, or None)."""
    if terms is None or len(terms) == 0:
        return {}
    try:
        pairs = np.asarray(terms, float).reshape(-1, 2)
    except (TypeError, ValueError):
        raise InputError(f"got {terms!r}; expected (g, τ) pairs, e.g. [(0.5, 0.05)]",
                         key="relaxation") from None
    return {"relaxation_moduli": pairs[:, 0], "relaxation_times": pairs[:, 1]}


#: A fit's start for each relative modulus when none is given: half the long-term stiffness
#: relaxes away, the middle of soft tissue's range (liver, brain: g about 0.3-3)
START_RELATIVE_MODULUS = 0.5


def start_terms(spec, duration: float) -> list[tuple[float, float]]:
    """The Prony terms ``[(g, τ), ...]`` a fit starts from: ``spec`` is a number of terms
    (1–3; each g = 0.5 and the times spread by tens below a fifth of the recording's
    ``duration``, so the first is seen to relax within it), ``(g, τ)`` pairs, or their text
    ``"0.5:0.05,0.2:1"`` (the command line's).

    Raises
    ------
    InputError
        A count outside 1–3, a pair that is not two numbers, or bad values.
    """
    if isinstance(spec, str):
        text = spec.strip()
        if text.isdigit():
            spec = int(text)
        else:
            try:
                spec = [tuple(float(x) for x in pair.split(":")) for pair in text.split(",")]
            except ValueError:
                spec = None
            if spec is None or any(len(pair) != 2 for pair in spec):
                raise InputError(f"got {text!r}; expected a number of Prony terms (1-"
                                 f"{MAX_TERMS}) or g:tau pairs such as 0.5:0.05,0.2:1",
                                 key="--relaxation")
    if isinstance(spec, (int, np.integer)):
        if not 1 <= int(spec) <= MAX_TERMS:
            raise InputError(f"got {int(spec)} Prony terms; expected 1 to {MAX_TERMS}",
                             key="--relaxation")
        first = max(float(duration), 1e-6) / 5.0
        return [(START_RELATIVE_MODULUS, first / 10.0**k) for k in range(int(spec))]
    terms = [tuple(float(x) for x in pair) for pair in spec]
    relaxation_arrays([g for g, _ in terms], [t for _, t in terms], 1)   # checks the values
    return terms


def decay(times, h: float) -> np.ndarray:
    """``aᵢ = exp(-h/τᵢ)`` of the times ``τ`` (any shape) for a step of ``h`` seconds."""
    return np.exp(-float(h) / np.asarray(times, float))


def relaxed_stress(elastic, history, moduli) -> np.ndarray:
    """``(1 + Σᵢ gᵢ) S_e + Σᵢ gᵢ rᵢ`` (..., 3, 3): the stress of the elastic stress ``S_e``
    (n, 3, 3), the internal variables ``r`` (n, K, 3, 3) and relative moduli ``g`` (n, K)."""
    g = np.asarray(moduli, float)
    return ((1.0 + g.sum(axis=1))[:, None, None] * elastic
            + np.einsum("nk,nkij->nij", g, history))


def relaxation_update(elastic, history, decays) -> np.ndarray:
    """``rᵢ' = aᵢ rᵢ - (1 - aᵢ) S_e`` (n, K, 3, 3), the internal variables after a step."""
    a = np.asarray(decays, float)[:, :, None, None]
    return a * history - (1.0 - a) * elastic[:, None]
