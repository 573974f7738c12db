"""``fit(experiments, ...) -> FitOutcome``: the start of the fit, the rule base as a prior,
the learner, the outcome check and the summary, in that order and in one place.

Before this module the command line held the pipeline and ``fit-many`` rebuilt it without
the outcome check, so a specimen whose fit diverged was recorded as fitted. Now both call
:func:`fit`, and so do the examples.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..errors import InputError
from ..experiment import Experiment
from ..formatting import length_text
from ..progress import announced, note
from .lab import fit_lab, lab_kind
from .options import FitOptions
from .outcome import check_outcome, explained, require_motion

__all__ = ["FitOutcome", "fit", "tie_label", "experiment_list"]


@dataclass(frozen=True)
class FitOutcome:
    """What one fit produced, checked.

    Attributes
    ----------
    model : Model
        The fitted model (``learner.model_``).
    learner : Learner
        The fitted learner (history, standard errors, lack of fit …).
    start : StartModel
        Where the fit started (:func:`~.start.start_model`).
    prior : FuzzyPrior or None
        The rule base as a prior, when the fit used one.
    experiments : list of Experiment
        The load cases that were fitted.
    summary : dict
        The object of ``neurofuzzy fit --json`` (:func:`~.learners.fit_summary`).
    record : dict
        What a fitted model file keeps of the fit (:func:`~.learners.fit_record`).
    """

    model: object
    learner: object
    start: object
    prior: object
    experiments: list
    summary: dict = field(repr=False)
    record: dict = field(repr=False)

    @property
    def lack_of_fit(self):
        """The fitted model's lack of fit against the marker noise (with its verdict)."""
        return self.learner.lack_of_fit_

    @property
    def substeps(self) -> int:
        """Integration steps per frame with which :attr:`model` reproduces the data."""
        return self.learner.substeps_

    @property
    def rms_error(self) -> float:
        """The fitted model's RMS error per marker (metres)."""
        return self.learner.rms_error_

    @property
    def rms_error_initial(self) -> float:
        """The start model's RMS error per marker (metres)."""
        return self.learner.rms_error_initial_

    @property
    def history(self):
        """The learner's objective per cycle (an array), counted in :attr:`cycle_name`."""
        import numpy as np

        return np.asarray(self.learner.history_)

    @property
    def cycle_name(self) -> str:
        """What one entry of :attr:`history` is (a cycle, an evaluation …)."""
        return self.learner.cycle_name

    @property
    def n_cycles(self) -> int:
        return self.learner.n_cycles_

    @property
    def learn_masses(self) -> bool:
        """Whether the masses were learned (else the density is the masses', not a finding)."""
        return self.learner.learn_masses

    # what only the gradient learner estimates: None (or empty) after the paper's
    @property
    def identifiability(self):
        """Standard errors and unidentifiable parameters
        (:class:`~neurofuzzy.learn.identifiability.Identifiability`), or None (the paper's
        learner estimates none)."""
        return getattr(self.learner, "identifiability_", None)

    @property
    def intervals(self) -> dict:
        """95 % intervals per parameter name (empty when none were estimated)."""
        return getattr(self.learner, "intervals_", None) or {}

    @property
    def intervals_hold(self) -> str | None:
        """What :attr:`intervals` hold: the noise alone, or the noise and the mesh."""
        return getattr(self.learner, "intervals_hold_", None)

    @property
    def mesh_check(self):
        """The fit on the mesh refined once, when it was made (else None)."""
        return getattr(self.learner, "mesh_check_", None)

    @property
    def prior_weight(self) -> dict | None:
        """With a prior: its weight ``alpha``, how it was chosen and the marker noise."""
        return getattr(self.learner, "prior_", None) if self.prior is not None else None

    @property
    def regions(self) -> dict | None:
        """With a prior: the regions found (``regions``, ``rest``, ``words``, ``power``)."""
        return getattr(self.learner, "regions_", None) if self.prior is not None else None


def tie_label(tie: str | None, start) -> str:
    """The tying a fit used, for its record: the option given, else ``"model"`` when a start
    model's own tie groups were kept, else ``"groups"``."""
    return tie or ("model" if start is not None else "groups")


def fit(experiments: Experiment | str | os.PathLike | Sequence, *, start=None, rules=None,
        tissue: str | None = None, tie: str | None = None, elements: bool | None = None,
        law: str | None = None, relaxation=None, stiffening: float | None = None,
        prior="default", options: FitOptions | None = None, names: Sequence[str] | None = None,
        validate_on=None, method: str | None = None, cycles: int | None = None,
        learn_masses: bool | None = None, substeps: int | str | None = None,
        learning_rate: float | None = None, mass_learning_rate: float | None = None,
        mesh_check: bool | str | None = None, progress: bool | None = None) -> FitOutcome:
    """Fit a model to ``experiments``: the one fit of the command line, ``fit-many`` and
    Python.

    1. the start (:func:`~.start.start_model`: ``start``, else ``rules`` and
       ``tissue``, else the equation-error estimate), checked against the data
       (:func:`~neurofuzzy.plausibility.check_fit_inputs`);
    2. the prior (:func:`~.learners.make_prior`) and the learner
       (:meth:`~.options.FitOptions.learner`);
    3. the fit; a learner's own failure is re-raised as :class:`FitFailedError` with its
       likely cause;
    4. the outcome check (:func:`~.outcome.check_outcome`): a fit whose simulation diverges or
       that ends worse than a model that never moves raises :class:`FitFailedError`;
    5. the summary (``neurofuzzy fit --json``) and the model file's record.

    Parameters
    ----------
    experiments : Experiment, path or sequence of them
        Load cases of one object; paths are read with
        :func:`~neurofuzzy.io.load_experiment`.
    start : Model or path, optional
        A start model (its regions, tissues, masses and tie groups are kept).
    rules : RuleBase, path or shipped name, optional
        The rule base: start values with ``tissue``, words for the summary, the prior.
    tissue : str, optional
    tie : {"global", "groups", "none"}, optional
        Parameter tying (default: the start model's own, else ``"groups"``).
    elements : bool, optional
        With ``rules``: tetrahedral elements or springs (default: elements when the mesh has
        tetrahedra). The paper's learner always starts from the spring network.
    law : {"st-venant-kirchhoff", "neo-hookean", "yeoh"}, optional
        The elements' material law (default: the start model's own, else
        St. Venant–Kirchhoff); see :mod:`neurofuzzy.forces.laws`.
    stiffening : float, optional
        Yeoh's ``C₂₀/C₁₀`` to start the Yeoh elements from (default the start model's own,
        else 1); it is fitted per region.
    relaxation : int, sequence of (g, τ) or str, optional
        Prony relaxation of the elements to fit (a number of terms, or their start values;
        default the start model's own, else none); see :mod:`neurofuzzy.forces.relaxation`.
    prior : {"default", "auto", "off"}, float or FuzzyPrior
        See :func:`~.learners.make_prior`.
    options : FitOptions, optional
        How the fit learns (:class:`~.options.FitOptions`: the learner, its cycles, substeps,
        mesh check, progress …); default ``FitOptions()``.
    names : sequence of str, optional
        How the summary names the experiments (default: their files).
    validate_on : float, str or sequence of int or str, optional
        Data kept out of the fit and predicted (:mod:`.validation`): a time in seconds, a
        float (every experiment fitted on its frames before it), or load cases (a name, or a
        list of indices into ``experiments`` or names). The summary's ``validation`` holds
        the prediction error beside the fitted one.

    method, cycles, learn_masses, substeps, learning_rate, mass_learning_rate, mesh_check, progress
        Shorthands of the same fields of ``options``: each one given (not None) overrides it
        (``progress=True``: report progress on stderr).

    A lab experiment, one load-step file (``LoadSteps``: scans at equilibria) or one
    recording whose body a stage moved (an ``Experiment`` with driven sets or a tool), is
    fitted as ``neurofuzzy fit`` fits it (:mod:`.lab`: E, ν and, in time, η through static or
    implicit steps), from ``start`` or ``rules`` and ``tissue``, with ``law``, ``validate_on``
    (load steps by number) and the options ``mesh_check``, ``progress`` and (in time)
    ``substeps``; the learners' other options are refused by name. It returns a
    :class:`~.load_steps.LoadStepOutcome` (``result``, ``record``: the object of ``fit
    --json``).

    Returns
    -------
    FitOutcome
        Or a :class:`~.load_steps.LoadStepOutcome` for a lab experiment.

    Raises
    ------
    InputError
        Bad input (files, options, a start of another object).
    FitFailedError
        The fit ran but failed (diverged, or worse than a model that never moves).
    """
    from .learners import fit_record, fit_summary, make_prior
    from .start import start_model
    from ..plausibility import check_fit_inputs

    options = (FitOptions() if options is None else options).with_shorthands(
        method=method, cycles=cycles, learn_masses=learn_masses, substeps=substeps,
        learning_rate=learning_rate, mass_learning_rate=mass_learning_rate,
        mesh_check=mesh_check, progress=progress)
    kind = lab_kind(experiments)
    if kind is not None:
        return fit_lab(kind, experiments[0] if isinstance(experiments, list | tuple)
                       else experiments, start=start, rules=rules, tissue=tissue, law=law,
                       validate_on=validate_on, options=options,
                       refused={"tie": tie, "elements": elements, "relaxation": relaxation,
                                "stiffening": stiffening, "names": names,
                                "prior": None if isinstance(prior, str) and prior == "default"
                                else prior})
    method, substeps, progress = options.method, options.substeps, options.progress
    experiments = experiment_list(experiments)
    names = [str(e.source) for e in experiments] if names is None else [str(n) for n in names]
    split = None
    if validate_on is not None:
        from .validation import hold_out

        split = hold_out(experiments, validate_on, names)
        experiments, names = split.fitted, split.fitted_names
    if method == "paper":
        elements = False                    # the paper's learner is the spring network's
    begun = start_model(experiments, model=start, rules=rules, tissue=tissue, tie=tie,
                        elements=elements, law=law, relaxation=relaxation,
                        stiffening=stiffening, progress=progress)
    if options.checked:
        check_fit_inputs(experiments, begun.model, substeps=substeps,
                         model_source=start if isinstance(start, str | os.PathLike) else None,
                         physical=begun.how in ("model", "rules"))
    require_motion(experiments)
    if options.mesh_check and options.mesh_check != "auto" and begun.model.elements is None:
        raise InputError("refines tetrahedral elements; this fit's model is a spring network "
                         "(give a model or experiment with tetrahedra, or --elements tetra)",
                         key="--mesh-check")
    chosen_prior = make_prior(begun, prior, tie=tie, method=method)
    learner = options.learner(chosen_prior)
    with announced(progress):
        if options.checked:
            with explained("fit", experiments, begun.model, substeps):
                learner.fit(begun.model, experiments)
            check_outcome("fit", experiments, begun.model, learner.model_,
                          learner.rms_error_initial_, learner.rms_error_, learner.substeps_)
        else:
            learner.fit(begun.model, experiments)
    # the progress lines give each stage's RMS; this is the fitted model's, as the summary's
    note(progress, f"fit: {learner.substeps_} substep(s) per frame kept, RMS "
                   f"{length_text(learner.rms_error_)} per marker")
    summary = fit_summary(learner, begun, method=method, tie=tie_label(tie, start),
                          experiments=names)
    if split is not None:
        from .validation import validation

        summary["validation"] = validation(learner.model_, split, substeps=learner.substeps_,
                                           fitted_rms=learner.rms_error_,
                                           noise_rms=learner.lack_of_fit_.noise)
        note(progress, f"held out: RMS {length_text(summary['validation']['rms_error'])} "
                       "per marker predicted")
    return FitOutcome(model=learner.model_, learner=learner, start=begun, prior=chosen_prior,
                      experiments=experiments, summary=summary,
                      record=fit_record(learner, names, begun.rules))


def experiment_list(experiments) -> list[Experiment]:
    """``experiments`` as a list of :class:`Experiment` (paths read)."""
    if isinstance(experiments, Experiment | str | os.PathLike):
        experiments = [experiments]
    out = []
    for item in experiments:
        if isinstance(item, Experiment):
            out.append(item)
        elif isinstance(item, str | os.PathLike):
            from ..io import load_experiment

            out.append(load_experiment(item))
        else:
            raise InputError(f"got {type(item).__name__}; expected an Experiment or the path "
                             "of an experiment file", key="experiments")
    if not out:
        raise InputError("no experiments given", key="experiments")
    return out
