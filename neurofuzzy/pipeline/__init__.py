"""The one fit path of the toolkit: :func:`fit` (start, prior, learner, outcome check and
summary), called by Python users (``nf.fit``), ``neurofuzzy fit`` and every specimen of
``neurofuzzy fit-many``; a fit that diverged or explains the data worse than a model that
never moves raises :class:`FitFailedError` in all three. Where a fit starts is
:func:`start_model` (:mod:`.start`); the learner, the prior and the summary are chosen in
:mod:`.learners`, how it learns is one :class:`FitOptions` value (:mod:`.options`)."""

from ..lazy import lazy
from .fitting import FitOutcome, fit, tie_label
from .options import FitOptions
from .outcome import (FitFailedError, check_outcome, explained, measured_motion,
                      require_motion)

__all__ = ["fit", "FitOptions", "FitOutcome", "FitFailedError", "check_outcome", "explained",
           "measured_motion", "require_motion", "tie_label", "start_model"]

# the start imports the learners (a third of a second): only when it is used
__getattr__, __dir__ = lazy(__name__, {"start_model": "start"})
