"""Viscoelastic relaxation: the diagnosis' candidate for "the elements' stress relaxes (and the
tissue creeps) under a held load", whose addition gives every element a Prony term
(:mod:`neurofuzzy.forces.relaxation`).

A model without relaxation can only meet creep under a held load with a stiffer E and a larger
Kelvin–Voigt η: the words then say "hard" and "viscous" for a firm tissue that relaxes. Like
:mod:`.hyperelasticity` the candidate is a switch of the elements' material, not a force patch:
the diagnosis scores it by the change of the marker residual when every element takes one
Prony term (one compiled run of the switched model, :meth:`Relaxation.switch`) and, when it
wins, refits the switched model, so the model it returns relaxes. It is not a force: a model
never carries it (:class:`~.base.MaterialSwitch`).
"""

from __future__ import annotations

import numpy as np

from ..forces.relaxation import START_RELATIVE_MODULUS, relaxation_fields
from .base import MaterialSwitch, register

__all__ = ["Relaxation", "PROBE_RELATIVE_MODULUS", "MAX_START"]

#: The relative modulus of the diagnosis's probe of relaxation
#: (:meth:`Relaxation.probe_switch`), and the least a refit starts from.
PROBE_RELATIVE_MODULUS = 0.05
#: The most relative modulus a refit starts from (soft tissue's range reaches about 3).
MAX_START = 3.0


def _start_time(duration: float) -> float:
    """τ of the switch's Prony term: a fifth of the recording, so it relaxes within it."""
    return max(float(duration), 1e-6) / 5.0


@register
class Relaxation(MaterialSwitch):
    """Give every element one Prony term (module docstring)."""

    name = "relaxation"
    switches_partly = True
    instead = "give the elements Prony terms (fit with --relaxation)"

    @staticmethod
    def switch(model, duration: float, share: float | None = None):
        """``model`` whose elements relax, for the refit to start from: one Prony term, τ a
        fifth of the recording's ``duration`` (s), and g = 0.5, or, given the ``share`` of
        the probe (:meth:`probe_switch`) that the diagnosis's linearised fit asks for,
        ``share`` × :data:`PROBE_RELATIVE_MODULUS` within [that, :data:`MAX_START`]. On
        sfepy's relaxing block on 4 mm voxels (g = 0.5, τ = 50 ms), the linearised start
        (g = 0.14) refitted in 113 s, the fixed one in 152 s, to the same values (g = 0.47,
        τ = 52 ms)."""
        g = (START_RELATIVE_MODULUS if share is None or not np.isfinite(share)
             else float(np.clip(share * PROBE_RELATIVE_MODULUS, PROBE_RELATIVE_MODULUS,
                                MAX_START)))
        return model.with_elements(**relaxation_fields([(g, _start_time(duration))]))

    def probe_switch(self, model, duration: float):
        """``model`` whose elements relax a little (g = :data:`PROBE_RELATIVE_MODULUS`, τ
        as in :meth:`switch`): the secant of the diagnosis's evidence. The whole switch's
        secant is far outside the linear range: on sfepy's relaxing block (g = 0.5, τ = 50 ms)
        fitted as SVK with damping on 4 mm voxels, it explained 1 % of the misfit above the
        noise, a tenth of the way (g = 0.05) 22 %."""
        return model.with_elements(**relaxation_fields([(PROBE_RELATIVE_MODULUS,
                                                         _start_time(duration))]))

    def switched_values(self, model) -> dict[str, float]:
        """The refitted elements' relative modulus g and time τ (s) (medians)."""
        return {"relaxation_modulus": float(np.median(model.elements.relaxation_moduli)),
                "relaxation_time": float(np.median(model.elements.relaxation_times))}

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
