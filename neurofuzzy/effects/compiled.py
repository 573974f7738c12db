"""Which effects the compiled kernels compute, and their values in the kernels' terms, written
once for the stepper (:class:`neurofuzzy._steppers.NumbaStepper`) and the sensitivities
(:class:`neurofuzzy.learn._compiled.CompiledModel`):

- constant forces (gravity, an unmodeled load): added to the loads;
- a node drag ``-b v``;
- inclusions of elements: extra element constants (:meth:`StiffInclusion.added_constants`);
- strain stiffening of the elements: ``κ`` of :mod:`neurofuzzy.kernels.laws`.

Every other effect takes the numpy path.
"""

from __future__ import annotations

import numpy as np

from ..forces.tetra_geometry import ElementConstants
from .inclusions import SoftInclusion, StiffInclusion
from .nodes import Gravity, NodeDrag, UnmodeledLoad
from .stiffening import NonlinearStiffening

__all__ = ["CONSTANT", "element_inclusion", "element_stiffening", "kernel_effects",
           "element_constants", "kernel_values"]

#: effects that are constant forces
CONSTANT = (Gravity, UnmodeledLoad)


def element_inclusion(effect) -> bool:
    return isinstance(effect, (StiffInclusion, SoftInclusion)) and effect.on_elements


def element_stiffening(effect) -> bool:
    return isinstance(effect, NonlinearStiffening) and effect.on_elements


def kernel_effects(model) -> bool:
    """True when the compiled kernels compute every effect of ``model`` (at most one node drag
    and one strain stiffening)."""
    drags = sum(isinstance(effect, NodeDrag) for effect in model.effects)
    stiffenings = sum(element_stiffening(effect) for effect in model.effects)
    return drags <= 1 and stiffenings <= 1 and all(
        isinstance(effect, (*CONSTANT, NodeDrag)) or element_inclusion(effect)
        or element_stiffening(effect) for effect in model.effects)


def element_constants(model) -> tuple[ElementConstants, dict[str, np.ndarray]]:
    """The model's own element :class:`ElementConstants` and the constants ``shear``,
    ``shear_rate``, ``lam``, ``lam_rate`` (per element) with its inclusions' added."""
    own = ElementConstants.of(model)
    parts = [own] + [effect.added_constants(model, effect.params[0])
                     for effect in model.effects if element_inclusion(effect)]
    return own, {key: sum(getattr(part, key) for part in parts)
                 for key in ("shear", "shear_rate", "lam", "lam_rate")}


def kernel_values(model) -> tuple[float, np.ndarray, float]:
    """``(drag, constant force (n_nodes, 3), κ)`` of the model's effects (0, zeros, 0
    without)."""
    drag, kappa = 0.0, 0.0
    constant = np.zeros((model.n_nodes, 3))
    for effect in model.effects:
        if isinstance(effect, NodeDrag):
            drag = float(effect.params[0])
        elif isinstance(effect, CONSTANT):
            constant += effect.force(model, model.mesh.rest_positions, None)
        elif element_stiffening(effect):
            kappa = float(effect.params[0])
    return drag, constant, kappa
