"""Force terms of a model and their derivatives.

- :class:`ForceTerm`: the interface (force, Jacobian-vector products with respect to the state,
  parameters and their units, stiffness and damping at rest);
- :class:`Springs`: the springs and their constants, eqs. 3.4–3.6;
- :class:`Tetrahedra`: linear tetrahedral finite elements with the material's E, ν and η, a
  material law per element and Prony relaxation (:mod:`neurofuzzy.forces.tetrahedra`);
- :class:`Incidence`: the node ↔ spring maps, one per mesh (:func:`incidence`);
  :func:`tetrahedron_geometry` and :class:`ElementConstants` the same for tetrahedra.

The effects of :mod:`neurofuzzy.effects` are force terms too.
"""

from .assembly import Incidence, incidence
from .base import ForceTerm, region_index, vector
from .central import central_jvp, central_vjp, projected_laplacian
from .springs import Springs, SpringState
from .tetra_geometry import ElementConstants, tetrahedron_geometry
from .tetrahedra import Tetrahedra

__all__ = ["ForceTerm", "Springs", "SpringState", "Incidence", "incidence", "central_jvp",
           "central_vjp", "projected_laplacian", "Tetrahedra", "tetrahedron_geometry",
           "ElementConstants", "vector", "region_index"]
