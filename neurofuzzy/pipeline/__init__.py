"""The one fit path of the toolkit: :func:`fit` (start, prior, learner, outcome check and
summary), called by Python users (``nf.fit``), ``neurofuzzy fit`` and every specimen of
``neurofuzzy fit-many``; a fit that diverged or explains the data worse than a model that
never moves raises :class:`FitFailedError` in all three."""

from .fitting import FitOutcome, fit, tie_label
from .outcome import (FitFailedError, check_outcome, explained, measured_motion,
                      require_motion)

__all__ = ["fit", "FitOutcome", "FitFailedError", "check_outcome", "explained",
           "measured_motion", "require_motion", "tie_label"]
