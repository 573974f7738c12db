"""Force terms of a model and their derivatives.

- :class:`ForceTerm`: the interface (force, Jacobian-vector products with respect to the state,
  parameters and their units, stiffness and damping at rest);
- :class:`SpringForce` (:data:`SPRINGS`): the springs, eqs. 3.4–3.6;
- :class:`TetrahedronForce` (:data:`TETRAHEDRA`): linear tetrahedral finite elements with the
  material's E, ν and η (St. Venant–Kirchhoff, Kelvin–Voigt viscosity);
- :class:`Incidence`: the node ↔ spring maps, one per mesh (:func:`incidence`);
  :func:`tetrahedron_geometry` and :class:`ElementConstants` the same for tetrahedra.

The effects of :mod:`neurofuzzy.effects` are force terms too.
"""

from .assembly import Incidence, incidence
from .base import ForceTerm
from .springs import (SPRINGS, SpringForce, SpringState, central_jvp, central_vjp,
                      projected_laplacian)
from .tetra_geometry import ElementConstants, tetrahedron_geometry
from .tetrahedra import TETRAHEDRA, TetrahedronForce

__all__ = ["ForceTerm", "SpringForce", "SPRINGS", "SpringState", "Incidence", "incidence",
           "central_jvp", "central_vjp", "projected_laplacian", "TetrahedronForce",
           "TETRAHEDRA", "tetrahedron_geometry", "ElementConstants"]
