"""The learner's part of :mod:`neurofuzzy.warmup`: its forward sensitivities compiled without
the time stepper (which another part compiles at the same time)."""

from __future__ import annotations

import numpy as np

from ._parameters import Parameterization
from ._sensitivity import Sensitivity

__all__ = ["run_with_tangents"]


def run_with_tangents() -> None:
    """One run with tangents through the learner's own path (``kernels.sensitivity.forward``)
    of each kind of model the kernels compile apart: the paper's cube (springs; compiled
    without the element code) and a block of six tetrahedra, on data made up rather than
    simulated."""
    from ..datasets import paper_cube_model
    from ..experiment import Experiment
    from ..mesh import from_tetra, kuhn_block
    from ..model import Model

    block = Model.continuum(from_tetra(*kuhn_block((1, 1, 1), 0.01)), youngs_modulus=6e3,
                            poisson_ratio=0.45, viscosity=2.0, density=1000.0)
    for model in (paper_cube_model().tied("global"), block.tied("global")):
        rest = model.mesh.rest_positions
        data = Experiment(model.mesh, 1e-3, np.repeat(rest[None], 6, axis=0),
                          external_forces=np.full((model.n_nodes, 3), 1e-3))
        parameters = Parameterization(model)
        Sensitivity(parameters, model.length_unit).run(parameters.initial(), data,
                                                       tangents=True)
