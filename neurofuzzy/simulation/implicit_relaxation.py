"""The derivatives of the Prony terms' internal variables through implicit steps
(:class:`RelaxationTangent`), for :func:`~.implicit_derivatives.implicit_sensitivities`.

An implicit step takes the internal variables one step on from the state it starts at and
holds them through its solve (:mod:`.implicit`): ``rᵢ' = aᵢ rᵢ - (1 - aᵢ) S_e(x₀)``, and the
step's force holds ``Σᵢ gᵢ rᵢ'`` as a stress of its own. Differentiated by a constant θ,

    drᵢ' = aᵢ drᵢ - (1 - aᵢ) (∂S_e/∂G dG(dx₀) + ∂S_e/∂π dπ + D(G) d(2μ)),

with ``dG = sym(Fᵀ dF)``, ``dπ`` the volumetric stress's change (``dλ θ + λ N:dG`` per
element, or the nodal form's node averages of both) and ``D(G)`` the law's stress per unit
of ``2μ`` (every law's stress is linear in ``2μ`` and ``π``); the step's equation then
gains the force of the stress ``Σᵢ gᵢ drᵢ'`` at the step's end, ``-V F (Σᵢ gᵢ drᵢ') Bᵀ``,
beside ``∂F/∂θ``. The law's derivatives are the kernels' complex-step ones
(:func:`~neurofuzzy.kernels.law_arrays.stress_jvp_arrays`); the rest is the chain rule over
arrays of elements, no loop over them.
"""

from __future__ import annotations

import numpy as np

from ..effects.compiled import element_constants
from ..forces.tetra_geometry import lame_factors

__all__ = ["RelaxationTangent"]


class RelaxationTangent:
    """``drᵢ`` of a run's elements by each column (E, ν, η of each group), advanced with
    the run (module docstring).

    Parameters
    ----------
    model : Model
        Elements with Prony terms, no effects.
    groups : (n_elements,) int
        The element groups of the columns.
    values : [E, ν, η]
        Per group (:func:`~.implicit_derivatives._grouped`).
    decay : (n_elements, n_terms) float
        ``aᵢ = exp(-h/τᵢ)`` of the run's step.
    """

    def __init__(self, model, groups, values, decay):
        constants, total = element_constants(model)
        geometry = constants.geometry
        self.geometry, self.tets = geometry, np.asarray(geometry.nodes, np.intp)
        self.inverse_rest = np.asarray(geometry.inverse_rest, float)
        self.volume = np.asarray(geometry.volume, float)
        self.nodal, self.average = bool(constants.nodal), geometry.average
        self.law = np.array(constants.law, np.intp)
        self.law_constant = np.array(model.elements.stiffening, float)
        self.shear = np.array(total["shear"], float)
        self.lam = np.array(total["lam"], float)
        self.moduli = np.array(model.elements.relaxation_moduli, float)      # (K, T)
        self.decay = np.array(decay, float)
        E, nu, _ = values
        a, b, da, db = lame_factors(nu)
        n_groups, k = len(E), len(self.tets)
        member = (np.asarray(groups)[None, :] == np.arange(n_groups)[:, None]).astype(float)
        zero = np.zeros((n_groups, k))
        # per column: d(2μ) and dλ of every element (E, then ν, then η; η moves neither)
        self.d_shear = np.concatenate([2 * b[:, None] * member,
                                       2 * (db * E)[:, None] * member, zero])
        self.d_lam = np.concatenate([a[:, None] * member, (da * E)[:, None] * member, zero])
        self.dr = np.zeros((len(self.d_shear), k, self.moduli.shape[1], 3, 3))

    def advance(self, x0: np.ndarray, dx0: np.ndarray) -> None:
        """``drᵢ ← aᵢ drᵢ - (1 - aᵢ) dS_e`` from the state the step starts at, ``x0``
        (n_nodes, 3), and its derivatives ``dx0`` (columns, 3 n_nodes)."""
        from ..kernels.law_arrays import stress_arrays, stress_jvp_arrays, volumetric_arrays

        k = len(self.tets)
        geometry = self.geometry
        F = geometry.edges(np.asarray(x0, float).reshape(-1, 3)) @ self.inverse_rest
        tangent = np.asarray(dx0, float).reshape(len(dx0), -1, 3).transpose(1, 0, 2)
        dF = geometry.edges(tangent) @ self.inverse_rest[:, None]           # (K, M, 3, 3)
        G = 0.5 * (np.swapaxes(F, -1, -2) @ F - np.eye(3))[:, None]        # (K, 1, 3, 3)
        product = np.swapaxes(F, -1, -2)[:, None] @ dF
        dG = np.ascontiguousarray(0.5 * (product + np.swapaxes(product, -1, -2)))
        theta, N = np.zeros(k), np.zeros((k, 1, 3, 3))
        volumetric_arrays(self.law, np.ascontiguousarray(G), theta, N)
        d_theta = np.einsum("kij,kmij->km", N[:, 0], dG)                    # (K, M)
        if self.nodal:
            average_theta = self.average @ theta                             # (n_nodes,)
            node_lam = self.average @ self.lam
            pressure = 0.25 * (node_lam * average_theta)[self.tets].sum(axis=1)
            d_node = (self.average @ self.d_lam.T) * average_theta[:, None] \
                + node_lam[:, None] * (self.average @ d_theta)               # (n_nodes, M)
            d_pressure = 0.25 * d_node[self.tets].sum(axis=1)                # (K, M)
        else:
            pressure = self.lam * theta
            d_pressure = self.d_lam.T * theta[:, None] + self.lam[:, None] * d_theta
        zeros = np.zeros(k)
        rate = np.zeros_like(G)
        change = np.zeros_like(dG)
        stress_jvp_arrays(self.law, np.ascontiguousarray(G), rate,
                          (self.shear, zeros, pressure, zeros, 0.0, self.law_constant),
                          (dG, np.zeros_like(dG), np.ascontiguousarray(d_pressure),
                           np.zeros_like(d_pressure)), change)
        unit = np.zeros_like(G)                               # D(G): the stress per unit 2μ
        stress_arrays(self.law, np.ascontiguousarray(G), rate,
                      (np.ones(k), zeros, zeros, zeros, 0.0, self.law_constant), unit)
        d_elastic = np.moveaxis(change, 1, 0) + self.d_shear[:, :, None, None] * unit[:, 0]
        a = self.decay[None, :, :, None, None]
        self.dr = a * self.dr - (1.0 - a) * d_elastic[:, :, None]

    def force(self, x1: np.ndarray) -> np.ndarray:
        """The force of the stress ``Σᵢ gᵢ drᵢ`` at the state ``x1`` (n_nodes, 3), per column:
        (columns, 3 n_nodes)."""
        x1 = np.asarray(x1, float).reshape(-1, 3)
        F = self.geometry.edges(x1) @ self.inverse_rest                     # (K, 3, 3)
        stress = np.einsum("kt,mktij->kmij", self.moduli, self.dr)          # (K, M, 3, 3)
        columns = -self.volume[:, None, None, None] * (
            F[:, None] @ stress @ np.swapaxes(self.inverse_rest, -1, -2)[:, None])
        forces = self.geometry.scatter(columns, len(x1))                    # (n_nodes, M, 3)
        return forces.transpose(1, 0, 2).reshape(len(self.dr), -1)
