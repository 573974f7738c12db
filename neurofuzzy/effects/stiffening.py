"""Nonlinear stiffening: the material grows stiffer with strain, as soft tissue does.

On a spring network every spring pulls ``κ (l - L0)³ / L0²`` extra (κ per spring group, N/m).
On a tetrahedral-element model every element gains the strain energy
``W = ½ κ V (G:G)²`` (κ in Pa, one value), i.e. the extra second Piola–Kirchhoff stress
``S = 2 κ (G:G) G`` with ``G`` the Green strain: quartic in the strain, so nothing changes at
small strain, and independent of the model's own E, ν and η (their derivatives stay exact when
both are fitted). The force is conservative, so its position Jacobian is symmetric: the
state VJP is the JVP of the cotangent.

In the diagnosis of an element model the entry is not that patch but a **switch of the law**
(:attr:`NonlinearStiffening.switches_material` on elements): neo-Hookean elements become Yeoh's
strain-stiffening ones (:mod:`neurofuzzy.forces.laws`, C₂₀/C₁₀ started at 1 and refitted with
E, ν and η), the same at small strain. It is offered once the elements are neo-Hookean (an SVK
model is first offered ``hyperelasticity``): Yeoh's law contains a neo-Hookean-like solid, so
offering both at once would let the larger law win on data the smaller one explains.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..forces import tetrahedron_geometry
from ..forces.element_forces import columns
from ..forces.laws import DEFAULT_STIFFENING, LAWS, ElementStress
from ..forces.springs import spring_constants, spring_law
from .base import Effect, register
from .springs import SpringEffect

__all__ = ["NonlinearStiffening"]


def _sym(matrix):
    return 0.5 * (matrix + np.swapaxes(matrix, -1, -2))


@register
class NonlinearStiffening(SpringEffect):
    """Spring force grows faster than linear: ``κ (l - L0)³ / L0²`` extra (κ per group, N/m);
    relative to the spring's stiffness, ``β = κ / s``: ``f = s (l - L0) [1 + β ((l - L0)/L0)²]``.
    On elements (``on="elements"``, one κ in Pa): extra stress ``2 κ (G:G) G``."""

    name = "nonlinear_stiffening"
    coefficient = "kappa"

    def __init__(self, params, *, on: str = "springs", **options):
        if on not in ("springs", "elements"):
            raise InputError(f"got {on!r}; nonlinear_stiffening acts on 'springs' or "
                             "'elements'", key="on")
        if on == "springs":
            super().__init__(params, **options)
            return
        if options:
            raise InputError(f"nonlinear_stiffening on elements takes no options "
                             f"({', '.join(sorted(options))})", key="on")
        Effect.__init__(self, params, on="elements")

    @property
    def on_elements(self) -> bool:
        return self.options.get("on") == "elements"

    def compile(self, layout, model, column):
        """The elements' κ, or a second central force along springs that stiffens."""
        if self.on_elements:
            layout.add_stiffening(self.params[0], column)
        else:
            layout.add_spring_cubic(self.per_spring(model), self.learned_springs(model, column))

    @property
    def one_per_model(self) -> bool:
        """On elements: a model's elements stiffen by one κ."""
        return self.on_elements

    @property
    def switches_material(self) -> bool:
        """On elements the diagnosis switches their law to Yeoh's (module docstring)."""
        return self.on_elements

    def switched_values(self, model) -> dict[str, float]:
        """Yeoh's C₂₀/C₁₀ of the refitted elements (the median)."""
        return {"stiffening": float(np.median(model.elements.stiffening))}

    @staticmethod
    def switch(model, duration: float, share: float | None = None):
        """``model`` with Yeoh elements of the default C₂₀/C₁₀ (what the diagnosis refits
        when the entry wins on an element model; ``duration`` and ``share`` unused)."""
        return model.with_elements(law="yeoh", stiffening=DEFAULT_STIFFENING)

    @property
    def labels(self):
        return ("kappa",) if self.on_elements else super().labels

    @property
    def unit(self):
        """Pa for elements, N/m for springs (exponents of length, time, mass)."""
        return (-1, -2, 1) if self.on_elements else (0, -2, 1)

    def shape(self, model, state, selection):
        """``(x³ / L0², 3 x² / L0²)``: the magnitude of a unit κ, ``q = κ / L0²``
        (:func:`neurofuzzy.kernels.springs.magnitude`)."""
        return spring_law().magnitudes(state.stretch,
                                       cubic=spring_constants(model)[2][selection] ** -2.0)

    @classmethod
    def examples(cls, model):
        """κ = 3 kPa on elements; κ = 400 N/m per spring group on springs."""
        if model.elements is not None:
            return [(model, cls([3e3], on="elements"))]
        return [(model, cls.for_model(model, 400.0))]

    @classmethod
    def propose(cls, model, evidence):
        """One coefficient per spring group on spring networks; on element models with
        neo-Hookean elements the switch to Yeoh's law (module docstring), none on others."""
        if cls.name in evidence.present:
            return []
        if model.elements is not None and not np.any(spring_constants(model)[0]):
            neo_hookean = np.all(model.elements.law == LAWS.index("neo-hookean"))
            return [cls([0.0], on="elements")] if neo_hookean else []
        return [cls.for_model(model, [0.0])]

    # -- elements -----------------------------------------------------------------------------
    def _strain(self, model, positions):
        geometry = tetrahedron_geometry(model.mesh)
        F = geometry.edges(positions) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        return geometry, F, green

    def _stress(self, model, green, kappa) -> ElementStress:
        """The elements' stress of the effect alone, ``2κ (G:G) G`` (every other constant
        0), from the compiled stress the kernels step with (:mod:`neurofuzzy.kernels.laws`)."""
        none = np.zeros(len(green))
        return ElementStress.at(model.elements.law, green, np.zeros_like(green), none, none,
                                none, none, model.elements.stiffening,
                                (none, np.zeros_like(green)), kappa=kappa)

    def _element_force(self, model, positions, kappa):
        geometry, F, green = self._strain(model, positions)
        stress = self._stress(model, green, kappa).stress()
        return geometry.scatter(columns(geometry, F @ stress), len(positions))

    def force(self, model, positions, velocities):
        if not self.on_elements:
            return super().force(model, positions, velocities)
        return self._element_force(model, positions, self.params[0])

    def parameter_jacobian(self, model, positions, velocities):
        if not self.on_elements:
            return super().parameter_jacobian(model, positions, velocities)
        return self._element_force(model, positions, 1.0)[:, None, :]

    def state_jvp(self, model, positions, velocities, dp, dv):
        if not self.on_elements:
            return super().state_jvp(model, positions, velocities, dp, dv)
        geometry, F, green = self._strain(model, positions)
        at = self._stress(model, green, self.params[0])
        dF = geometry.edges(dp) @ geometry.inverse_rest[:, None]          # (K, P, 3, 3)
        d_green = _sym(np.swapaxes(F[:, None], -1, -2) @ dF)
        none = np.zeros(d_green.shape[:2])
        d_stress = at.jvp(d_green, np.zeros_like(d_green), none, none)
        d_piola = dF @ at.stress()[:, None] + F[:, None] @ d_stress
        return geometry.scatter(columns(geometry, d_piola), len(positions))

    def state_vjp(self, model, positions, velocities, cotangent):
        if not self.on_elements:
            return super().state_vjp(model, positions, velocities, cotangent)
        # conservative: ∂F/∂p is symmetric, so (∂F/∂p)ᵀ λ = (∂F/∂p) λ; no velocity part
        bar_p = self.state_jvp(model, positions, velocities, cotangent[:, None, :],
                               np.zeros_like(cotangent)[:, None, :])[:, 0]
        return bar_p, np.zeros_like(cotangent)

    def relative(self, model) -> dict[str, float]:
        """κ per group relative to its springs' stiffness, or to the elements' mean shear
        modulus ``μ``."""
        if not self.on_elements:
            return super().relative(model)
        mu = model.elements.youngs_modulus / (2.0 * (1.0 + model.elements.poisson_ratio))
        return {"kappa": float(self.params[0] / np.mean(mu))}

    def equation(self):
        if self.on_elements:
            return (f"nonlinear_stiffening: S += 2 κ (G:G) G on every element; "
                    f"κ = {self.params[0]:.4g} Pa")
        return f"nonlinear_stiffening: f += κ (l - L0)³ / L0²; {self._values()}"
