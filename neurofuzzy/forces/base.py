"""The interface every force of a model implements: :class:`ForceTerm`.

A model's internal force is a sum of terms, ``F(p, v) = Σ_terms F_term(p, v; θ_term)``: its
springs (:class:`~neurofuzzy.forces.springs.SpringForce`) and every effect it carries
(:mod:`neurofuzzy.effects`). The stepper, the sensitivities and the adjoint, the paper's
learner, the equation-error start and the diagnosis see only this interface, so a new effect
or element is one new class plus its tests.

Conventions (shapes first, node-major tangents):

- states ``positions``, ``velocities`` : (n_nodes, 3) float;
- forces : (n_nodes, 3) float, the force the term exerts on every node;
- tangents ``dp``, ``dv`` and their images : (n_nodes, P, 3) float, P directions at once;
- ``parameter_jacobian`` : (n_nodes, n_params, 3) float, for terms with a few parameters
  (effects); terms with one parameter per spring or element give per-entity templates
  instead (:meth:`~neurofuzzy.forces.springs.SpringForce.parameter_templates`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

__all__ = ["ForceTerm"]


class ForceTerm(ABC):
    """A force ``F(p, v; θ)`` on the nodes of a model, with its derivatives.

    Attributes
    ----------
    name : str
        Printable name of the term (the effect vocabulary of DESIGN.md for effects).
    unit : (int, int, int)
        Exponents of length, time and mass in the unit of the term's parameters.
    per_unit_mass : bool
        True when the force is proportional to the node mass (gravity), so ``F/m`` is not.
    """

    name: ClassVar[str]
    unit: ClassVar[tuple[int, int, int]] = (0, 0, 0)
    per_unit_mass: ClassVar[bool] = False

    @abstractmethod
    def force(self, model, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
        """(n_nodes, 3) force of this term at the state ``(positions, velocities)``."""

    def state_jvp(self, model, positions, velocities, dp, dv) -> np.ndarray:
        """(n_nodes, P, 3): ``∂F/∂p · dp + ∂F/∂v · dv`` for tangents of shape (n_nodes, P, 3)."""
        return np.zeros_like(dp)

    def state_vjp(self, model, positions, velocities, cotangent):
        """``((∂F/∂p)ᵀ λ, (∂F/∂v)ᵀ λ)``, each (n_nodes, 3), for a cotangent ``λ`` (n_nodes, 3)."""
        return np.zeros_like(cotangent), np.zeros_like(cotangent)

    # -- the term's own parameters ---------------------------------------------------------
    def parameter_values(self, model) -> dict[str, np.ndarray]:
        """The term's own parameters in ``model``, by name (each a 1-D array: per spring,
        per element or the effect's few)."""
        return {}

    def with_parameter_values(self, model, values: dict):
        """``(model, term)`` with the term's parameters set to ``values`` (the names of
        :meth:`parameter_values`)."""
        return model, self

    def parameter_jvp(self, model, positions, velocities, directions: dict) -> np.ndarray:
        """(n_nodes, P, 3): the force's change along P directions of the term's parameters
        (``directions[name]`` of shape (len(values[name]), P), dense or sparse)."""
        return np.zeros((model.n_nodes, _columns(directions), 3))

    def parameter_vjp(self, model, positions, velocities, cotangent) -> dict[str, np.ndarray]:
        """``λ · ∂F/∂θ`` for a cotangent ``λ`` (n_nodes, 3), by parameter name (the adjoint of
        :meth:`parameter_jvp`)."""
        return {}

    @classmethod
    def examples(cls, model) -> list:
        """``[(model, term), …]``: instances of this kind of term on ``model`` (a small spring
        network or element model) with non-zero parameters, or ``[]`` when it does not apply
        there; the registry test checks every kind of term on them
        (``tests/test_terms_registry.py``)."""
        return []

    def rest_matrices(self, model):
        """``(K, C)``: the (3N, 3N) sparse stiffness and damping matrices at rest, or None for
        a term that adds neither (used for the stability bound of the time step)."""
        return None


def _columns(directions: dict) -> int:
    """P, the number of directions of a parameter-direction dictionary."""
    return next(iter(directions.values())).shape[1] if directions else 0
