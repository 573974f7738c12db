"""Material values and words per region of a model (:func:`materials`): the physics of the
values is :mod:`neurofuzzy.constants`, the words the rule base's (used through its methods)."""

from __future__ import annotations

import numpy as np

from ..constants import (SPRING_POISSON_RATIO, element_values, spring_geometry,
                         spring_material_values)
from ..model import SpringMassModel

__all__ = ["materials", "material_values"]

def materials(model: SpringMassModel, rules=None, tissue: str | None = None) -> dict:
    """The material values every region of ``model`` stands for, with words.

    Returns ``{region: {"youngs_modulus": Pa, "poisson_ratio": ..., "viscosity": Pa·s,
    "density": kg/m³, "tissue": str or None, "labels": {quantity: word}}}`` (the form of
    ``fit --json``'s ``"materials"``). For spring models, E, η and ρ are what the spring
    constants, viscosities and masses correspond to (:mod:`neurofuzzy.constants.springs`) and
    ν is the 1/4 the springs are locked to; for element models they are the elements' own
    values (medians over the region). ``labels`` (with ``rules``) are the rule base's words
    for each quantity.
    """
    if model.has_elements:
        return _element_materials(model, rules, tissue)
    geometry = spring_geometry(model.mesh)
    moving = model.mesh.free[model.mesh.springs].any(axis=1)
    out = {}
    for index, region in enumerate(model.region_names):
        springs = np.flatnonzero((model.spring_region == index) & moving)
        nodes = np.flatnonzero((model.node_region == index) & model.mesh.free)
        if springs.size == 0 or nodes.size == 0:
            continue
        factor = geometry.spring_factor[springs]
        values = {
            "youngs_modulus": float(np.median(model.spring_stiffness[springs] / factor)),
            "poisson_ratio": SPRING_POISSON_RATIO,
            "viscosity": float(np.median(model.spring_damping[springs] / factor)),
            "density": float(np.sum(model.node_mass[nodes])
                             / np.sum(geometry.node_volume[nodes])),
            "tissue": model.region_tissues[index] or tissue,
        }
        if rules is not None:
            described = rules.describe(material_values(rules, model, springs, nodes))
            values["labels"] = {rules.outputs[name].quantity: label.term
                                for name, label in described.items()}
        out[region] = values
    return out


def _element_materials(model: SpringMassModel, rules, tissue) -> dict:
    out = {}
    for index, region in enumerate(model.region_names):
        chosen = model.element_region == index
        if not chosen.any():
            continue
        values = {**element_values(model, chosen),
                  "tissue": model.region_tissues[index] or tissue}
        if rules is not None:
            by_output = {name: values[variable.quantity]
                         for name, variable in rules.outputs.items()
                         if variable.quantity in values}
            values["labels"] = {rules.outputs[name].quantity: label.term
                                for name, label in rules.describe(by_output).items()}
        out[region] = values
    return out


def material_values(rules, model: SpringMassModel, springs=None, nodes=None,
                    elements=None) -> dict:
    """The material quantities a model's parameters stand for, per output variable of
    ``rules``.

    Spring models: medians over the given springs and nodes (default all; springs with both
    ends fixed are left out, their values are never learned); Poisson's ratio is the 1/4 a
    spring network is locked to. Element models: the elements' own E, ν, η (medians over
    ``elements``, default all) and the density of their lumped masses.
    """
    if model.has_elements:
        chosen = (np.ones(model.mesh.n_tetrahedra, bool) if elements is None
                  else np.isin(np.arange(model.mesh.n_tetrahedra), elements))
        by_quantity = element_values(model, chosen)
        return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
                if variable.quantity in by_quantity}
    by_quantity = spring_material_values(model, springs, nodes)
    return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
            if variable.quantity in by_quantity}
