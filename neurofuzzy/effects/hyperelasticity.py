"""Large-strain hyperelasticity: the diagnosis' candidate for "the elements' law is wrong at
large strain", a switch of the elements to the neo-Hookean law.

A St. Venant–Kirchhoff element model softens under strong compression (beyond about 30 %,
under a probe) where tissue stiffens; the neo-Hookean law (:mod:`neurofuzzy.forces.laws`) has
the same E, ν and η at small strain and does not. The diagnosis scores the candidate by the
change of the marker residual when the elements' law is switched (the secant of the switch,
one compiled run of the neo-Hookean model) and, when it wins, switches the law
(:attr:`Hyperelasticity.switches_to`) and refits (:mod:`neurofuzzy.diagnosis.loop`), so the
model it returns is a neo-Hookean one. Only element models with St. Venant–Kirchhoff elements
are offered it. It is not a force: a model never carries it (:class:`~.base.MaterialSwitch`).
"""

from __future__ import annotations

import numpy as np

from ..forces.laws import LAWS
from .base import MaterialSwitch, register

__all__ = ["Hyperelasticity", "NEO_HOOKEAN"]

#: the law number the switch moves the elements to
NEO_HOOKEAN = LAWS.index("neo-hookean")


@register
class Hyperelasticity(MaterialSwitch):
    """Switch the elements to the neo-Hookean law (module docstring)."""

    name = "hyperelasticity"
    #: the diagnosis switches the elements to this law
    switches_to = NEO_HOOKEAN
    instead = "give the elements the neo-Hookean law (law: neo-hookean)"

    @classmethod
    def switch(cls, model, duration: float, share: float | None = None):
        """``model`` with neo-Hookean elements (what the diagnosis refits when the candidate
        wins; ``duration`` and the linearised ``share`` unused: a law is switched whole)."""
        return model.with_elements(law=cls.switches_to)

    @classmethod
    def propose(cls, model, evidence) -> list:
        """One candidate on element models with St. Venant–Kirchhoff elements."""
        if (cls.name in evidence.present or model.elements is None
                or not np.any(model.elements.law == LAWS.index("st-venant-kirchhoff"))):
            return []          # neo-Hookean or Yeoh elements already stiffen
        return [cls([0.0])]

    def equation(self) -> str:
        return ("hyperelasticity: the elements take the neo-Hookean law "
                "(S = μ (I - C⁻¹) + λ ln J C⁻¹)")
