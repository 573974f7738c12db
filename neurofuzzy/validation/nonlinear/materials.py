"""Material laws of the nonlinear reference: what each one is, in the words of the codes our
users compare with, and its strain energy in principal stretches for the closed forms.

Every law is *isotropic and compressible*; its small-strain limit is linear elasticity with the
Young's modulus E and Poisson's ratio ν it is built from (shear modulus μ = E / (2 (1 + ν)),
bulk modulus K = E / (3 (1 - 2ν))), so a recording made with it can be compared with the
linear reference and with our SVK elements at small strain.

- :class:`NeoHookean` — the *coupled* compressible neo-Hookean solid,
  ``Ψ = μ/2 (I₁ - 3) - μ ln J + λ/2 (ln J)²`` (Bonet & Wood, *Nonlinear Continuum Mechanics
  for Finite Element Analysis*, eq. 6.27): FEBio's ``neo-Hookean``, ArtiSynth's
  ``NeoHookeanMaterial``. Its energy grows without bound as J → 0, so no element can be
  squeezed flat, and μ, λ are exactly the Lamé constants at small strain.
- :class:`Yeoh` — the strain-stiffening law, in the *uncoupled* form of Abaqus, ANSYS and
  COMSOL (and sfepy's ``dw_tl_he_genyeoh`` + ``dw_tl_bulk_penalty``):
  ``Ψ = C₁₀ (Ī₁ - 3) + C₂₀ (Ī₁ - 3)² + C₃₀ (Ī₁ - 3)³ + K/2 (J - 1)²`` with
  ``Ī₁ = J^(-2/3) I₁``. With C₂₀ = C₃₀ = 0 it is the uncoupled neo-Hookean solid
  (Abaqus' ``NEO HOOKE``; μ = 2 C₁₀). Why Yeoh: see :class:`Yeoh`.
- :class:`Prony` — quasi-linear viscoelasticity on top of either law, as FEBio's
  ``viscoelastic`` material writes it: the second Piola–Kirchhoff stress is the elastic one
  convolved with the reduced relaxation function ``G(t) = 1 + Σᵢ gᵢ exp(-t/τᵢ)``, so the
  elastic law is the *long-term* (fully relaxed) response and the instantaneous one is
  (1 + Σ gᵢ) times stiffer.

Moduli in Pa, times in s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError

__all__ = ["NeoHookean", "Yeoh", "Prony", "lame_from_youngs"]


def lame_from_youngs(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """(μ, λ): the Lamé constants of E (Pa) and ν."""
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    return mu, lam


def _check_elastic(youngs_modulus, poisson_ratio):
    if not (np.isfinite(youngs_modulus) and youngs_modulus > 0):
        raise InputError(f"must be a positive number of Pa, got {youngs_modulus!r}",
                         key="youngs_modulus")
    if not (-1 < poisson_ratio < 0.5):
        raise InputError(f"must lie in (-1, 0.5), got {poisson_ratio!r}", key="poisson_ratio")


@dataclass(frozen=True)
class NeoHookean:
    """The coupled compressible neo-Hookean solid (module docstring), built from its
    small-strain E (Pa) and ν.

    ``Ψ = μ/2 (I₁ - 3) - μ ln J + λ/2 (ln J)²``, ``S = μ (I - C⁻¹) + λ ln J C⁻¹``.
    """

    youngs_modulus: float
    poisson_ratio: float

    def __post_init__(self):
        _check_elastic(self.youngs_modulus, self.poisson_ratio)

    name = "neo-Hookean"
    form = "Ψ = μ/2 (I₁ - 3) - μ ln J + λ/2 (ln J)²"

    @property
    def shear_modulus(self) -> float:
        return lame_from_youngs(self.youngs_modulus, self.poisson_ratio)[0]

    @property
    def lame_lambda(self) -> float:
        return lame_from_youngs(self.youngs_modulus, self.poisson_ratio)[1]

    @property
    def bulk_modulus(self) -> float:
        return self.lame_lambda + 2 * self.shear_modulus / 3

    def energy(self, stretches) -> np.ndarray:
        """Ψ (Pa) of principal stretches (..., 3)."""
        s = np.asarray(stretches, float)
        log_j = np.log(s).sum(axis=-1)
        return (self.shear_modulus / 2 * (np.sum(s**2, axis=-1) - 3)
                - self.shear_modulus * log_j + self.lame_lambda / 2 * log_j**2)

    def principal_nominal_stress(self, stretches) -> np.ndarray:
        """∂Ψ/∂λᵢ (Pa, force per reference area) of principal stretches (..., 3)."""
        s = np.asarray(stretches, float)
        log_j = np.log(s).sum(axis=-1, keepdims=True)
        return self.shear_modulus * (s - 1 / s) + self.lame_lambda * log_j / s

    def scaled(self, factor: float) -> NeoHookean:
        """The same law with every modulus times ``factor``."""
        return NeoHookean(self.youngs_modulus * factor, self.poisson_ratio)


@dataclass(frozen=True)
class Yeoh:
    """Yeoh's strain-stiffening law, uncoupled (module docstring).

    ``Ψ = C₁₀ (Ī₁ - 3) + C₂₀ (Ī₁ - 3)² + C₃₀ (Ī₁ - 3)³ + K/2 (J - 1)²``.

    Why Yeoh, for soft tissue probed by indentation: (1) it stiffens in compression as in
    tension, because Ī₁ grows in both (Mooney–Rivlin's second invariant makes it *softer*
    than neo-Hookean in tension and only mildly stiffer in compression: about 20 % at 30 %
    uniaxial compression for C₀₁ = C₁₀, far from the several-fold stiffening of liver, brain
    or muscle); (2) it depends on I₁ alone, and one indentation experiment is close to one
    mode of deformation, from which the split between ∂Ψ/∂I₁ and ∂Ψ/∂I₂ that Mooney–Rivlin
    needs cannot be identified (Yeoh 1993, *Rubber Chem. Technol.* 66:754, made the same
    argument for filled rubber); (3) it contains the neo-Hookean solid (C₂₀ = C₃₀ = 0), so a
    fitted neo-Hookean model *becomes* a stiffening one by freeing C₂₀ — the switch the
    diagnosis needs — with a small-strain shear modulus 2 C₁₀ that does not move; (4) its
    stress is a closed form of invariants, cheap and vectorised (a one-term Ogden law, the
    other common choice for brain — Budday et al. 2017, *Acta Biomater.* 48:319 — needs
    principal stretches, whose derivatives degenerate at equal stretches, and sfepy's
    Ogden term loops in Python over quadrature points, too slow for dynamics). Yeoh is in
    Abaqus, ANSYS, COMSOL, ArtiSynth (``YeohMaterial``) and sfepy; FEBio's uncoupled
    ``polynomial`` material holds C₁₀ and C₂₀ (not C₃₀), so the recordings use C₃₀ = 0.
    """

    c10: float
    c20: float
    c30: float
    bulk_modulus: float

    def __post_init__(self):
        if not self.c10 > 0:
            raise InputError(f"must be positive (μ = 2 C10), got {self.c10!r}", key="c10")
        if self.c20 < 0 or self.c30 < 0:
            raise InputError(f"C20 and C30 must not be negative (the law would soften and "
                             f"lose stability), got {self.c20!r}, {self.c30!r}", key="c20")
        if not self.bulk_modulus > 0:
            raise InputError(f"must be positive, got {self.bulk_modulus!r}", key="bulk_modulus")

    name = "Yeoh"
    form = "Ψ = C₁₀ (Ī₁ - 3) + C₂₀ (Ī₁ - 3)² + C₃₀ (Ī₁ - 3)³ + K/2 (J - 1)²"

    @classmethod
    def from_youngs(cls, youngs_modulus: float, poisson_ratio: float, *,
                    c20_ratio: float = 0.0, c30_ratio: float = 0.0) -> Yeoh:
        """The law with small-strain E (Pa) and ν, ``C₂₀ = c20_ratio · C₁₀`` and
        ``C₃₀ = c30_ratio · C₁₀``."""
        _check_elastic(youngs_modulus, poisson_ratio)
        mu, lam = lame_from_youngs(youngs_modulus, poisson_ratio)
        return cls(mu / 2, c20_ratio * mu / 2, c30_ratio * mu / 2, lam + 2 * mu / 3)

    @property
    def shear_modulus(self) -> float:
        return 2 * self.c10

    @property
    def youngs_modulus(self) -> float:
        mu, k = self.shear_modulus, self.bulk_modulus
        return 9 * k * mu / (3 * k + mu)

    @property
    def poisson_ratio(self) -> float:
        mu, k = self.shear_modulus, self.bulk_modulus
        return (3 * k - 2 * mu) / (2 * (3 * k + mu))

    def energy(self, stretches) -> np.ndarray:
        s = np.asarray(stretches, float)
        j = np.prod(s, axis=-1)
        x = j ** (-2 / 3) * np.sum(s**2, axis=-1) - 3
        return (self.c10 * x + self.c20 * x**2 + self.c30 * x**3
                + self.bulk_modulus / 2 * (j - 1) ** 2)

    def principal_nominal_stress(self, stretches) -> np.ndarray:
        s = np.asarray(stretches, float)
        j = np.prod(s, axis=-1, keepdims=True)
        i1 = np.sum(s**2, axis=-1, keepdims=True)
        x = j ** (-2 / 3) * i1 - 3
        dpsi = self.c10 + 2 * self.c20 * x + 3 * self.c30 * x**2
        return (dpsi * j ** (-2 / 3) * (2 * s - 2 * i1 / (3 * s))
                + self.bulk_modulus * (j - 1) * j / s)

    def scaled(self, factor: float) -> Yeoh:
        return Yeoh(self.c10 * factor, self.c20 * factor, self.c30 * factor,
                    self.bulk_modulus * factor)


@dataclass(frozen=True)
class Prony:
    """A Prony series of 1–3 terms: relative moduli gᵢ (> 0, of the long-term modulus) and
    relaxation times τᵢ (s), ``G(t) = 1 + Σᵢ gᵢ exp(-t/τᵢ)`` (FEBio's ``viscoelastic``
    with g0 = 1). One term is the standard linear solid."""

    relative_moduli: tuple
    times: tuple

    def __post_init__(self):
        g = np.atleast_1d(np.asarray(self.relative_moduli, float))
        tau = np.atleast_1d(np.asarray(self.times, float))
        if g.shape != tau.shape or not 1 <= len(g) <= 3:
            raise InputError(f"needs 1-3 terms, as many moduli as times; got {len(g)} moduli "
                             f"and {len(tau)} times", key="prony")
        if np.any(~np.isfinite(g)) or np.any(g <= 0):
            raise InputError(f"relative moduli must be positive, got {tuple(g)}",
                             key="relative_moduli")
        if np.any(~np.isfinite(tau)) or np.any(tau <= 0):
            raise InputError(f"relaxation times must be positive seconds, got {tuple(tau)}",
                             key="times")
        object.__setattr__(self, "relative_moduli", tuple(float(x) for x in g))
        object.__setattr__(self, "times", tuple(float(x) for x in tau))

    def relaxation(self, t) -> np.ndarray:
        """G(t), the reduced relaxation function (1 at t → ∞, 1 + Σ gᵢ at t = 0)."""
        t = np.asarray(t, float)[..., None]
        return 1 + np.sum(np.asarray(self.relative_moduli)
                          * np.exp(-t / np.asarray(self.times)), axis=-1)

    def step_factors(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(decay, ramp) per term over a step ``dt``: ``exp(-dt/τ)`` and
        ``(1 - exp(-dt/τ)) / (dt/τ)``, the weights of the recursive update
        ``Hᵢ ← decay Hᵢ + ramp (Sₑ⁽ⁿ⁺¹⁾ - Sₑ⁽ⁿ⁾)``, exact for a piecewise-linear elastic
        stress history (FEBio's ``FEViscoElasticMaterial``; Simo & Hughes,
        *Computational Inelasticity*, § 10.3)."""
        x = dt / np.asarray(self.times)
        decay = np.exp(-x)
        return decay, -np.expm1(-x) / x
