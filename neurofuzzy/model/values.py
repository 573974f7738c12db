"""Checked per-entity arrays of a model (:func:`vector`, :func:`per_spring`), their one-line
description (:func:`describe`) and the spring tie groups (:func:`tie_index`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import numpy as np

from ..errors import InputError
from ..forces.base import vector
from ..mesh import Mesh

__all__ = ["Tie", "TIES", "tie_index", "PerSpring", "vector", "per_spring", "describe",
           "term_values"]

Tie = Literal["global", "groups", "none"]
TIES: tuple[str, ...] = ("global", "groups", "none")

PerSpring = float | Sequence[float] | np.ndarray | Mapping[str, float]


def tie_index(mesh: Mesh, tie: Tie) -> np.ndarray:
    """(n_springs,) int: the tie group of every spring for a tying mode.

    Parameters
    ----------
    mesh : Mesh
        Topology whose ``spring_group`` is used for ``tie="groups"``.
    tie : {"global", "groups", "none"}
        One shared group, the mesh's spring groups, or one group per spring.
    """
    if tie == "global":
        return np.zeros(mesh.n_springs, dtype=np.intp)
    if tie == "groups":
        _, index = np.unique(mesh.spring_group, return_inverse=True)
        return index.astype(np.intp)
    if tie == "none":
        return np.arange(mesh.n_springs, dtype=np.intp)
    raise InputError(f"got {tie!r}; expected one of {list(TIES)}", key="tie")


def describe(values: np.ndarray) -> str:
    """``"v"`` for equal values, else ``"median (median; min .. max)"``."""
    lo, hi = float(values.min()), float(values.max())
    if np.isclose(lo, hi, rtol=1e-9, atol=0):
        return f"{lo:.6g}"
    return f"{float(np.median(values)):.6g} (median; {lo:.4g} .. {hi:.4g})"


def per_spring(mesh: Mesh, value: PerSpring, key: str) -> np.ndarray:
    """(n_springs,) float from a number, an array or a mapping spring group → value."""
    if isinstance(value, Mapping):
        unknown = set(value) - set(mesh.group_names)
        if unknown:
            raise InputError(f"unknown spring group(s) {sorted(unknown)}; the mesh has "
                             f"{list(mesh.group_names)}", key=key)
        missing = [name for g, name in enumerate(mesh.group_names)
                   if name not in value and np.any(mesh.spring_group == g)]
        if missing:
            raise InputError(f"no value for spring group(s) {missing}", key=key)
        per_group = np.array([value.get(name, np.nan) for name in mesh.group_names], float)
        return per_group[mesh.spring_group]
    return vector(value, mesh.n_springs, key, "n_springs")


def term_values(model) -> dict[str, np.ndarray]:
    """Every term's own parameters by name: the springs' ``stiffness``, ``damping``, the
    elements' ``youngs_modulus``, ``poisson_ratio``, ``viscosity``, an effect's parameters
    under its name (``gravity`` …)."""
    out = {}
    for term in model.terms:
        values = term.parameter_values(model)
        out.update({term.name: values["params"]} if set(values) == {"params"} else values)
    return {name: np.asarray(value) for name, value in out.items()}
