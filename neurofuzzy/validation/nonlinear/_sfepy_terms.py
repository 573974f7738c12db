"""Two total-Lagrangian terms written in sfepy's own hyperelastic framework.

sfepy's ``HyperElasticTLBase`` computes the deformation gradient and its invariants at the
quadrature points, and assembles ``∫ S : δE dV`` and the tangent ``∫ (Bᵀ ℂ B + Gᵀ S G) dV``
(material and geometric parts, its C function ``dw_he_rtm``) from a term's second
Piola–Kirchhoff stress S and material tangent ℂ = ∂S/∂E at each point: a term supplies only
those two. Both are given in sfepy's order ``(xx, yy, zz, xy, xz, yz)``, the tangent as plain
components ``ℂ[I, J] = ℂ_ijkl`` (checked against sfepy's C neo-Hookean term to round-off,
``tests/test_validation_nonlinear.py``).

- :class:`CoupledNeoHookeanTLTerm`: the coupled neo-Hookean stress
  ``S = μ (I - C⁻¹) + λ ln J C⁻¹`` and tangent
  ``ℂ = λ C⁻¹ ⊗ C⁻¹ + (μ - λ ln J) (C⁻¹ ⊙ C⁻¹)``, ``(A ⊙ A)_ijkl = A_ik A_jl + A_il A_jk``
  (Bonet & Wood, eqs. 6.28 and 6.29), which sfepy lacks (its neo-Hookean is the isochoric
  part of the uncoupled law).
- :class:`GivenStressTLTerm`: a stress the solver gives at every quadrature point (the
  Prony series' history, constant during a step's Newton iterations) plus Kelvin–Voigt
  viscosity ``S_v = η/E ℂ₀ : Ė``, ``Ė = sym(Fᵀ Ḟ)``, with ``Ḟ`` from the trapezoidal rule.
"""

from __future__ import annotations

import numpy as np
from sfepy.terms.terms_hyperelastic_base import HyperElasticBase
from sfepy.terms.terms_hyperelastic_tl import HyperElasticTLBase

#: Voigt order of sfepy's symmetric tensors.
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
_FULL = np.array([[0, 3, 4], [3, 1, 5], [4, 5, 2]])
_ROWS = np.array([i for i, _ in PAIRS])
_COLS = np.array([j for _, j in PAIRS])


def to_matrix(voigt: np.ndarray) -> np.ndarray:
    """(..., 6) → (..., 3, 3)."""
    return voigt[..., _FULL]


def to_voigt(matrix: np.ndarray) -> np.ndarray:
    """(..., 3, 3) → (..., 6)."""
    return matrix[..., _ROWS, _COLS]


def _symmetric_product(a: np.ndarray) -> np.ndarray:
    """(..., 6, 6): ``a_ik a_jl + a_il a_jk`` in Voigt rows (ij) and columns (kl)."""
    i, j = _ROWS[:, None], _COLS[:, None]
    k, l = _ROWS[None, :], _COLS[None, :]
    return a[..., i, k] * a[..., j, l] + a[..., i, l] * a[..., j, k]


def isotropic_tangent(lame_lambda: float, shear_modulus: float) -> np.ndarray:
    """(6, 6): ``λ I ⊗ I + μ (I ⊙ I)`` in sfepy's plain Voigt components."""
    eye = np.eye(3)
    return (lame_lambda * np.outer(to_voigt(eye), to_voigt(eye))
            + shear_modulus * _symmetric_product(eye))


class CoupledNeoHookeanTLTerm(HyperElasticTLBase):
    r"""Coupled compressible neo-Hookean term, material ``(μ, λ)``.

    :Arguments:
        - material : :math:`\mu, \lambda`
        - virtual  : :math:`\ul{v}`
        - state    : :math:`\ul{u}`
    """

    name = "dw_nf_tl_he_neohook_coupled"
    family_data_names = ["det_f", "sym_inv_c"]
    arg_shapes = {"material": "1, 2", "virtual": ("D", "state"), "state": "D"}
    geometries = ["3_4"]

    @staticmethod
    def _unpack(mat, det_f, inv_c):
        mat = HyperElasticBase.tile_mat(mat, det_f.shape[0])
        mu, lam = mat[..., 0, 0], mat[..., 0, 1]
        return mu, lam, np.log(det_f[..., 0, 0]), inv_c[..., 0]

    def stress_function(self, out, mat, det_f, inv_c, **kwargs):
        mu, lam, log_j, inv_c = self._unpack(mat, det_f, inv_c)
        eye = to_voigt(np.eye(3))
        out[..., 0] = mu[..., None] * (eye - inv_c) + (lam * log_j)[..., None] * inv_c
        return out

    def tan_mod_function(self, out, mat, det_f, inv_c, **kwargs):
        mu, lam, log_j, inv_c = self._unpack(mat, det_f, inv_c)
        out[:] = (lam[..., None, None] * inv_c[..., :, None] * inv_c[..., None, :]
                  + (mu - lam * log_j)[..., None, None] * _symmetric_product(to_matrix(inv_c)))
        return out


class GivenStressTLTerm(HyperElasticTLBase):
    r"""A second Piola–Kirchhoff stress given per quadrature point, plus Kelvin–Voigt
    viscosity; no material argument (the solver sets the attributes below).

    Attributes
    ----------
    history_stress : (n_cells, n_qp, 6) float or None
        The given stress (Pa).
    viscous_tangent : (6, 6) float or None
        ``η/E ℂ₀`` (Pa·s); None: no viscosity.
    rate_coefficient : float
        ``∂Ḟ/∂F`` over a step (2/Δt for the trapezoidal rule).
    previous_gradient, rate_predictor : (n_cells, n_qp, 3, 3) float
        ``Fₙ`` and the part of ``Ḟₙ₊₁`` that does not depend on ``Fₙ₊₁`` (``-Ḟₙ``).
    deformation_gradient : (n_cells, n_qp, 3, 3) float
        F at the last evaluation (read back by the solver).
    """

    name = "dw_nf_tl_given_stress"
    arg_types = ("virtual", "state")
    arg_shapes = {"virtual": ("D", "state"), "state": "D"}
    family_data_names = ["mtx_f"]
    geometries = ["3_4"]

    history_stress = None
    viscous_tangent = None
    rate_coefficient = 0.0
    previous_gradient = None
    rate_predictor = None
    deformation_gradient = None

    def get_fargs(self, virtual, state, mode=None, term_mode=None, diff_var=None, **kwargs):
        return HyperElasticTLBase.get_fargs(self, None, virtual, state, mode=mode,
                                            term_mode=term_mode, diff_var=diff_var, **kwargs)

    def get_eval_shape(self, virtual, state, mode=None, term_mode=None, diff_var=None,
                       **kwargs):
        return HyperElasticTLBase.get_eval_shape(self, None, virtual, state, mode=mode,
                                                 term_mode=term_mode, diff_var=diff_var,
                                                 **kwargs)

    def gradient_rate(self, gradient: np.ndarray) -> np.ndarray:
        """Ḟ at the end of the step for F = ``gradient`` there."""
        return self.rate_coefficient * (gradient - self.previous_gradient) + self.rate_predictor

    def stress_function(self, out, mat, mtx_f, **kwargs):
        self.deformation_gradient = mtx_f.copy()
        out[:] = 0.0
        if self.history_stress is not None:
            out[..., 0] = self.history_stress
        if self.viscous_tangent is not None:
            product = np.einsum("...ki,...kj->...ij", mtx_f, self.gradient_rate(mtx_f))
            rate = to_voigt(0.5 * (product + np.swapaxes(product, -1, -2)))
            rate[..., 3:] *= 2                          # engineering shear rates for ℂ₀
            out[..., 0] += np.einsum("IJ,...J->...I", self.viscous_tangent, rate)
        return out

    def tan_mod_function(self, out, mat, mtx_f, **kwargs):
        out[:] = 0.0
        if self.viscous_tangent is not None:
            # ∂S_v/∂E through Ḟ only; the term δFᵀ Ḟ is left out of the tangent (it is
            # O(Δt) against this one and changes only Newton's rate, not the solution).
            tangent = self.rate_coefficient * self.viscous_tangent
            out[:] = tangent
        return out
