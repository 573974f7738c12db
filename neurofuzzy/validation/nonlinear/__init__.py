"""Nonlinear reference data from code nobody here wrote: hyperelastic and viscoelastic
elements solved by sfepy, closed forms, and recordings of the probed block.

The laws (:mod:`.materials`): the coupled compressible neo-Hookean solid, Yeoh's
strain-stiffening law, and FEBio's quasi-linear Prony-series viscoelasticity on top of
either. :class:`HyperelasticSolver` solves them dynamically at large strain;
:mod:`.closed_forms` gives uniaxial stress and the standard linear solid's creep and
relaxation to check it against; :mod:`.recordings` records the probed block of
:mod:`neurofuzzy.validation.probed_block` with them (up to about 35 % compression under the probe);
:mod:`.indentation` presses a rigid sphere deep into a block with sfepy's own contact term.

Needs sfepy (``pip install 'neurofuzzy[validation-nonlinear]'``) for the solver; the closed forms need only numpy and
scipy.
"""

from .closed_forms import (prony_relaxation, sls_creep, sls_relaxation, uniaxial_stress,
                           uniaxial_stretch)
from .materials import NeoHookean, Prony, Yeoh, lame_from_youngs
from .solver import HyperelasticSolver, Trajectory

__all__ = ["NeoHookean", "Yeoh", "Prony", "lame_from_youngs", "uniaxial_stress",
           "uniaxial_stretch", "sls_creep", "sls_relaxation", "prony_relaxation",
           "HyperelasticSolver", "Trajectory"]

