"""Learners that refine a model's parameters from measured trajectories.

- :class:`PaperLearner`: the paper's algorithm (Figure 2), faithful.
- :class:`GradientLearner`: exact gradients of the discrete simulator with Gauss–Newton or
  L-BFGS and multiple shooting.

Both follow the estimator convention: ``fit(model, experiments)`` returns the learner, results
end in ``_`` (``model_``, ``history_``, ``rms_error_`` …).
"""

from ._base import Learner, rms_error
from .gradient import GradientLearner, auto_substeps
from .identifiability import Identifiability
from .paper import PaperLearner

__all__ = ["Learner", "PaperLearner", "GradientLearner", "Identifiability", "rms_error",
           "auto_substeps"]
