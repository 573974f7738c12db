"""Large-strain hyperelasticity: the diagnosis' candidate for "the elements' law is wrong at
large strain", whose addition makes the elements neo-Hookean.

A St. Venant–Kirchhoff element model softens under strong compression (beyond about 30 %,
under a probe) where tissue stiffens; the neo-Hookean law (:mod:`neurofuzzy.forces.laws`) has
the same E, ν and η at small strain and does not. As a force term the effect is the share
``s`` of the way from the model's own elements to the same elements with the neo-Hookean law::

    f = s (f_neo-Hookean(x, v) - f_own(x, v))

so that ``s = 0`` is the model as it is and ``s = 1`` the neo-Hookean model. The diagnosis
scores the candidate by the change of the marker residual from ``s = 0`` to ``s = 1`` (the
secant of the switch, one compiled run of the neo-Hookean model) and, when it wins, does not
keep the patch: it switches the elements' law (:attr:`Hyperelasticity.switches_to`) and
refits (:mod:`neurofuzzy.diagnosis.loop`), so the model it returns is a neo-Hookean one with
no effect added. Only element models with St. Venant–Kirchhoff elements are offered it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..forces import ElementConstants
from ..forces.element_forces import element_force, element_state_jvp, element_state_vjp
from ..forces.laws import LAWS
from .base import Effect, register

__all__ = ["Hyperelasticity", "NEO_HOOKEAN"]

#: the law number the effect moves the elements to
NEO_HOOKEAN = LAWS.index("neo-hookean")


@register
class Hyperelasticity(Effect):
    """The share ``s`` (1) of the way to neo-Hookean elements (module docstring)."""

    name = "hyperelasticity"
    unit = (0, 0, 0)
    _labels = ("share",)
    #: the diagnosis switches the elements to this law instead of keeping the effect
    switches_to = NEO_HOOKEAN
    switches_material = True

    @classmethod
    def switch(cls, model, duration: float, share: float | None = None):
        """``model`` with neo-Hookean elements (what the diagnosis refits when the candidate
        wins; ``duration`` and the linearised ``share`` unused: a law is switched whole)."""
        return model.with_elements(law=cls.switches_to)

    @staticmethod
    def _pair(model) -> tuple[ElementConstants, ElementConstants]:
        own = model.elements.constants(model)
        return own, replace(own, law=np.full_like(own.law, NEO_HOOKEAN))

    def _difference(self, function, model, *args):
        own, target = self._pair(model)
        return function(target, *args) - function(own, *args)

    def force(self, model, positions, velocities):
        return self.params[0] * self._difference(element_force, model, positions, velocities)

    def parameter_jacobian(self, model, positions, velocities):
        return self._difference(element_force, model, positions, velocities)[:, None, :]

    def state_jvp(self, model, positions, velocities, dp, dv):
        return self.params[0] * self._difference(element_state_jvp, model, positions, velocities,
                                                 dp, dv)

    def state_vjp(self, model, positions, velocities, cotangent):
        own, target = self._pair(model)
        lam_p, lam_v = element_state_vjp(target, positions, velocities, cotangent)
        own_p, own_v = element_state_vjp(own, positions, velocities, cotangent)
        return self.params[0] * (lam_p - own_p), self.params[0] * (lam_v - own_v)

    @classmethod
    def examples(cls, model) -> list:
        """Half way to neo-Hookean on element models."""
        return [(model, cls([0.5]))] if model.elements is not None else []

    @classmethod
    def propose(cls, model, evidence) -> list:
        """One candidate on element models with St. Venant–Kirchhoff elements."""
        if (cls.name in evidence.present or model.elements is None
                or not np.any(model.elements.law == LAWS.index("st-venant-kirchhoff"))):
            return []          # neo-Hookean or Yeoh elements already stiffen
        return [cls([0.0])]

    def equation(self) -> str:
        return (f"hyperelasticity: the elements {self.params[0]:.3g} of the way to the "
                "neo-Hookean law (S = μ (I - C⁻¹) + λ ln J C⁻¹)")
