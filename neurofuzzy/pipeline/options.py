"""How a fit learns, as one value: :class:`FitOptions`, the learner's options of
:func:`~neurofuzzy.pipeline.fit`. Where a fit starts (model, rules, tissue, tying, law) and
what it reports (names, held-out data) stay :func:`~neurofuzzy.pipeline.fit`'s own keywords.

The command line, ``fit-many``, the demo and the diagnosis's refits all fit through
:func:`~neurofuzzy.pipeline.fit`; the diagnosis gives it options that a user rarely sets
(``windows=()``: the whole recording at once; ``abandon_above``: give up a candidate that
cannot beat the best so far; ``checked=False``: a refit that ends badly is a candidate's
score, not an error).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields, replace

from ..errors import InputError, closest_name

__all__ = ["FitOptions", "METHODS"]

#: the learners ``method`` may name
METHODS = ("gradient", "paper")


@dataclass(frozen=True)
class FitOptions:
    """The learner's options of one fit (immutable; :meth:`replace` makes a changed copy).

    Parameters
    ----------
    method : {"gradient", "paper"}
        :class:`~neurofuzzy.learn.GradientLearner` or the paper's
        :class:`~neurofuzzy.learn.PaperLearner`.
    cycles : int, optional
        Learning cycles (paper, default 100) or iterations per stage (gradient, default 100).
    learn_masses : bool
        Learn the node masses too.
    substeps : int or "auto"
        Gradient method: simulation steps per frame (``"auto"``: the fewest the data follow,
        at two steps and extrapolated).
    learning_rate, mass_learning_rate : float
        The paper's learner's rates η and η_m.
    mesh_check : "auto", "step", "refit" or False
        Gradient method: how far the values move on the mesh refined once widens the
        intervals (:mod:`neurofuzzy.learn.mesh_check`).
    progress : bool
        Report progress on stderr.
    windows : sequence of int, optional
        Gradient method: the growing beginnings of the recording fitted in turn (frames);
        ``()`` fits the whole recording at once (from a start close to the answer); default
        the learner's own choice.
    tolerance : float, optional
        Gradient method: the relative change of the objective that ends a stage (default the
        learner's, 1e-10).
    abandon_above : float, optional
        Gradient method: give the fit up once its RMS error cannot come below this (metres;
        the diagnosis's best refit so far).
    fitted_at : int, optional
        Gradient method: the substeps at which the start model was already fitted (the fit
        then goes on at twice them only).
    checked : bool
        Check the data against the start (its size, frames not hundreds of stable steps
        apart) and refuse a fit that diverged or ends worse than a model that never moves
        (:class:`~neurofuzzy.pipeline.FitFailedError`), the default. False: the diagnosis's
        refits, whose data it checked once and which it ranks by their error: the fit is
        returned as it ends.
    """

    method: str = "gradient"
    cycles: int | None = None
    learn_masses: bool = False
    substeps: int | str = "auto"
    learning_rate: float = 0.1
    mass_learning_rate: float = 0.1
    mesh_check: bool | str = "auto"
    progress: bool = False
    windows: Sequence[int] | None = None
    tolerance: float | None = None
    abandon_above: float | None = None
    fitted_at: int | None = None
    checked: bool = True

    def __post_init__(self):
        if self.method not in METHODS:
            hint = closest_name(str(self.method), METHODS)
            raise InputError(f"got {self.method!r}; expected one of {', '.join(METHODS)}"
                             + (f" (did you mean {hint!r}?)" if hint else ""), key="method")
        if self.cycles is not None and not (isinstance(self.cycles, int)
                                            and not isinstance(self.cycles, bool)
                                            and self.cycles >= 1):
            raise InputError(f"got {self.cycles!r}; expected a positive integer", key="cycles")
        if self.method == "paper":
            if self.mesh_check and self.mesh_check != "auto":
                raise InputError("the paper's learner fits spring networks, whose constants "
                                 "belong to their mesh: the mesh check needs elements and the "
                                 "gradient method", key="mesh_check")
            gradient_only = [f.name for f in fields(self)
                             if f.name in ("windows", "tolerance", "abandon_above", "fitted_at")
                             and getattr(self, f.name) is not None]
            if gradient_only:
                raise InputError(f"{', '.join(gradient_only)}: options of the gradient method, "
                                 "not of the paper's learner", key="method")

    def replace(self, **changes) -> FitOptions:
        """A copy with ``changes`` (checked as a new value is)."""
        return replace(self, **changes)

    def with_shorthands(self, **given) -> FitOptions:
        """A copy with every ``given`` value that is not None (the shorthand keywords of
        :func:`~neurofuzzy.pipeline.fit`, which override the same fields of its options)."""
        return replace(self, **{k: v for k, v in given.items() if v is not None})

    def learner(self, prior=None):
        """The learner these options make (unfitted), with ``prior`` (a
        :class:`~neurofuzzy.learn.prior.FuzzyPrior` or None; the gradient method only)."""
        if self.method == "paper":
            from ..learn import PaperLearner

            if prior is not None:
                raise InputError("the paper's learner takes no prior; use the gradient method "
                                 "or --prior off", key="prior")
            return PaperLearner(learning_rate=self.learning_rate,
                                mass_learning_rate=self.mass_learning_rate,
                                cycles=self.cycles or 100, learn_masses=self.learn_masses,
                                progress=self.progress)
        from ..learn import GradientLearner

        chosen = {name: value for name, value in (("windows", self.windows),
                                                   ("tolerance", self.tolerance),
                                                   ("abandon_above", self.abandon_above),
                                                   ("fitted_at", self.fitted_at))
                  if value is not None}
        return GradientLearner(learn_masses=self.learn_masses, substeps=self.substeps,
                               max_iterations=self.cycles or 100, prior=prior,
                               mesh_check=self.mesh_check, progress=self.progress, **chosen)
