"""Closed forms to check the nonlinear reference against.

Uniaxial stress of a homogeneous compressible block (:func:`uniaxial_stress`,
:func:`uniaxial_stretch`): the axial stretch λ is imposed or the nominal stress P given, the
two lateral stretches are equal and free of stress, ``∂Ψ/∂λ₂(λ, λₜ, λₜ) = 0``, solved for λₜ
by bracketing (between 1 and λ^(-1/2), the lateral stretches of ν = 0 and of an
incompressible solid) from the material's energy in principal stretches
(:meth:`~.materials.NeoHookean.principal_nominal_stress`). Such a block deforms
homogeneously, so a finite-element solution must reproduce it to the solver's tolerance.

The standard linear solid in one dimension, with FEBio's convention (the long-term modulus
E∞ and one Prony term g, τ: relaxation modulus ``E(t) = E∞ (1 + g e^(-t/τ))``), and its
creep under a held stress (retardation time ``(1 + g) τ``). Both accept a linear ramp of
duration ``ramp`` before the hold (the Prony update treats a step as a ramp over one time
step): the closed forms are the hereditary integrals of that ramp.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq

from ...errors import InputError

__all__ = ["UniaxialStress", "uniaxial_stress", "uniaxial_stretch", "sls_relaxation",
           "sls_creep", "prony_relaxation"]


class UniaxialStress(NamedTuple):
    """Uniaxial stress at axial stretch λ (arrays of λ's shape)."""

    nominal_stress: np.ndarray     #: P = force / reference area (Pa)
    lateral_stretch: np.ndarray    #: λₜ
    cauchy_stress: np.ndarray      #: σ = force / current area = P λ / J (Pa)


def _lateral(material, stretch: float) -> float:
    def lateral_stress(s):
        return material.principal_nominal_stress([stretch, s, s])[1]

    low, high = sorted((1.0, stretch ** -0.5))
    low, high = low * (1 - 1e-9), high * (1 + 1e-9)
    for _ in range(20):                 # a law far from both limits: widen the bracket
        if lateral_stress(low) * lateral_stress(high) <= 0:
            break
        low, high = low / 1.5, high * 1.5
    else:
        raise InputError(f"no lateral stretch between {low:.6g} and {high:.6g} frees the "
                         f"sides at axial stretch {stretch}", key="stretch")
    return brentq(lateral_stress, low, high, xtol=1e-15, rtol=1e-15, maxiter=200)


def uniaxial_stress(material, stretch) -> UniaxialStress:
    """Uniaxial stress of ``material`` (:mod:`.materials`) at axial stretch(es) λ > 0."""
    stretch = np.asarray(stretch, float)
    if np.any(~(stretch > 0)):
        raise InputError(f"stretches must be positive, got {stretch}", key="stretch")
    lateral = np.vectorize(lambda s: _lateral(material, float(s)))(stretch)
    principal = np.stack([stretch, lateral, lateral], axis=-1)
    nominal = material.principal_nominal_stress(principal)[..., 0]
    return UniaxialStress(nominal, lateral, nominal * stretch / (stretch * lateral**2))


def uniaxial_stretch(material, nominal_stress: float, *, bracket=(0.2, 5.0)) -> float:
    """The axial stretch at which uniaxial stress reaches ``nominal_stress`` (Pa, force per
    reference area; negative in compression)."""
    def excess(s):
        return float(uniaxial_stress(material, s).nominal_stress) - nominal_stress

    low, high = bracket
    if excess(low) * excess(high) > 0:
        raise InputError(f"no stretch in {bracket} carries {nominal_stress} Pa",
                         key="nominal_stress")
    return brentq(excess, low, high, xtol=1e-15, rtol=1e-14, maxiter=200)


def _ramped(response, t, ramp):
    """The hereditary integral of a unit linear ramp over [0, ramp], then held, for a
    response ``response(t)`` to a unit step that is ``a + b e^(-t/T)`` (given as
    (a, b, T))."""
    a, b, time_constant = response
    t = np.asarray(t, float)
    if ramp == 0:
        return np.where(t >= 0, a + b * np.exp(-np.maximum(t, 0) / time_constant), 0.0)
    during = (a * t + b * time_constant * (1 - np.exp(-t / time_constant))) / ramp
    after = a + b * time_constant / ramp * (np.exp(-(t - ramp) / time_constant)
                                            - np.exp(-t / time_constant))
    return np.where(t < 0, 0.0, np.where(t < ramp, during, after))


def sls_relaxation(t, strain: float, *, modulus: float, relative_modulus: float,
                   time: float, ramp: float = 0.0) -> np.ndarray:
    """Stress (Pa) of the standard linear solid at times ``t`` (s) after a strain
    ``strain`` is applied (over ``ramp`` s) and held: ``E∞ ε (1 + g e^(-t/τ))`` for a step.
    ``modulus`` is E∞ (Pa), ``relative_modulus`` g, ``time`` τ (s)."""
    return strain * modulus * _ramped((1.0, relative_modulus, time), t, ramp)


def sls_creep(t, stress: float, *, modulus: float, relative_modulus: float, time: float,
              ramp: float = 0.0) -> np.ndarray:
    """Strain of the standard linear solid at times ``t`` (s) after a stress ``stress``
    (Pa) is applied (over ``ramp`` s) and held:
    ``σ/E∞ (1 - g/(1 + g) e^(-t/((1 + g) τ)))`` for a step, from σ/((1 + g) E∞) at once to
    σ/E∞."""
    g = relative_modulus
    return stress / modulus * _ramped((1.0, -g / (1 + g), (1 + g) * time), t, ramp)


def prony_relaxation(t, strain: float, *, modulus: float, prony) -> np.ndarray:
    """Stress (Pa) after a step strain for a whole Prony series (:class:`~.materials.Prony`):
    ``E∞ ε G(t)``."""
    return strain * modulus * prony.relaxation(t)
