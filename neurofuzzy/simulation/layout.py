"""A model in the compiled kernels' layout: its springs and its elements as the flat arrays
the kernels read, defined once for the stepper
(:func:`neurofuzzy.simulation.steppers.NumbaStepper`, which adds its scratch space and the
relaxation's decay per step) and for the sensitivities and the adjoint
(:class:`neurofuzzy.learn._compiled.CompiledModel`, which adds the parameter derivatives).
The effects' share comes from :class:`~neurofuzzy.effects.compiled.KernelEffects`."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..effects.compiled import KernelEffects, element_constants, spring_entries
from ..forces.springs import spring_constants

__all__ = ["ElementArrays", "spring_arrays", "element_arrays"]


class ElementArrays(NamedTuple):
    """The elements as every kernel reads them (a tuple: the kernels take it whole, or
    unpacked into their arguments, and read its fields by name): the nodes of each
    tetrahedron, its inverse rest edges and volume, its law and that law's own constant
    (:mod:`neurofuzzy.kernels.laws`), its constants (shear ``2μ``, its rate ``2μβ``, ``λ``,
    ``λβ``), whether the volumetric stress is taken from node averages (``nodal``) and, for
    that form, the node volumes and the node averages ``Λ``, ``H`` of ``λ`` and ``λβ``."""

    tets: np.ndarray | None
    inverse_rest: np.ndarray
    volume: np.ndarray
    law: np.ndarray
    law_constant: np.ndarray
    shear: np.ndarray
    shear_rate: np.ndarray
    lam: np.ndarray
    lam_rate: np.ndarray
    nodal: bool
    node_volume: np.ndarray
    node_lam: np.ndarray
    node_lam_rate: np.ndarray


def spring_arrays(model, effects: KernelEffects, dtype=np.float64, *,
                  every_spring: bool = False) -> tuple:
    """``(a, b, stiffness, damping, rest, q, derivatives)``: the springs as the kernels step
    them (:func:`~neurofuzzy.effects.compiled.spring_entries`: the springs with a force, then
    once more those that stiffen), their end nodes, constants and rest lengths, ``q`` of the
    last ``len(q)`` entries, and the effects' parameter derivatives of the entries
    (``every_spring``: every spring an entry, for learned spring constants)."""
    spring, stiffness, damping, cubic, derivatives = spring_entries(
        model, effects, every_spring=every_spring)
    return (np.ascontiguousarray(model.mesh.springs[spring, 0]),
            np.ascontiguousarray(model.mesh.springs[spring, 1]),
            np.asarray(stiffness, dtype), np.asarray(damping, dtype),
            np.array(spring_constants(model)[2][spring], dtype), np.asarray(cubic, dtype),
            derivatives)


def element_arrays(model, effects: KernelEffects, dtype=np.float64) -> ElementArrays:
    """The model's elements (:class:`ElementArrays`): the constants of
    :class:`~neurofuzzy.forces.ElementConstants` with the effects' added, and for the nodal
    volumetric form the node volumes and node averages of λ and λβ (zeros otherwise). A model
    without elements gives empty arrays and ``tets`` None, which the kernels compile without
    their element code (a spring model waits a third of the time for its first
    compilation)."""
    if model.elements is None:
        empty = np.zeros(0, dtype)
        return ElementArrays(None, np.zeros((0, 3, 3), dtype), empty, np.zeros(0, np.intp),
                             empty, empty, empty, empty, empty, False, empty, empty, empty)
    materials, total = element_constants(model, effects)
    geometry = materials.geometry
    nodal = materials.nodal
    node_values = ((geometry.node_volume, geometry.average @ total["lam"],
                    geometry.average @ total["lam_rate"]) if nodal
                   else (np.zeros(model.n_nodes),) * 3)
    return ElementArrays(
        np.array(geometry.nodes, np.intp, order="C"),
        np.ascontiguousarray(geometry.inverse_rest, dtype), geometry.volume.astype(dtype),
        # copies of the model's (read-only) arrays: a read-only argument is another type to
        # numba, and the learners pass writable ones (one compiled driver for both)
        np.array(materials.law, np.intp, order="C"),
        np.array(model.elements.stiffening, dtype, order="C"),
        *(np.ascontiguousarray(total[key], dtype)
          for key in ("shear", "shear_rate", "lam", "lam_rate")),
        nodal, *(np.ascontiguousarray(values, dtype) for values in node_values))
