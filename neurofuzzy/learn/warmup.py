"""The learner's part of :mod:`neurofuzzy.warmup`: its forward sensitivities compiled without
the time stepper (which another part compiles at the same time)."""

from __future__ import annotations

import numpy as np

from ._parameters import Parameterization
from ._sensitivity import Sensitivity

__all__ = ["run_with_tangents"]


def run_with_tangents() -> None:
    """One run of the paper's cube with tangents through the learner's own path
    (``kernels.sensitivity.forward``), on data made up rather than simulated."""
    from ..datasets import paper_cube_model
    from ..experiment import Experiment

    model = paper_cube_model().tied("global")
    rest = model.mesh.rest_positions
    data = Experiment(model.mesh, 1e-3, np.repeat(rest[None], 6, axis=0),
                      external_forces=np.full((model.n_nodes, 3), 1e-3))
    parameters = Parameterization(model)
    Sensitivity(parameters, model.length_unit).run(parameters.initial(), data, tangents=True)
