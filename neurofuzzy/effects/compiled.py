"""The effects in the compiled kernels' terms: :class:`KernelEffects`, the share of a model's
effects in the arrays the kernels step with, written by each effect itself
(:meth:`~neurofuzzy.effects.Effect.compile`) once for the stepper
(:class:`neurofuzzy.simulation.steppers.NumbaStepper`), the sensitivities and the adjoint
(:class:`neurofuzzy.learn._compiled.CompiledModel`) and the static and implicit solves.

The kernels know five slots beside the springs and the elements, and an effect fills one or
more of them through the layout's methods:

- a force that does not depend on the state, added to the loads
  (:meth:`KernelEffects.add_constant`: gravity, an unmodeled load);
- a drag ``-b v`` on every node (:meth:`~KernelEffects.add_drag`);
- extra stiffness along springs, ``x`` (:meth:`~KernelEffects.add_spring_stretch`: inclusions
  of springs), and a second central force that stiffens, ``q x³`` of
  :func:`neurofuzzy.kernels.stepper.spring_state` (:meth:`~KernelEffects.add_spring_cubic`:
  strain stiffening of springs);
- extra element constants (:meth:`~KernelEffects.add_element_constants`: inclusions of
  elements);
- the elements' strain stiffening ``κ`` of :mod:`neurofuzzy.kernels.laws`
  (:meth:`~KernelEffects.add_stiffening`).

A model carries only effects that compile themselves, and at most one node drag and one
element stiffening (:func:`neurofuzzy.model.model._ordered` refuses the rest).
"""

from __future__ import annotations

import numpy as np

from ..forces.springs import spring_constants
from ..forces.tetra_geometry import ElementConstants
from ..kernels.springs import CLOSING, CUBIC, STRETCH

__all__ = ["STRETCH", "CLOSING", "CUBIC", "KernelEffects", "element_constants",
           "spring_entries"]

#: the element constants an effect may add, per element
ELEMENT_KEYS = ("shear", "shear_rate", "lam", "lam_rate")


class KernelEffects:
    """The share of ``model``'s effects in the kernels' arrays.

    Parameters
    ----------
    model : Model
    columns : dict, optional
        The first parameter column of every learned effect, by its index in ``model.effects``
        (the learners'); the effects not in it are held.

    Attributes
    ----------
    constant : (n_nodes, 3) float
        The state-independent forces, added to the loads.
    directions : list of (slice, (n_nodes, 3, n) float)
        The learned constant forces' columns and their forces per unit parameter.
    drag, drag_column : float, int
        ``b`` of the node drag (0 without) and its column (-1: held).
    kappa, kappa_column : float, int
        The elements' strain stiffening ``κ`` (0 without) and its column.
    stretch, cubic : (n_springs,) float
        Extra spring stiffness, and ``q = κ / L0²`` of the springs' second force.
    learned_stretch, learned_cubic : (n_springs,) bool
        The springs whose stretch or cubic coefficient is learned.
    spring_derivatives : list of (springs, columns, basis, factor)
        Per learned spring effect: its springs, every spring's column, the basis of the
        derivative (:data:`STRETCH` ``x`` or :data:`CUBIC` ``x³``) and its factor.
    element : dict of (n_elements,) float
        The extra element constants (:data:`ELEMENT_KEYS`).
    element_derivatives : list of (elements, columns, d shear, d shear_rate, d λ, d λβ)
        Per learned element inclusion.
    """

    def __init__(self, model, columns: dict[int, int] | None = None):
        columns = columns or {}
        n_springs, n_elements = model.n_springs, model.mesh.n_tetrahedra
        self.model = model
        self.constant = np.zeros((model.n_nodes, 3))
        self.directions: list = []
        self.drag, self.drag_column = 0.0, -1
        self.kappa, self.kappa_column = 0.0, -1
        self.stretch, self.cubic = np.zeros(n_springs), np.zeros(n_springs)
        self.learned_stretch = np.zeros(n_springs, bool)
        self.learned_cubic = np.zeros(n_springs, bool)
        self.spring_derivatives: list = []
        self.element = {key: np.zeros(n_elements) for key in ELEMENT_KEYS}
        self.element_derivatives: list = []
        for i, effect in enumerate(model.effects):
            effect.compile(self, model, columns.get(i))

    @property
    def has_spring_effects(self) -> bool:
        return bool(np.any(self.stretch) or np.any(self.cubic) or self.spring_derivatives)

    # -- the slots, filled by the effects ----------------------------------------------------
    def add_constant(self, force: np.ndarray, column: int | None = None,
                     per_parameter: np.ndarray | None = None) -> None:
        """A state-independent ``force`` (n_nodes, 3); learned from ``column`` on, with its
        force per unit parameter ``per_parameter`` (n_nodes, n_params, 3)."""
        self.constant += force
        if column is not None:
            span = slice(column, column + per_parameter.shape[1])
            self.directions.append((span, per_parameter.transpose(0, 2, 1)))

    def add_drag(self, b: float, column: int | None = None) -> None:
        """A drag ``-b v`` on every node."""
        self.drag += float(b)
        self.drag_column = -1 if column is None else int(column)

    def add_stiffening(self, kappa: float, column: int | None = None) -> None:
        """The elements' strain stiffening ``κ`` (Pa)."""
        self.kappa += float(kappa)
        self.kappa_column = -1 if column is None else int(column)

    def add_spring_stretch(self, per_spring: np.ndarray, learned=None) -> None:
        """Extra stiffness ``per_spring`` (n_springs,) N/m; ``learned`` the ``(springs,
        columns)`` of its coefficients when they are fitted."""
        self.stretch += per_spring
        if learned is not None:
            springs, columns = learned
            self.learned_stretch[springs] = True
            self.spring_derivatives.append((springs, columns, STRETCH, np.ones(len(springs))))

    def add_spring_cubic(self, per_spring: np.ndarray, learned=None) -> None:
        """A second central force ``κ x³ / L0²`` with ``κ = per_spring`` (n_springs,) N/m;
        ``learned`` as in :meth:`add_spring_stretch`."""
        rest_length = spring_constants(self.model)[2]
        self.cubic += per_spring / rest_length**2
        if learned is not None:
            springs, columns = learned
            self.learned_cubic[springs] = True
            self.spring_derivatives.append((springs, columns, CUBIC,
                                            1.0 / rest_length[springs]**2))

    def add_element_constants(self, constants: ElementConstants, learned=None) -> None:
        """Extra element ``constants``; ``learned`` the ``(elements, column, unit)`` of a
        fitted coefficient, ``unit`` its constants per unit value."""
        for key in ELEMENT_KEYS:
            self.element[key] = self.element[key] + getattr(constants, key)
        if learned is not None:
            elements, column, unit = learned
            self.element_derivatives.append(
                (elements, np.full(len(elements), column),
                 *(np.asarray(getattr(unit, key))[elements] for key in ELEMENT_KEYS)))


def element_constants(model, effects: KernelEffects | None = None
                      ) -> tuple[ElementConstants, dict[str, np.ndarray]]:
    """The model's own element :class:`ElementConstants` and the constants ``shear``,
    ``shear_rate``, ``lam``, ``lam_rate`` (per element) with its effects' added (``effects``
    its :class:`KernelEffects`, made here when not given)."""
    own = model.elements.constants(model)
    added = (effects or KernelEffects(model)).element
    return own, {key: getattr(own, key) + added[key] for key in ELEMENT_KEYS}


def spring_entries(model, effects: KernelEffects | None = None, *, every_spring=False):
    """The springs as the kernels step them (:func:`neurofuzzy.kernels.stepper._springs`):
    the model's springs, then once more each spring that stiffens, with no stiffness or
    damping of its own and its ``q = κ / L0²`` (a second central force along the same spring,
    so that the springs that do not stiffen are stepped with ``q = 0`` compiled in).

    ``effects`` is the model's :class:`KernelEffects` (made here, every effect held, when not
    given); ``every_spring`` keeps springs with no force (their own constants are
    learned). Returns ``(spring, stiffness, damping, cubic, derivatives)``: per entry the
    model's spring index, the stiffness (the spring inclusions' added) and the damping;
    ``cubic`` the ``q`` of the last ``len(cubic)`` entries; ``derivatives`` the spring effects'
    parameter derivatives of the entries' magnitudes as ``(entry, column, basis, factor)``
    arrays (an inclusion's ``x`` with factor 1, a stiffening's ``x³`` with ``1 / L0²``).
    """
    own_stiffness, damping, _ = spring_constants(model)
    keep = every_spring | (own_stiffness != 0) | (damping != 0)
    effects = effects or KernelEffects(model)
    if not effects.has_spring_effects:                  # most models: quickly
        plain = np.flatnonzero(keep)
        return (plain, np.asarray(own_stiffness[plain], float),
                np.asarray(damping[plain], float), np.zeros(0),
                (np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0)))
    stiffness = own_stiffness + effects.stretch
    keep |= effects.learned_stretch | (stiffness != 0)  # an inclusion's springs, no own force
    stiffens = effects.learned_cubic | (effects.cubic != 0)
    plain, tail = np.flatnonzero(keep), np.flatnonzero(stiffens)
    entry = np.full((2, model.n_springs), -1, np.intp)     # model spring → plain, tail entry
    entry[0, plain] = np.arange(len(plain))
    entry[1, tail] = len(plain) + np.arange(len(tail))
    parts = [(entry[int(basis == CUBIC), springs], column, np.full(len(springs), basis),
              factor) for springs, column, basis, factor in effects.spring_derivatives]
    derivatives = tuple(np.concatenate([part[k] for part in parts]) if parts else
                        np.zeros(0, float if k == 3 else np.intp) for k in range(4))
    spring = np.concatenate([plain, tail])
    zeros = np.zeros(len(tail))
    return (spring, np.concatenate([stiffness[plain], zeros]),
            np.concatenate([damping[plain], zeros]), effects.cubic[tail], derivatives)
