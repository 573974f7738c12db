"""A model's force at one state, compiled: what an implicit step evaluates where the explicit
stepper updates (:func:`neurofuzzy.kernels.stepper.advance` adds the same forces and then
moves the nodes).

:func:`body_force` writes ``F(p, v)``, every spring's and element's force and the node drag,
into ``force``, from the model's groups as the stepper takes them
(:func:`neurofuzzy.simulation.steppers._prepared`); the arithmetic is the stepper's own
(:func:`~neurofuzzy.kernels.stepper._springs`,
:func:`~neurofuzzy.kernels.element_forces.element_forces`), nothing is written again.
"""

import numba

from .element_forces import element_forces
from .stepper import _springs


@numba.njit(cache=True, nogil=True)
def body_force(p, v, springs, elements, node_strain, relaxation, terms, force):
    """``force = F(p, v)``: the springs ``(a, b, stiffness, damping, rest, cubic)``, the
    elements (``ElementArrays``, ``tets`` of shape (0, 4) for none; ``node_strain`` (N, 2)
    scratch space), their Prony terms ``relaxation = (g, a, history)`` and ``terms = (kappa,
    drag)``, the strain stiffening and a node drag; no external load. One thread. Elements
    that relax read their internal variables ``history`` and advance them as a step does
    (:func:`~neurofuzzy.kernels.relaxation.relax`): pass a copy to keep them."""
    kappa, drag = terms
    for i in range(p.shape[0]):
        for k in range(3):
            force[i, k] = -drag * v[i, k]
    a, b, stiffness, damping, rest, cubic = springs
    _springs(p, v, a, b, stiffness, damping, rest, cubic, force)
    if elements.tets.shape[0]:
        element_forces(p, v, elements, node_strain, relaxation, kappa, force, None)
