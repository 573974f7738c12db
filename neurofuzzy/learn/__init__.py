"""Learners that refine a model's parameters from measured trajectories.

- :class:`PaperLearner`: the paper's algorithm (Figure 2), faithful.
- :class:`Parameterization` (the free parameters as one vector) and :class:`Sensitivity`
  (simulation with exact forward sensitivities and the adjoint): the derivative machinery
  behind the gradient learner, for tests and for users who build their own optimiser;
- :func:`start_model`: where a fit starts (a model file, a rule base, or the data alone);
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
from .start import StartModel, estimate_start, start_model

__all__ = ["Learner", "PaperLearner", "GradientLearner", "Identifiability", "auto_substeps",
           "StartModel", "start_model", "estimate_start", "Parameterization",
           "Sensitivity", "Run", "element_directions"]
