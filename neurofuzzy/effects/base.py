"""The catalogue of effects: :class:`Entry` (a named change of a model with a few parameters,
what the diagnosis proposes), its two kinds, :class:`Effect` (a force term with a few learned
parameters) and :class:`MaterialSwitch` (a change of the elements' material: a law, a Prony
term; never a force a model carries), the registry of both by name, and the effects'
model-file form."""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from ..errors import InputError, closest_name
from ..forces import ForceTerm

__all__ = ["Entry", "Effect", "MaterialSwitch", "EFFECTS", "register", "effect_to_dict",
           "effect_from_dict", "term_kinds", "per_unit_mass_force"]

#: Registry of the catalogue's classes by name (effects and switches of the material).
EFFECTS: dict[str, type[Entry]] = {}


def register(cls: type[Entry]) -> type[Entry]:
    """Class decorator: make a catalogue entry known by its ``name``."""
    EFFECTS[cls.name] = cls
    return cls


class Entry:
    """An entry of the catalogue: a name from the vocabulary of DESIGN.md, a few parameters,
    fixed options, and the instances worth proposing to a diagnosis (:meth:`propose`).

    Subclasses set ``name``, ``unit`` (the exponents of length, time and mass of the
    parameters' unit) and ``_labels`` (or a ``labels`` property).

    Parameters
    ----------
    params : (n_params,) float
        Parameter values (see the table in :mod:`neurofuzzy.effects`).
    **options
        Fixed, non-learned settings (which springs, which node).
    """

    name: ClassVar[str]
    unit: ClassVar[tuple[int, int, int]] = (0, 0, 0)

    def __init__(self, params, **options):
        self.params = np.array(params, dtype=float).ravel()
        self.options = options
        if self.params.shape != (len(self.labels),):
            raise InputError(f"{self.name} takes {len(self.labels)} parameter(s) "
                             f"({', '.join(self.labels)}), got {self.params.size}",
                             key="params")

    @property
    def labels(self) -> tuple[str, ...]:
        """Short names of the parameters."""
        return self._labels

    _labels: ClassVar[tuple[str, ...]] = ()
    #: True for an entry that the diagnosis applies by switching the elements' material
    #: (``switch(model, duration, share=None) -> model``: a law, a Prony term, with ``share``
    #: the linearised fit's multiple of :meth:`probe_switch` where the switch can be partial)
    #: instead of adding it as a force term
    switches_material: ClassVar[bool] = False
    #: True for a switch that can go part of the way (:meth:`probe_switch` is a small one
    #: and ``switch`` takes its linearised ``share``): the diagnosis then starts its refit
    #: from the linearised step of the model's own parameters too
    switches_partly: ClassVar[bool] = False

    def switched_values(self, model) -> dict[str, float]:
        """For an entry that switches the material, what the switched and refitted ``model``
        carries for it, by name (the diagnosis' finding reports it)."""
        return {label: 1.0 for label in self.labels}

    def probe_switch(self, model, duration: float):
        """For an entry that switches the material, the switched model whose change of the
        residual is the diagnosis's evidence for it (a secant): the switch itself unless the
        entry can switch a little of the way, which keeps the secant in the linear range."""
        return self.switch(model, duration)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{label}" for label in self.labels)

    def parameter_units(self, length: float, time: float, mass: float) -> np.ndarray:
        """(n_params,) the unit of every parameter for given units of length, time, mass."""
        a, b, c = self.unit
        return np.full(len(self.params), length**a * time**b * mass**c)

    def with_params(self, params) -> Entry:
        """A copy with new parameter values (same options)."""
        return type(self)(params, **self.options)

    @property
    def springs(self) -> np.ndarray:
        """Springs the entry acts on locally (empty for global ones)."""
        return np.asarray(self.options.get("springs", []), dtype=int)

    @property
    def elements(self) -> np.ndarray:
        """Tetrahedral elements the entry acts on locally (empty for the others)."""
        return np.asarray(self.options.get("elements", []), dtype=int)

    @property
    def nodes(self) -> np.ndarray:
        """Nodes the entry acts on locally (empty for global ones)."""
        node = self.options.get("node")
        return np.zeros(0, dtype=int) if node is None else np.array([int(node)])

    @classmethod
    def propose(cls, model, evidence) -> list:
        """Instances of this entry worth scoring against a diagnosis' residuals (zero
        parameters; the diagnosis estimates them).

        ``evidence`` offers ``present`` (names of the effects the model has),
        ``mean_force`` ((n_nodes, 3) mean residual force per node), ``taken_nodes`` /
        ``taken_springs`` (already used by located effects) and ``inclusion_region(taken)``
        (the compact region of springs whose stiffness change best explains the residual).
        Default: one global instance when the model does not carry the effect yet.
        """
        return [] if cls.name in evidence.present else [cls(np.zeros(len(cls._labels)))]

    def equation(self) -> str:
        """The entry in words and numbers, e.g. ``F_i += m_i (0, 0, -9.81)``."""
        return f"{self.name}: {self._values()}"

    def _values(self) -> str:
        return ", ".join(f"{n} = {v:.4g}" for n, v in zip(self.labels, self.params))

    def __repr__(self) -> str:
        return self.equation()


class MaterialSwitch(Entry):
    """A change of the elements' material that the diagnosis proposes, scores by a compiled
    run of the switched model (:meth:`probe_switch`) and, when it wins, refits
    (:meth:`switch`): a law, a Prony term. Not a force: a model never carries one."""

    switches_material = True
    _labels = ("share",)
    #: what a user does instead of adding the entry to a model (the model files' message)
    instead: ClassVar[str] = ""

    @classmethod
    def switch(cls, model, duration: float, share: float | None = None):
        """``model`` with its elements' material switched (``duration`` of the recording,
        s; ``share`` of :meth:`probe_switch` the linearised fit asks for, where the switch
        can go part of the way)."""
        raise NotImplementedError(f"{cls.__name__} does not say how it switches a model")


class Effect(Entry, ForceTerm):
    """A force term ``F(p, v; θ)`` with a few learned parameters, added to the spring forces.

    Subclasses implement :meth:`force`, :meth:`parameter_jacobian` and :meth:`propose`;
    forces that depend on the state also implement :meth:`state_jvp` and :meth:`state_vjp`
    (node-major, see :mod:`neurofuzzy.forces.base`).
    """

    @abstractmethod
    def compile(self, layout, model, column: int | None) -> None:
        """Write this effect into the compiled kernels' arrays: ``layout`` a
        :class:`~neurofuzzy.effects.compiled.KernelEffects`, whose slots (a constant force,
        the node drag, spring stretch or cubic terms, element constants, the elements' κ)
        it fills; ``column`` its first parameter column when the learners fit it (None:
        held). The kernels compute every effect through this alone."""

    @abstractmethod
    def parameter_jacobian(self, model, positions: np.ndarray,
                           velocities: np.ndarray) -> np.ndarray:
        """(n_nodes, n_params, 3): derivative of :meth:`force` with respect to ``params``."""

    # -- the uniform parameter interface of force terms ----------------------------------------
    def parameter_values(self, model) -> dict[str, np.ndarray]:
        """``{"params": params}``: an effect owns its few parameters."""
        return {"params": self.params}

    def with_parameter_values(self, model, values):
        """``(model, effect)`` with new parameters (the model's copy of the effect replaced
        when it carries this one)."""
        effect = self.with_params(values["params"])
        effects = tuple(effect if e is self else e for e in model.effects)
        return (model.replace(effects=effects) if effects != model.effects else model), effect

    def blocks(self, model, *, index: int = 0):
        """Its raw parameters, the block ``effect:index``
        (:class:`~neurofuzzy.forces.blocks.EffectBlocks`)."""
        from ..forces.blocks import EffectBlocks

        return EffectBlocks(self, index)

    def parameter_jvp(self, model, positions, velocities, directions) -> np.ndarray:
        """(n_nodes, P, 3) from :meth:`parameter_jacobian` and ``directions["params"]``
        (n_params, P)."""
        return np.einsum("ipk,pq->iqk", self.parameter_jacobian(model, positions, velocities),
                         np.asarray(directions["params"]))

    def parameter_vjp(self, model, positions, velocities, cotangent):
        return {"params": np.einsum("ipk,ik->p",
                                    self.parameter_jacobian(model, positions, velocities),
                                    cotangent)}

    @classmethod
    def examples(cls, model) -> list:
        """One instance with every parameter 0.5 (override where that is not a sensible
        effect on ``model``)."""
        return [(model, cls(np.full(len(cls._labels), 0.5)))]


def effect_to_dict(effect: Effect) -> dict:
    """Plain-Python description of an effect (for model files)."""
    options = {key: (value.tolist() if isinstance(value, np.ndarray) else value)
               for key, value in effect.options.items()}
    return {"name": effect.name, "params": effect.params.tolist(), **options}


def effect_from_dict(data: dict, source: str = "<model>") -> Effect:
    """Inverse of :func:`effect_to_dict`."""
    if not isinstance(data, dict) or "name" not in data or "params" not in data:
        raise InputError("each effect needs 'name' and 'params'", source=source, key="effects")
    name = data["name"]
    if name not in EFFECTS:
        hint = closest_name(str(name), EFFECTS)
        raise InputError(f"unknown effect {name!r}" + (f"; did you mean {hint!r}?" if hint
                                                        else f"; known: {sorted(EFFECTS)}"),
                         source=source, key="effects")
    if not issubclass(EFFECTS[name], Effect):
        raise InputError(f"{name} is a change of the elements' material, not a force a model "
                         f"carries: {EFFECTS[name].instead}", source=source, key="effects")
    options = {key: value for key, value in data.items() if key not in ("name", "params")}
    try:
        return EFFECTS[name](data["params"], **options)
    except TypeError as error:
        raise InputError(f"bad options for {name}: {error}", source=source,
                         key="effects") from None


def term_kinds() -> dict[str, type[ForceTerm]]:
    """Every kind of force term a model can carry, by name: the springs, the tetrahedral
    elements and every registered effect (:func:`register`; not the switches of the
    material). The registry test (``tests/test_terms_registry.py``) checks each on its
    :meth:`ForceTerm.examples`."""
    from ..forces import Springs, Tetrahedra

    return {Springs.name: Springs, Tetrahedra.name: Tetrahedra,
            **{name: kind for name, kind in EFFECTS.items() if issubclass(kind, Effect)}}


def per_unit_mass_force(model, positions, velocities) -> np.ndarray:
    """(n_nodes, 3): the forces of ``model``'s effects that are proportional to node mass
    (gravity). ``W F`` does not see them when the masses change, so a mass's derivative
    leaves them out."""
    force = np.zeros((model.n_nodes, 3))
    for effect in model.effects:
        if effect.per_unit_mass:
            force += effect.force(model, positions, velocities)
    return force
