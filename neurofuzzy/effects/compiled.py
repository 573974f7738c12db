"""Which effects the compiled kernels compute, and their values in the kernels' terms, written
once for the stepper (:class:`neurofuzzy._steppers.NumbaStepper`) and the sensitivities
(:class:`neurofuzzy.learn._compiled.CompiledModel`):

- constant forces (gravity, an unmodeled load): added to the loads;
- a node drag ``-b v``;
- inclusions of springs: extra stiffness of their springs; strain stiffening of springs: the
  κ of :func:`neurofuzzy.kernels.stepper.spring_state` (:func:`spring_constants`,
  :func:`spring_columns`);
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

__all__ = ["CONSTANT", "STRETCH", "CLOSING", "CUBIC", "element_inclusion",
           "element_stiffening", "spring_effect", "kernel_effects", "element_constants",
           "kernel_values", "spring_constants", "spring_columns"]

#: effects that are constant forces
CONSTANT = (Gravity, UnmodeledLoad)


#: the spring kernels' bases of a parameter's derivative of a spring's magnitude
#: ``m = s x + c ẋ + q x³`` (``x = l - L0``, ``ẋ`` the closing speed, ``q = κ / L0²``):
#: ``x``, ``ẋ``, ``x³``
STRETCH, CLOSING, CUBIC = 0, 1, 2


def spring_effect(effect) -> bool:
    """An inclusion or strain stiffening of springs (a coefficient per spring group)."""
    return (isinstance(effect, (StiffInclusion, SoftInclusion, NonlinearStiffening))
            and not effect.on_elements)


def _basis(effect) -> int:
    """The basis of a spring effect's coefficient: ``x`` (inclusions), ``x³`` (stiffening,
    with the factor ``1 / L0²``)."""
    return CUBIC if isinstance(effect, NonlinearStiffening) else STRETCH


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
        or element_stiffening(effect) or spring_effect(effect) for effect in model.effects)


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


def spring_constants(model) -> tuple[np.ndarray, np.ndarray]:
    """``(stiffness, q)`` per spring (n_springs,): the springs' own stiffness with the spring
    inclusions' extra stiffness added, and the spring stiffening's ``q = κ / L0²`` (0
    without), the coefficient of ``x³`` in :func:`neurofuzzy.kernels.stepper.spring_state`."""
    stiffness = np.array(model.spring_stiffness, dtype=float)
    cubic = np.zeros(model.n_springs)
    for effect in model.effects:
        if spring_effect(effect):
            if _basis(effect) == CUBIC:
                cubic += effect.per_spring(model) / model.spring_rest_length**2
            else:
                stiffness += effect.per_spring(model)
    return stiffness, cubic


def spring_columns(model, columns: dict[int, int]):
    """The derivatives of the springs' magnitudes by the learned spring effects'
    coefficients, as ``(spring, column, basis, factor)`` arrays (factor 1 for an inclusion's
    ``x``, ``1 / L0²`` for a stiffening's ``x³``): ``columns`` maps the index of each
    learned effect in ``model.effects`` to its first parameter column."""
    parts = []
    for i, effect in enumerate(model.effects):
        if spring_effect(effect) and i in columns:
            selection = effect.selected(model)
            index = effect.parameter_index(model, selection)
            springs = selection[index >= 0]
            basis = _basis(effect)
            factor = (1.0 / model.spring_rest_length[springs]**2 if basis == CUBIC
                      else np.ones(len(springs)))
            parts.append((springs, columns[i] + index[index >= 0],
                          np.full(len(springs), basis), factor))
    if not parts:
        return np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0)
    spring, column, basis, factor = (np.concatenate(part) for part in zip(*parts))
    return spring.astype(np.intp), column.astype(np.intp), basis.astype(np.intp), factor
