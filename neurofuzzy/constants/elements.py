"""Element models whose parameters are the materials themselves: per-element E, ν, η and
density from per-tissue values (:func:`element_model`), and back (:func:`element_values`)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import Model

__all__ = ["DEFAULT_POISSON_RATIO", "element_model", "element_values", "region_density"]

#: Poisson's ratio of an element model whose rule base says nothing about it: soft tissue is
#: nearly incompressible (0.45-0.49 in most measurements; 0.45 keeps linear tetrahedra from
#: locking on coarse meshes).
DEFAULT_POISSON_RATIO = 0.45


def element_model(mesh, names, per_tissue: dict, element_tissue, *, node_region) -> Model:
    """An element model of ``mesh``: every tetrahedron takes the E (Pa), ν, η (Pa·s) and
    density (kg/m³) of its tissue.

    Parameters
    ----------
    mesh : Mesh
        With tetrahedra.
    names : sequence of str
        The tissues (one region each).
    per_tissue : dict of quantity → (n_tissues,) float
        ``youngs_modulus``, ``poisson_ratio``, ``viscosity`` and ``density`` of every tissue.
    element_tissue : (n_tetrahedra,) int
        Index into ``names`` of every tetrahedron's tissue.
    node_region : (n_nodes,) int
        The region of every node.
    """
    if mesh.tetrahedra is None:
        raise InputError("element models need a mesh with tetrahedra (a volume mesh, or "
                         "--tetra for a surface)", key="elements")
    model = Model.continuum(
        mesh, **{key: np.asarray(value)[element_tissue] for key, value in per_tissue.items()})
    return model.replace(region_names=tuple(names), region_tissues=tuple(names),
                         node_region=node_region,
                         terms=(model.elements.replace(region=element_tissue),))


def element_values(model: Model, chosen: np.ndarray) -> dict[str, float]:
    """E, ν, η (medians) and density of the elements ``chosen`` (bool mask) of an element
    model, by quantity; for elements that relax (Prony terms, E the long-term modulus) also
    ``relaxation_modulus``, the relative modulus that relaxes away in all (``Σ gᵢ``: the
    material is ``1 + Σ gᵢ`` times stiffer at once), and ``relaxation_time``, its times'
    mean weighted by their moduli (geometric; τ itself for one term), medians over the
    elements; for the elements of a law whose constant has words (its record's ``quantity``:
    Yeoh's ``strain_stiffening``), the median of their constant."""
    values = {
        "youngs_modulus": float(np.median(model.elements.youngs_modulus[chosen])),
        "poisson_ratio": float(np.median(model.elements.poisson_ratio[chosen])),
        "viscosity": float(np.median(model.elements.viscosity[chosen])),
        "density": region_density(model, chosen),
    }
    if model.n_relaxation_terms:
        g = model.elements.relaxation_moduli[chosen]
        total = g.sum(axis=1)
        weights = g / np.where(total > 0, total, 1.0)[:, None]
        times = np.exp((weights * np.log(model.elements.relaxation_times[chosen])).sum(axis=1))
        values["relaxation_modulus"] = float(np.median(total))
        values["relaxation_time"] = float(np.median(times))
    from ..forces.laws import LAW_OF_QUANTITY

    for quantity, law in LAW_OF_QUANTITY.items():
        own = chosen & (model.elements.law == law)
        if np.any(own):
            values[quantity] = float(np.median(model.elements.stiffening[own]))
    return values


def region_density(model, chosen) -> float:
    """Mass over volume of a region's elements, each element carrying a quarter of the mass
    of each of its nodes' lumped share (exact for lumped masses of one density)."""
    from ..forces import tetrahedron_geometry

    geometry = tetrahedron_geometry(model.mesh)
    share = np.bincount(geometry.nodes.ravel(), np.repeat(geometry.volume / 4, 4),
                        model.n_nodes)
    element_mass = (model.node_mass[geometry.nodes] / share[geometry.nodes]
                    * (geometry.volume[:, None] / 4)).sum(axis=1)
    return float(element_mass[chosen].sum() / geometry.volume[chosen].sum())
