"""Viscoelastic relaxation: the diagnosis' candidate for "the elements' stress relaxes (and the
tissue creeps) under a held load", whose addition gives every element a Prony term
(:mod:`neurofuzzy.forces.relaxation`).

A model without relaxation can only meet creep under a held load with a stiffer E and a larger
Kelvin–Voigt η: the words then say "hard" and "viscous" for a firm tissue that relaxes. Like
:mod:`.hyperelasticity` the candidate is a switch of the elements' material, not a force patch:
the diagnosis scores it by the change of the marker residual when every element takes one
Prony term (one compiled run of the switched model, :meth:`Relaxation.switch`) and, when it
wins, refits the switched model, so the model it returns relaxes and carries no effect.

The relaxation's internal variables have no place in a stateless force: the effect has no
force of its own (:meth:`Relaxation.force` says so) and is never added to a model.
"""

from __future__ import annotations


import numpy as np

from ..errors import InputError
from ..forces.relaxation import START_RELATIVE_MODULUS, relaxation_fields
from .base import Effect, register

__all__ = ["Relaxation", "PROBE_RELATIVE_MODULUS"]

#: The relative modulus of the diagnosis's probe of relaxation (:meth:`Relaxation.probe_switch`).
PROBE_RELATIVE_MODULUS = 0.05


@register
class Relaxation(Effect):
    """The share ``s`` (1) of the way to elements with one Prony term (module docstring)."""

    name = "relaxation"
    unit = (0, 0, 0)
    _labels = ("share",)
    switches_material = True

    @staticmethod
    def switch(model, duration: float):
        """``model`` whose elements relax: one Prony term, g = 0.5 and τ a fifth of the
        recording's ``duration`` (s), for the refit to start from."""
        return model.with_elements(**relaxation_fields([(START_RELATIVE_MODULUS,
                                                   max(float(duration), 1e-6) / 5.0)]))

    def probe_switch(self, model, duration: float):
        """``model`` whose elements relax a little (g = :data:`PROBE_RELATIVE_MODULUS`, τ
        as in :meth:`switch`): the secant of the diagnosis's evidence. The whole switch's
        secant is far outside the linear range: on sfepy's relaxing block (g = 0.5, τ = 50 ms)
        fitted as SVK with damping on 4 mm voxels, it explained 1 % of the misfit above the
        noise, a twentieth of the way 22 %."""
        return model.with_elements(**relaxation_fields([(PROBE_RELATIVE_MODULUS,
                                                   max(float(duration), 1e-6) / 5.0)]))

    def switched_values(self, model) -> dict[str, float]:
        """The refitted elements' relative modulus g and time τ (s) (medians)."""
        return {"relaxation_modulus": float(np.median(model.elements.relaxation_moduli)),
                "relaxation_time": float(np.median(model.elements.relaxation_times))}

    def force(self, model, positions, velocities):
        raise InputError("relaxation is a change of the elements' material (a Prony term with "
                         "internal variables), not a force a model can carry: fit with "
                         "--relaxation instead", key="effects")

    parameter_jacobian = force

    @classmethod
    def examples(cls, model) -> list:
        """None: it has no force to check (the switched model's derivatives are checked in
        ``tests/test_relaxation.py``)."""
        return []

    @classmethod
    def propose(cls, model, evidence) -> list:
        """One candidate on element models whose elements do not relax yet."""
        if (cls.name in evidence.present or model.elements is None
                or model.n_relaxation_terms):
            return []
        return [cls([0.0])]

    def equation(self) -> str:
        return ("relaxation: every element gets a Prony term, S = S_e + g h, "
                "dh/dt = dS_e/dt - h/tau (the long-term E, 1 + g times stiffer at once)")
