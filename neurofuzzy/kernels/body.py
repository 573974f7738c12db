"""A model's force at one state, compiled: what an implicit step evaluates where the explicit
stepper updates (:func:`neurofuzzy.kernels.stepper.advance` adds the same forces and then
moves the nodes).

:func:`body_force` writes ``F(p, v)``, every spring's and element's force and the node drag,
into ``force``, from the arrays of the stepper's layout
(:func:`neurofuzzy.simulation.steppers._prepared`) passed as two tuples, the springs' and the
elements'; the arithmetic is the stepper's own (:func:`~neurofuzzy.kernels.stepper._springs`,
:func:`~neurofuzzy.kernels.element_forces.element_forces`), nothing is written again.
"""

import numba

from .element_forces import element_forces
from .stepper import _springs


@numba.njit(cache=True, nogil=True)
def body_force(p, v, springs, elements, kappa, drag, force):
    """``force = F(p, v)``: the springs ``(a, b, stiffness, damping, rest, cubic)``, the
    elements (the 17 arrays of :func:`~neurofuzzy.simulation.steppers._element_arrays`, with
    ``tets`` of shape (0, 4) for none), the strain stiffening ``kappa`` and a node drag
    ``drag``; no external load. One thread. Elements that relax read their internal
    variables (``elements[-1]``) and advance them as a step does
    (:func:`~neurofuzzy.kernels.relaxation.relax`): pass a copy to keep them."""
    for i in range(p.shape[0]):
        for k in range(3):
            force[i, k] = -drag * v[i, k]
    a, b, stiffness, damping, rest, cubic = springs
    _springs(p, v, a, b, stiffness, damping, rest, cubic, force)
    if elements[0].shape[0]:
        element_forces(p, v, elements[:13], elements[13], elements[14:], kappa, force, None)
