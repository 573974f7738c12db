"""The material values a model stands for, whichever term carries its material: its
tetrahedral elements (their own E, ν, η, Prony terms and Yeoh constant) or, for a spring
network, its springs (E and η by the homogenisation of :mod:`.springs`, ν the 1/4 springs are
locked to). One function per kind of term, chosen in one place (:data:`MATERIAL_VALUES`)."""

from __future__ import annotations

import numpy as np

from ..forces import Springs, Tetrahedra
from .elements import element_values
from .springs import spring_geometry, spring_material_values

__all__ = ["material_term", "quantities", "region_quantities", "MATERIAL_VALUES"]


def _element_quantities(model, *, elements=None, **_) -> dict[str, float]:
    chosen = (np.ones(model.mesh.n_tetrahedra, bool) if elements is None
              else np.isin(np.arange(model.mesh.n_tetrahedra), elements))
    return element_values(model, chosen)


def _spring_quantities(model, *, springs=None, nodes=None, **_) -> dict[str, float]:
    return spring_material_values(model, springs, nodes)


def _element_region(model, index: int) -> dict | None:
    chosen = np.flatnonzero(model.elements.region == index)
    return {"elements": chosen} if chosen.size else None


def _spring_region(model, index: int) -> dict | None:
    moving = model.mesh.free[model.mesh.springs].any(axis=1)
    springs = np.flatnonzero((model.springs.region == index) & moving)
    nodes = np.flatnonzero((model.node_region == index) & model.mesh.free)
    return {"springs": springs, "nodes": nodes} if springs.size and nodes.size else None


#: per kind of term that carries a material: (its quantities over a selection, the
#: selection of a region's members or None when the region has none)
MATERIAL_VALUES = {Tetrahedra: (_element_quantities, _element_region),
                   Springs: (_spring_quantities, _spring_region)}


def material_term(model):
    """The term whose constants stand for the model's material: its elements, else its
    springs."""
    return model.elements if model.elements is not None else model.springs


def quantities(model, *, springs=None, nodes=None, elements=None) -> dict[str, float]:
    """The material quantities (``youngs_modulus``, ``poisson_ratio``, ``viscosity``,
    ``density``, and what the term adds) of ``model`` over a selection of its springs and
    nodes, or elements (default all), by quantity."""
    values, _ = MATERIAL_VALUES[type(material_term(model))]
    return values(model, springs=springs, nodes=nodes, elements=elements)


def region_quantities(model, index: int) -> dict[str, float] | None:
    """:func:`quantities` of region number ``index`` (None for a region without members)."""
    values, region = MATERIAL_VALUES[type(material_term(model))]
    selection = region(model, index)
    return None if selection is None else values(model, **selection)


def spring_factor(model) -> np.ndarray:
    """``k = E · factor`` of every spring (the rule base's mapping, :mod:`.springs`; 1 where a
    spring stands for no volume)."""
    factor = spring_geometry(model.mesh).spring_factor
    return np.where(factor > 0, factor, 1.0)


def item_values(model) -> tuple[str, dict[str, np.ndarray]]:
    """``("elements", {quantity: per element})`` for element models, else ``("springs",
    {quantity: the E and η every spring stands for})``."""
    if model.elements is not None:
        return "elements", {"youngs_modulus": model.elements.youngs_modulus,
                            "poisson_ratio": model.elements.poisson_ratio,
                            "viscosity": model.elements.viscosity}
    factor = spring_factor(model)
    return "springs", {"youngs_modulus": model.springs.stiffness / factor,
                       "viscosity": model.springs.damping / factor}
