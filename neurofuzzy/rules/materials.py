"""Material values and words per region of a model (:func:`materials`), and element models
whose parameters are the materials themselves (:func:`element_model`)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import SpringMassModel
from .physical import SPRING_POISSON_RATIO, material_values, spring_geometry

__all__ = ["materials", "element_model", "element_values", "SPRING_POISSON_RATIO",
           "DEFAULT_POISSON_RATIO"]

#: Poisson's ratio of an element model whose rule base says nothing about it: soft tissue is
#: nearly incompressible (0.45-0.49 in most measurements; 0.45 keeps linear tetrahedra from
#: locking on coarse meshes).
DEFAULT_POISSON_RATIO = 0.45


def materials(model: SpringMassModel, rules=None, tissue: str | None = None) -> dict:
    """The material values every region of ``model`` stands for, with words.

    Returns ``{region: {"youngs_modulus": Pa, "poisson_ratio": ..., "viscosity": Pa·s,
    "density": kg/m³, "tissue": str or None, "labels": {quantity: word}}}`` (the form of
    ``fit --json``'s ``"materials"``). For spring models, E, η and ρ are what the spring
    constants, viscosities and masses correspond to (the mapping of the module docstring) and
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


def element_values(model: SpringMassModel, chosen: np.ndarray) -> dict[str, float]:
    """E, ν, η (medians) and density of the elements ``chosen`` (bool mask) of an element
    model, by quantity."""
    return {
        "youngs_modulus": float(np.median(model.element_youngs_modulus[chosen])),
        "poisson_ratio": float(np.median(model.element_poisson_ratio[chosen])),
        "viscosity": float(np.median(model.element_viscosity[chosen])),
        "density": _region_density(model, chosen),
    }


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


def _poisson_inputs(rules) -> set[str]:
    """The input variables of the rules that conclude on a Poisson's-ratio output."""
    outputs = {name for name, variable in rules.outputs.items()
               if variable.quantity == "poisson_ratio"}
    return {clause.variable for rule in rules.rules
            if any(c.variable in outputs for c in rule.consequents)
            for group in rule.antecedent for clause in group}


def _region_density(model, chosen) -> float:
    """Mass over volume of a region's elements, each element carrying a quarter of the mass
    of each of its nodes' lumped share (exact for lumped masses of one density)."""
    from ..forces import tetrahedron_geometry

    geometry = tetrahedron_geometry(model.mesh)
    share = np.bincount(geometry.nodes.ravel(), np.repeat(geometry.volume / 4, 4),
                        model.n_nodes)
    element_mass = (model.node_mass[geometry.nodes] / share[geometry.nodes]
                    * (geometry.volume[:, None] / 4)).sum(axis=1)
    return float(element_mass[chosen].sum() / geometry.volume[chosen].sum())


def element_model(rules, mesh, names, values, element_tissue, *, spring_region,
                  node_region) -> SpringMassModel:
    """An element model of ``mesh``: every tetrahedron takes E, ν, η and density of its
    tissue (``element_tissue`` indexes ``names``; ``values[name]`` are the tissue's inferred
    outputs). ν comes from an output of quantity ``poisson_ratio`` where the rule base has
    one and the tissue's description names an input of its rules; else (the expert said
    nothing about compressibility, and every ν rule would fire at once, giving the centre of
    the universe) :data:`DEFAULT_POISSON_RATIO`."""
    if mesh.tetrahedra is None:
        raise InputError("element models need a mesh with tetrahedra (a volume mesh, or "
                         "--tetra for a surface)", key="elements")
    per_tissue = {key: np.empty(len(names)) for key in ("youngs_modulus", "poisson_ratio",
                                                         "viscosity", "density")}
    for index, name in enumerate(names):
        quantities = {rules.outputs[output].quantity: value
                      for output, value in values[name].items() if rules.outputs[output].quantity}
        for key in ("youngs_modulus", "viscosity", "density"):
            if key not in quantities:
                raise InputError(f"an element model needs the rule base's {key}; it has "
                                 f"{sorted(quantities)}", source=rules.source, key="outputs")
            per_tissue[key][index] = quantities[key]
        said = _poisson_inputs(rules) & set(rules.tissues.get(name, {}))
        per_tissue["poisson_ratio"][index] = (quantities["poisson_ratio"] if said
                                              and "poisson_ratio" in quantities
                                              else DEFAULT_POISSON_RATIO)
    model = SpringMassModel.continuum(
        mesh, **{key: value[element_tissue] for key, value in per_tissue.items()})
    return model.replace(region_names=tuple(names), region_tissues=tuple(names),
                         spring_region=spring_region, node_region=node_region,
                         element_region=element_tissue)
