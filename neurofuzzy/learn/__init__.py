"""Learners that refine a model's parameters from measured trajectories.

- :class:`PaperLearner`: the paper's algorithm (Figure 2), faithful.
- :class:`Parameterization` (the free parameters as one vector) and :class:`Sensitivity`
  (simulation with exact forward sensitivities and the adjoint): the derivative machinery
  behind the gradient learner, for tests and for users who build their own optimiser;
- :func:`estimate_start`: start values from the data alone (equation error); where a fit
  starts (a model file, a rule base or the data) is :func:`neurofuzzy.pipeline.start_model`;
- :class:`GradientLearner`: exact gradients of the discrete simulator with Gauss–Newton or
  L-BFGS and multiple shooting.

Both follow the estimator convention: ``fit(model, experiments)`` returns the learner, results
end in ``_`` (``model_``, ``history_``, ``rms_error_`` …).
"""

from ._base import Learner
from ._parameters import Parameterization, element_directions
from ._sensitivity import Run, Sensitivity
from .gradient import GradientLearner
from .steps import auto_substeps
from .identifiability import Identifiability
from .paper import PaperLearner
from .equation_error import StartModel, estimate_start

__all__ = ["Learner", "PaperLearner", "GradientLearner", "Identifiability", "auto_substeps",
           "StartModel", "estimate_start", "Parameterization",
           "Sensitivity", "Run", "element_directions"]


def __getattr__(name: str):
    if name == "start_model":
        raise AttributeError("neurofuzzy.learn.start_model has moved to "
                             "neurofuzzy.start_model (neurofuzzy.pipeline): where a fit starts "
                             "is the fit pipeline's choice")
    raise AttributeError(f"module 'neurofuzzy.learn' has no attribute {name!r}")
