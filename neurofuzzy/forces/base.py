"""The interface every force of a model implements: :class:`ForceTerm`.

A model's internal force is a sum of terms, ``F(p, v) = Σ_terms F_term(p, v; θ_term)``: its
springs (:class:`~neurofuzzy.forces.springs.Springs`) and every effect it carries
(:mod:`neurofuzzy.effects`). The stepper, the sensitivities and the adjoint, the paper's
learner, the equation-error start and the diagnosis see only this interface, so a new effect
or element is one new class plus its tests.

Conventions (shapes first, node-major tangents):

- states ``positions``, ``velocities`` : (n_nodes, 3) float;
- forces : (n_nodes, 3) float, the force the term exerts on every node;
- tangents ``dp``, ``dv`` and their images : (n_nodes, P, 3) float, P directions at once;
- ``parameter_jacobian`` : (n_nodes, n_params, 3) float, for terms with a few parameters
  (effects); terms with one parameter per spring or element give per-entity templates
  instead (:meth:`~neurofuzzy.forces.springs.Springs.parameter_templates`).
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from ..errors import InputError

__all__ = ["ForceTerm", "MemberTerm", "vector", "region_index"]


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

    @property
    def one_per_model(self) -> bool:
        """True for a term of which a model carries at most one (the kernels hold one node
        drag and one strain stiffening of the elements; two of them add up to one)."""
        return False

    def bound(self, model) -> ForceTerm:
        """This term checked against ``model`` (its mesh and regions), with defaults filled
        in: what :class:`~neurofuzzy.model.Model` keeps. Terms whose values do not depend on
        the model (the effects) return themselves."""
        return self

    def _bound_to(self, model) -> bool:
        """True when this term was checked for ``model``'s mesh and regions already (a model
        made from another, ``model.replace(...)``, keeps its other terms as they are)."""
        mesh, regions = getattr(self, "_checked_for", (None, None))
        return mesh is model.mesh and regions == model.region_names

    def _checked(self, model):
        """Mark this (new, checked) term as bound to ``model``'s mesh and regions; returns
        it."""
        object.__setattr__(self, "_checked_for", (model.mesh, model.region_names))
        return self

    def blocks(self, model, *, index: int = 0):
        """What a learner may change of this term: its parameter blocks
        (:class:`~neurofuzzy.forces.blocks.TermBlocks`); ``index`` numbers the model's
        effects (their blocks are ``effect:index``)."""
        raise NotImplementedError(f"{type(self).__name__} has no learnable parameters")

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


class MemberTerm(ForceTerm):
    """A term with values for every member of the mesh, each spring or each element, and a
    tie group per member (``tie``): :class:`~neurofuzzy.forces.Springs`,
    :class:`~neurofuzzy.forces.Tetrahedra`, frozen dataclasses."""

    @property
    def n_ties(self) -> int:
        """The number of tie groups."""
        return int(self.tie.max()) + 1 if len(self.tie) else 0

    def replace(self, **changes):
        """A copy with some fields changed (checked again when it joins a model)."""
        return dataclasses.replace(self, **changes)


def _columns(directions: dict) -> int:
    """P, the number of directions of a parameter-direction dictionary."""
    return next(iter(directions.values())).shape[1] if directions else 0


def vector(value, n: int, key: str, size_name: str) -> np.ndarray:
    """(n,) float from a number or an array; :class:`InputError` naming ``key`` otherwise."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError("expected numbers", key=key) from None
    if array.ndim == 0:
        array = np.full(n, float(array))
    if array.shape != (n,):
        raise InputError(f"got shape {array.shape}; expected ({size_name},) = ({n},)", key=key)
    if not np.all(np.isfinite(array)):
        raise InputError("contains NaN or infinite values", key=key)
    return array


def region_index(value, n: int, n_regions: int, key: str, size_name: str) -> np.ndarray:
    """(n,) int region indices in ``0..n_regions-1`` (default all 0); :class:`InputError`
    naming ``key`` otherwise."""
    index = np.zeros(n, np.intp) if value is None else np.asarray(value)
    if index.shape != (n,) or not np.issubdtype(index.dtype, np.integer) or (
            n and (index.min() < 0 or index.max() >= n_regions)):
        raise InputError(f"expected ({size_name},) = ({n},) integers in "
                         f"0..{n_regions - 1}, one region index each", key=key)
    return index.astype(np.intp)
