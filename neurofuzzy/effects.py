"""Physical effects a model may carry besides its springs, as extra force terms.

Each effect is one class: a name from the fixed vocabulary of DESIGN.md, a parameter vector the
learners can fit, the force it adds, and its derivatives for the gradient learner. Adding an
effect means adding one subclass here and registering it in :data:`EFFECTS`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from .errors import InputError, closest_name

__all__ = ["Effect", "EFFECTS", "effect_to_dict", "effect_from_dict"]


class Effect(ABC):
    """A force term ``F(p, v; θ)`` added to the spring forces of every node.

    Subclasses set ``name`` and implement :meth:`force`, :meth:`parameter_jacobian` and
    :meth:`state_jvp` / :meth:`state_vjp`; parameters are a flat float vector ``params``.
    """

    name: ClassVar[str]

    def __init__(self, params, **options):
        self.params = np.array(params, dtype=float).ravel()
        self.options = options

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}[{i}]" for i in range(len(self.params)))

    def with_params(self, params) -> Effect:
        """A copy with new parameter values (same options)."""
        return type(self)(params, **self.options)

    @abstractmethod
    def force(self, model, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
        """(n_nodes, 3) force this effect adds at state ``(positions, velocities)``."""

    @abstractmethod
    def parameter_jacobian(self, model, positions: np.ndarray,
                           velocities: np.ndarray) -> np.ndarray:
        """(n_params, n_nodes, 3): derivative of :meth:`force` with respect to ``params``."""

    def state_jvp(self, model, positions, velocities, dp, dv) -> np.ndarray:
        """(n_nodes, 3): ``∂F/∂p · dp + ∂F/∂v · dv`` (zero for state-independent forces)."""
        return np.zeros_like(dp)

    def state_vjp(self, model, positions, velocities, cotangent) -> tuple[np.ndarray, np.ndarray]:
        """``(∂F/∂p)ᵀ λ, (∂F/∂v)ᵀ λ`` for a cotangent ``λ`` of shape (n_nodes, 3)."""
        return np.zeros_like(cotangent), np.zeros_like(cotangent)

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.parameter_names, self.params))
        return f"{self.name}({values})"


#: Registry of effect classes by name (filled below).
EFFECTS: dict[str, type[Effect]] = {}


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
    return EFFECTS[name](data["params"], **options)
