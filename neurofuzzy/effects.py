"""Physical effects a model may carry besides its springs, as extra force terms.

Each effect is one class with a name from the fixed vocabulary of DESIGN.md, a parameter vector
the learners fit, the force it adds, its derivatives (for the gradient learner) and the
physical units of its parameters (for the paper's learner). Adding an effect means adding one
subclass here and registering it with :func:`register`; the simulator, both learners, the model
files and the diagnosis pick it up from the registry (the diagnosis asks every registered class
for candidates through :meth:`Effect.propose`).

=====================  ====================================================  ===============
name                   force on node i                                        parameters
=====================  ====================================================  ===============
gravity                ``m_i g``                                              ``g`` (3,)
node_drag              ``-b v_i`` (viscous drag of the surrounding medium)    ``b``
stiff_inclusion        springs ``R`` get ``k (l - L0) u`` extra, k > 0        ``k`` per group
soft_inclusion         the same with k < 0 (k > -s)                           ``k`` per group
nonlinear_stiffening   every spring gets ``κ (l - L0)³ / L0² u`` extra        ``κ`` per group
unmodeled_load         a constant force ``f`` at one node                     ``f`` (3,)
=====================  ====================================================  ===============
"""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from .errors import InputError, closest_name
from .forces import SPRINGS, ForceTerm, central_jvp, central_vjp, incidence

__all__ = ["Effect", "SpringEffect", "Gravity", "NodeDrag", "StiffInclusion", "SoftInclusion",
           "NonlinearStiffening", "UnmodeledLoad", "EFFECTS", "register", "effect_to_dict",
           "effect_from_dict"]

#: Registry of effect classes by name.
EFFECTS: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: make an effect known by its ``name``."""
    EFFECTS[cls.name] = cls
    return cls


class Effect(ForceTerm):
    """A force term ``F(p, v; θ)`` with a few learned parameters, added to the spring forces.

    Subclasses set ``name``, ``unit`` (the exponents of length, time and mass of the
    parameters' unit) and ``_labels`` (or a ``labels`` property), and implement :meth:`force`,
    :meth:`parameter_jacobian` and :meth:`propose`; forces that depend on the state also
    implement :meth:`state_jvp` and :meth:`state_vjp` (node-major, see
    :mod:`neurofuzzy.forces.base`).

    Parameters
    ----------
    params : (n_params,) float
        Parameter values (see the table in the module docstring).
    **options
        Fixed, non-learned settings (which springs, which node).
    """

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

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{label}" for label in self.labels)

    def parameter_units(self, length: float, time: float, mass: float) -> np.ndarray:
        """(n_params,) the unit of every parameter for given units of length, time, mass."""
        a, b, c = self.unit
        return np.full(len(self.params), length**a * time**b * mass**c)

    def with_params(self, params) -> Effect:
        """A copy with new parameter values (same options)."""
        return type(self)(params, **self.options)

    @property
    def springs(self) -> np.ndarray:
        """Springs the effect acts on locally (empty for global effects)."""
        return np.asarray(self.options.get("springs", []), dtype=int)

    @property
    def nodes(self) -> np.ndarray:
        """Nodes the effect acts on locally (empty for global effects)."""
        node = self.options.get("node")
        return np.zeros(0, dtype=int) if node is None else np.array([int(node)])

    @abstractmethod
    def parameter_jacobian(self, model, positions: np.ndarray,
                           velocities: np.ndarray) -> np.ndarray:
        """(n_nodes, n_params, 3): derivative of :meth:`force` with respect to ``params``."""

    @classmethod
    def propose(cls, model, evidence) -> list:
        """Instances of this effect worth scoring against a diagnosis' residuals (zero
        parameters; the diagnosis estimates them).

        ``evidence`` offers ``present`` (names of the effects the model has),
        ``mean_force`` ((n_nodes, 3) mean residual force per node), ``taken_nodes`` /
        ``taken_springs`` (already used by located effects) and ``inclusion_region(taken)``
        (the compact region of springs whose stiffness change best explains the residual).
        Default: one global instance when the model does not carry the effect yet.
        """
        return [] if cls.name in evidence.present else [cls(np.zeros(len(cls._labels)))]

    def equation(self) -> str:
        """The force term in words and numbers, e.g. ``F_i += m_i (0, 0, -9.81)``."""
        return f"{self.name}: {self._values()}"

    def _values(self) -> str:
        return ", ".join(f"{n} = {v:.4g}" for n, v in zip(self.labels, self.params))

    def __repr__(self) -> str:
        return self.equation()


@register
class Gravity(Effect):
    """Uniform acceleration ``g`` (direction and magnitude learned): ``F_i = m_i g``."""

    name = "gravity"
    unit = (1, -2, 0)
    _labels = ("gx", "gy", "gz")
    per_unit_mass = True

    def force(self, model, positions, velocities):
        return model.node_mass[:, None] * self.params[None, :]

    def parameter_jacobian(self, model, positions, velocities):
        return model.node_mass[:, None, None] * np.eye(3)[None]

    def equation(self):
        g = self.params
        return (f"gravity: F_i += m_i g, g = ({g[0]:.4g}, {g[1]:.4g}, {g[2]:.4g}), "
                f"|g| = {np.linalg.norm(g):.4g}")


@register
class NodeDrag(Effect):
    """Viscous drag of the surrounding medium on every node: ``F_i = -b v_i``."""

    name = "node_drag"
    unit = (0, -1, 1)
    _labels = ("b",)

    def force(self, model, positions, velocities):
        return -self.params[0] * velocities

    def parameter_jacobian(self, model, positions, velocities):
        return -velocities[:, None, :]

    def state_jvp(self, model, positions, velocities, dp, dv):
        return -self.params[0] * dv

    def state_vjp(self, model, positions, velocities, cotangent):
        return np.zeros_like(cotangent), -self.params[0] * cotangent

    def equation(self):
        return f"node_drag: F_i += -b v_i, b = {self.params[0]:.4g}"


class SpringEffect(Effect):
    """A central, position-dependent force along a subset of springs (all when no ``springs``),
    with one coefficient per spring group (stiffness units, N/m), so that it does not depend
    on the springs' own stiffness while the learners change it.

    Options: ``groups`` (the spring-group indices that have a coefficient, in parameter order),
    ``group_names`` (for labels) and optionally ``springs``. Subclasses implement
    :meth:`shape`, the magnitude per unit coefficient and its derivative by length.
    """

    unit = (0, -2, 1)

    def __init__(self, params, *, groups, group_names=None, springs=None, **options):
        if springs is not None:
            options["springs"] = [int(j) for j in np.ravel(springs)]
        options["groups"] = [int(g) for g in np.ravel(groups)]
        if group_names is not None:
            options["group_names"] = [str(n) for n in group_names]
        super().__init__(params, **options)

    @classmethod
    def for_model(cls, model, params=None, springs=None):
        """The effect on ``springs`` (default all) of ``model``, one coefficient per group."""
        selection = np.arange(model.n_springs) if springs is None else np.asarray(springs, int)
        groups = np.unique(model.mesh.spring_group[selection])
        names = [model.mesh.group_names[g] for g in groups]
        params = np.zeros(len(groups)) if params is None else np.broadcast_to(
            np.asarray(params, float), (len(groups),))
        return cls(params, groups=groups, group_names=names, springs=springs)

    @property
    def labels(self):
        names = self.options.get("group_names") or [f"group{g}" for g in self.options["groups"]]
        return tuple(f"{self.coefficient}[{n}]" for n in names)

    coefficient: ClassVar[str] = "k"

    def _selection(self, model):
        springs = self.options.get("springs")
        return np.arange(model.n_springs) if springs is None else np.asarray(springs, int)

    @abstractmethod
    def shape(self, model, state, selection):
        """``(g, dg_dl)`` per selected spring: magnitude and its length derivative per unit
        coefficient."""

    def magnitude(self, model, state, selection):
        """``(m, dm_dl, dm_dparams)`` of shapes (n,), (n,), (n_params, n)."""
        index = np.searchsorted(self.options["groups"], model.mesh.spring_group[selection])
        index = np.minimum(index, len(self.params) - 1)
        known = np.asarray(self.options["groups"])[index] == model.mesh.spring_group[selection]
        coefficient = np.where(known, self.params[index], 0.0)
        g, dg = self.shape(model, state, selection)
        dm = np.zeros((len(self.params), len(selection)))
        dm[index[known], np.flatnonzero(known)] = g[known]
        return coefficient * g, coefficient * dg, dm

    def _parts(self, model, positions, velocities):
        selection = self._selection(model)
        state = SPRINGS.state(model, positions, velocities).select(selection)
        return selection, state, self.magnitude(model, state, selection)

    def _scatter(self, model, selection, per_spring):
        """(n_nodes, ...) net of a per-selected-spring array (node a +, node b -)."""
        full = np.zeros((model.n_springs, *per_spring.shape[1:]))
        full[selection] = per_spring
        return incidence(model.mesh).accumulate(full)

    def force(self, model, positions, velocities):
        selection, state, (m, _, _) = self._parts(model, positions, velocities)
        return self._scatter(model, selection, m[:, None] * state.direction)

    def parameter_jacobian(self, model, positions, velocities):
        selection, state, (_, _, dm) = self._parts(model, positions, velocities)
        return self._scatter(model, selection,
                             dm.T[:, :, None] * state.direction[:, None, :])

    def state_jvp(self, model, positions, velocities, dp, dv):
        selection, state, (m, dm_dl, _) = self._parts(model, positions, velocities)
        dd = incidence(model.mesh).difference(dp)[selection]            # (n, P, 3)
        return self._scatter(model, selection, central_jvp(state, m, dm_dl, None, dd, None))

    def state_vjp(self, model, positions, velocities, cotangent):
        selection, state, (m, dm_dl, _) = self._parts(model, positions, velocities)
        lam_f = -incidence(model.mesh).difference(cotangent)[selection]
        lam_d, _ = central_vjp(state, m, dm_dl, None, lam_f)
        return -self._scatter(model, selection, lam_d), np.zeros_like(cotangent)

    def relative(self, model) -> dict[str, float]:
        """Each coefficient relative to the mean stiffness of its group's selected springs."""
        selection = self._selection(model)
        out = {}
        for label, group, value in zip(self.labels, self.options["groups"], self.params):
            chosen = selection[model.mesh.spring_group[selection] == group]
            out[label] = float(value / np.mean(model.spring_stiffness[chosen]))
        return out


class _Inclusion(SpringEffect):
    """A compact region of springs with extra stiffness ``k`` (per spring group): the region's
    springs pull with ``(s_j + k) (l - L0)``."""

    coefficient = "extra_stiffness"

    def __init__(self, params, *, springs, **options):
        super().__init__(params, springs=springs, **options)

    def shape(self, model, state, selection):
        return state.stretch, np.ones_like(state.stretch)

    def equation(self):
        return (f"{self.name}: {len(self.springs)} springs pull harder by k (l - L0); "
                f"{self._values()}")


@register
class StiffInclusion(_Inclusion):
    """Springs of a compact region stiffer than the rest (k > 0)."""

    name = "stiff_inclusion"

    @classmethod
    def propose(cls, model, evidence):
        """The compact region of springs that best explains the residual (the diagnosis
        names it soft_inclusion when the fitted extra stiffness comes out negative)."""
        region = evidence.inclusion_region(evidence.taken_springs)
        return [cls.for_model(model, [0.0], springs=region)] if region else []


@register
class SoftInclusion(_Inclusion):
    """Springs of a compact region softer than the rest (k < 0)."""

    name = "soft_inclusion"

    @classmethod
    def propose(cls, model, evidence):
        """None of its own: :class:`StiffInclusion`'s region, refitted, turns soft when its
        extra stiffness is negative."""
        return []


@register
class NonlinearStiffening(SpringEffect):
    """Spring force grows faster than linear: ``κ (l - L0)³ / L0²`` extra (κ per group, N/m);
    relative to the spring's stiffness, ``β = κ / s``: ``f = s (l - L0) [1 + β ((l - L0)/L0)²]``."""

    name = "nonlinear_stiffening"
    coefficient = "kappa"

    def shape(self, model, state, selection):
        rest2 = model.spring_rest_length[selection] ** 2
        return state.stretch**3 / rest2, 3 * state.stretch**2 / rest2

    @classmethod
    def propose(cls, model, evidence):
        return [] if cls.name in evidence.present else [cls.for_model(model, [0.0])]

    def equation(self):
        return f"nonlinear_stiffening: f += κ (l - L0)³ / L0²; {self._values()}"


@register
class UnmodeledLoad(Effect):
    """A constant force ``f`` at one node that the data did not declare."""

    name = "unmodeled_load"
    unit = (1, -2, 1)
    _labels = ("fx", "fy", "fz")

    def __init__(self, params, *, node, **options):
        super().__init__(params, node=int(node), **options)

    def force(self, model, positions, velocities):
        force = np.zeros((model.n_nodes, 3))
        force[self.options["node"]] = self.params
        return force

    def parameter_jacobian(self, model, positions, velocities):
        jacobian = np.zeros((model.n_nodes, 3, 3))
        jacobian[self.options["node"]] = np.eye(3)
        return jacobian

    @classmethod
    def propose(cls, model, evidence):
        """A load at each of the three free nodes with the largest mean residual force."""
        ranked = np.argsort(-np.linalg.norm(evidence.mean_force, axis=1))[:3]
        return [cls(np.zeros(3), node=int(node)) for node in ranked
                if int(node) not in evidence.taken_nodes and model.mesh.free[node]]

    def equation(self):
        f = self.params
        return (f"unmodeled_load: F_{self.options['node']} += ({f[0]:.4g}, {f[1]:.4g}, "
                f"{f[2]:.4g})")


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
    options = {key: value for key, value in data.items() if key not in ("name", "params")}
    try:
        return EFFECTS[name](data["params"], **options)
    except TypeError as error:
        raise InputError(f"bad options for {name}: {error}", source=source,
                         key="effects") from None
