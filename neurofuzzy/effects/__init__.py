"""Physical effects a model may carry besides its springs, as extra force terms, and the
switches of the elements' material the diagnosis proposes beside them.

Each effect is one class with a name from the fixed vocabulary of DESIGN.md, a parameter vector
the learners fit, the force it adds, its derivatives (for the gradient learner) and the
physical units of its parameters (for the paper's learner). Adding an effect means adding one
subclass and registering it with :func:`register`; the simulator, both learners, the model
files and the diagnosis pick it up from the registry (the diagnosis asks every registered class
for candidates through :meth:`Effect.propose`). A switch of the material
(:class:`MaterialSwitch`: ``hyperelasticity``, ``relaxation``) is a catalogue entry the
diagnosis proposes and applies by changing the elements; it has no force, and a model never
carries one.

Modules: :mod:`.base` (the interface, the registry, model-file form), :mod:`.nodes` (gravity,
node drag, an unmodeled load), :mod:`.springs` (effects along springs), :mod:`.stiffening`
(springs or elements that stiffen with strain), :mod:`.inclusions` (regions of springs or of
tetrahedral elements), :mod:`.hyperelasticity` (elements whose law should be neo-Hookean),
:mod:`.relaxation` (elements that should relax).

=====================  ====================================================  ===============
name                   force on node i                                        parameters
=====================  ====================================================  ===============
gravity                ``m_i g``                                              ``g`` (3,)
node_drag              ``-b v_i`` (viscous drag of the surrounding medium)    ``b``
stiff_inclusion        springs ``R`` get ``k (l - L0) u`` extra, k > 0;       ``k`` per group;
                       elements ``R`` get Young's modulus ``E + δ``, δ > 0    ``δ`` (Pa)
soft_inclusion         the same with k < 0 (k > -s), δ < 0                    as above
nonlinear_stiffening   every spring gets ``κ (l - L0)³ / L0² u`` extra;      ``κ`` per group;
                       every element the stress ``2 κ (G:G) G`` extra        ``κ`` (Pa)
unmodeled_load         a constant force ``f`` at one node                     ``f`` (3,)
hyperelasticity        a switch, no force: the diagnosis gives the            none fitted
                       elements the neo-Hookean law
relaxation             a switch, no force: the diagnosis gives every          none fitted
                       element a Prony term (:mod:`neurofuzzy.forces.relaxation`)
=====================  ====================================================  ===============
"""

from .base import (EFFECTS, Effect, Entry, MaterialSwitch, effect_from_dict, effect_to_dict,
                   per_unit_mass_force, register, term_kinds)
from .nodes import Gravity, NodeDrag, UnmodeledLoad
from .inclusions import SoftInclusion, StiffInclusion
from .springs import SpringEffect
from .stiffening import NonlinearStiffening
from .hyperelasticity import Hyperelasticity
from .relaxation import Relaxation

__all__ = ["Entry", "Effect", "MaterialSwitch", "SpringEffect", "Gravity", "NodeDrag",
           "StiffInclusion", "SoftInclusion", "NonlinearStiffening", "UnmodeledLoad",
           "Hyperelasticity", "Relaxation", "EFFECTS",
           "register", "effect_to_dict", "effect_from_dict", "term_kinds",
           "per_unit_mass_force"]
