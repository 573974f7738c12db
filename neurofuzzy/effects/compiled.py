"""The effects the compiled kernels compute, and their values in the kernels' terms, written
once for the stepper (:class:`neurofuzzy.simulation.steppers.NumbaStepper`) and the sensitivities
(:class:`neurofuzzy.learn._compiled.CompiledModel`). Every effect says how the kernels compute it
(:attr:`~neurofuzzy.forces.ForceTerm.compiled_as`, one of
:data:`~neurofuzzy.forces.base.COMPILED_AS`):

- ``"constant force"`` (gravity, an unmodeled load): added to the loads;
- ``"node drag"``: ``-b v`` on every node;
- ``"spring stretch"`` (inclusions of springs): extra stiffness of their springs;
  ``"spring cubic"`` (strain stiffening of springs): a second central force along each spring
  that stiffens, ``q x³`` of :func:`neurofuzzy.kernels.stepper.spring_state`
  (:func:`spring_entries`);
- ``"element constants"`` (inclusions of elements): extra element constants
  (:meth:`StiffInclusion.added_constants`);
- ``"element stiffening"`` (strain stiffening of the elements): ``κ`` of
  :mod:`neurofuzzy.kernels.laws`.

A model carries no other effect, and at most one node drag and one element stiffening
(:func:`neurofuzzy.model.model._ordered` refuses the rest).
"""

from __future__ import annotations

import numpy as np

from ..forces.springs import spring_constants
from ..forces.tetra_geometry import ElementConstants
from ..kernels.springs import CLOSING, CUBIC, STRETCH

__all__ = ["STRETCH", "CLOSING", "CUBIC", "constant_force", "node_drag", "element_inclusion",
           "element_stiffening", "spring_effect", "element_constants",
           "kernel_values", "spring_entries"]

#: the basis of a spring effect's coefficient: ``x`` (inclusions), ``x³`` (stiffening, with
#: the factor ``1 / L0²``)
_BASIS = {"spring stretch": STRETCH, "spring cubic": CUBIC}


def constant_force(effect) -> bool:
    """A force that does not depend on the state (gravity, an unmodeled load)."""
    return effect.compiled_as == "constant force"


def node_drag(effect) -> bool:
    return effect.compiled_as == "node drag"


def spring_effect(effect) -> bool:
    """An inclusion or strain stiffening of springs (a coefficient per spring group)."""
    return effect.compiled_as in _BASIS


def element_inclusion(effect) -> bool:
    return effect.compiled_as == "element constants"


def element_stiffening(effect) -> bool:
    return effect.compiled_as == "element stiffening"


def element_constants(model) -> tuple[ElementConstants, dict[str, np.ndarray]]:
    """The model's own element :class:`ElementConstants` and the constants ``shear``,
    ``shear_rate``, ``lam``, ``lam_rate`` (per element) with its inclusions' added."""
    own = model.elements.constants(model)
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
        if node_drag(effect):
            drag = float(effect.params[0])
        elif constant_force(effect):
            constant += effect.force(model, model.mesh.rest_positions, None)
        elif element_stiffening(effect):
            kappa = float(effect.params[0])
    return drag, constant, kappa


def spring_entries(model, columns: dict[int, int] | None = None, *, every_spring=False):
    """The springs as the kernels step them (:func:`neurofuzzy.kernels.stepper._springs`):
    the model's springs, then once more each spring that stiffens, with no stiffness or
    damping of its own and its ``q = κ / L0²`` (a second central force along the same spring,
    so that the springs that do not stiffen are stepped with ``q = 0`` compiled in).

    ``columns`` maps the index of each learned effect in ``model.effects`` to its first
    parameter column; ``every_spring`` keeps springs with no force (their own constants are
    learned). Returns ``(spring, stiffness, damping, cubic, derivatives)``: per entry the
    model's spring index, the stiffness (the spring inclusions' added) and the damping;
    ``cubic`` the ``q`` of the last ``len(cubic)`` entries; ``derivatives`` the spring effects'
    parameter derivatives of the entries' magnitudes as ``(entry, column, basis, factor)``
    arrays (an inclusion's ``x`` with factor 1, a stiffening's ``x³`` with ``1 / L0²``).
    """
    columns = columns or {}
    own_stiffness, damping, rest_length = spring_constants(model)
    keep = every_spring | (own_stiffness != 0) | (damping != 0)
    if not any(spring_effect(effect) for effect in model.effects):    # most models: quickly
        plain = np.flatnonzero(keep)
        return (plain, np.asarray(own_stiffness[plain], float),
                np.asarray(damping[plain], float), np.zeros(0),
                (np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0)))
    stiffness = np.array(own_stiffness, dtype=float)
    cubic = np.zeros(model.n_springs)
    stiffens = np.zeros(model.n_springs, bool)
    learned = []                           # (springs, column, basis, factor) per effect
    for i, effect in enumerate(model.effects):
        if not spring_effect(effect):
            continue
        selection = effect.selected(model)
        index = effect.parameter_index(model, selection)
        springs = selection[index >= 0]
        basis = _BASIS[effect.compiled_as]
        if basis == CUBIC:
            cubic += effect.per_spring(model) / rest_length**2
            stiffens[springs] |= i in columns
            factor = 1.0 / rest_length[springs]**2
        else:
            stiffness += effect.per_spring(model)
            keep[springs] |= i in columns
            factor = np.ones(len(springs))
        if i in columns:
            learned.append((springs, columns[i] + index[index >= 0], basis, factor))
    keep |= stiffness != 0                 # an inclusion's springs with no force of their own
    stiffens |= cubic != 0
    plain, tail = np.flatnonzero(keep), np.flatnonzero(stiffens)
    entry = np.full((2, model.n_springs), -1, np.intp)     # model spring → plain, tail entry
    entry[0, plain] = np.arange(len(plain))
    entry[1, tail] = len(plain) + np.arange(len(tail))
    parts = [(entry[int(basis == CUBIC), springs], column, np.full(len(springs), basis),
              factor) for springs, column, basis, factor in learned]
    derivatives = tuple(np.concatenate([part[k] for part in parts]) if parts else
                        np.zeros(0, float if k == 3 else np.intp) for k in range(4))
    spring = np.concatenate([plain, tail])
    zeros = np.zeros(len(tail))
    return (spring, np.concatenate([stiffness[plain], zeros]),
            np.concatenate([damping[plain], zeros]), cubic[tail], derivatives)
