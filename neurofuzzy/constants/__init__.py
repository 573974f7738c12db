"""Material values ↔ the constants of a model's force terms, with no words (the ``materials``
layer of DESIGN.md; named ``constants`` because ``nf.materials`` is the function that reads
a fitted model's materials with words): spring
homogenisation (Young's modulus, viscosity and density ↔ spring constants and node masses on
lattices and tetrahedral meshes, :mod:`.springs`) and element models whose parameters are
the materials themselves (:mod:`.elements`). The rule bases (:mod:`neurofuzzy.rules`) turn
words into these values; this package turns the values into a model and back."""

from .elements import DEFAULT_POISSON_RATIO, element_model, element_values, region_density
from .springs import (SPRING_POISSON_RATIO, LatticeGeometry, TetraGeometry, lattice_geometry,
                      spring_geometry, spring_material_values, tetra_geometry,
                      tetrahedron_edge_springs, volume_shares)
from .values import (MATERIAL_VALUES, item_values, material_term, quantities,
                     region_quantities, spring_factor)

__all__ = ["DEFAULT_POISSON_RATIO", "element_model", "element_values", "region_density",
           "SPRING_POISSON_RATIO", "LatticeGeometry", "TetraGeometry", "lattice_geometry",
           "spring_geometry", "spring_material_values", "tetra_geometry",
           "tetrahedron_edge_springs", "volume_shares", "MATERIAL_VALUES", "material_term",
           "quantities", "region_quantities", "item_values", "spring_factor"]
