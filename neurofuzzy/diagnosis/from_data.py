"""``diagnose_data(experiments, ...) -> DiagnosedData``: the diagnosis as ``neurofuzzy diagnose``
runs it, from measured data to a checked answer, in one place.

:func:`~neurofuzzy.diagnosis.diagnose` takes a model; this is the rest of the command's
pipeline, as :func:`neurofuzzy.fit` is the fit's: the start
(:func:`~neurofuzzy.pipeline.start_model`, chosen as the fit chooses it), the inputs checked
against it, the rule base as a prior when an inclusion is to be located, the diagnosis with
its failure explained, and the outcome check (a final model that diverges or ends worse than
one that never moves raises :class:`~neurofuzzy.pipeline.FitFailedError`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..errors import InputError
from ..experiment import Experiment
from ..formatting import json_safe
from ..pipeline import check_outcome, explained, require_motion
from .loop import Diagnosis, diagnose

if TYPE_CHECKING:
    from .load_steps import LoadStepDiagnosis
    from .moving import MovingDiagnosis

__all__ = ["DiagnosedData", "diagnose_data"]


@dataclass(frozen=True)
class DiagnosedData:
    """What :func:`diagnose_data` produced, checked.

    Attributes
    ----------
    diagnosis : Diagnosis
        The answer (effects found, the final model refitted, the lack of fit …).
    start : StartModel
        Where the diagnosis started (:func:`~neurofuzzy.pipeline.start_model`).
    experiments : list of Experiment
        The load cases that were diagnosed.
    """

    diagnosis: Diagnosis
    start: object
    experiments: list

    @property
    def model(self):
        """The final model, with the effects found, refitted."""
        return self.diagnosis.model_

    def to_dict(self, names: Sequence[str] | None = None) -> dict:
        """The object of ``neurofuzzy diagnose --json``: the diagnosis's, with the experiments
        (``names``, default their files), the start and the rule base's provenance."""
        data = self.diagnosis.to_dict()
        data.update(experiments=[str(e.source) for e in self.experiments]
                    if names is None else [str(n) for n in names],
                    start=self.start.to_dict())
        if self.start.rules is not None:
            data["rules"] = self.start.rules.provenance()
        return json_safe(data)


def diagnose_data(experiments: Experiment | str | os.PathLike | Sequence, *, start=None,
                  rules=None, tissue: str | None = None, tie: str | None = None,
                  elements: bool | None = None, law: str | None = None, relaxation=None,
                  stiffening: float | None = None, localise: bool = False,
                  max_effects: int = 3, substeps: int | str = "auto", mesh_check: bool = True,
                  max_time: float | None = None, window: int | str | None = "auto",
                  progress: bool = False) -> DiagnosedData | LoadStepDiagnosis | MovingDiagnosis:
    """Diagnose measured data from the start :func:`neurofuzzy.fit` would take.

    Parameters
    ----------
    experiments : Experiment, path or sequence of them
        Load cases of one object (paths are read).
    start, rules, tissue, tie, elements, law, relaxation, stiffening
        Where the diagnosis starts, as in :func:`neurofuzzy.fit`.
    localise : bool
        Locate an inclusion found item by item, with the rule base as a prior (needs
        ``rules`` and ``tissue``); see :func:`~neurofuzzy.diagnosis.diagnose`'s ``prior``.
    max_effects, substeps, mesh_check, max_time, window, progress
        As in :func:`~neurofuzzy.diagnosis.diagnose`.

    A lab experiment, one load-step file (``LoadSteps``) or one recording whose body a stage
    moved (an ``Experiment`` with driven sets or a tool), is diagnosed as ``neurofuzzy
    diagnose`` diagnoses it (plate slip against bonding, the law:
    :func:`~.load_steps.diagnose_load_steps`, :func:`~.moving.diagnose_moving`) from
    ``start`` or ``rules`` and ``tissue``, with ``law``, ``max_effects``, ``progress`` and
    (in time) ``substeps``; the time series' other options are refused by name, and its
    answer is returned as it is (a ``LoadStepDiagnosis`` or ``MovingDiagnosis``).

    Returns
    -------
    DiagnosedData
        Or the lab experiment's diagnosis.

    Raises
    ------
    InputError
        Bad input (files, options, a start of another object, data without motion).
    FitFailedError
        The final model diverges or explains the data worse than a model that never moves.
    """
    from ..pipeline import start_model
    from ..pipeline.fitting import experiment_list
    from ..pipeline.lab import lab_kind
    from ..pipeline.learners import make_prior
    from ..plausibility import check_fit_inputs

    kind = lab_kind(experiments)
    if kind is not None:
        refused = {"tie": tie, "elements": elements, "relaxation": relaxation,
                   "stiffening": stiffening, "localise": localise or None,
                   "max_time": max_time,
                   "window": None if window in (None, "auto") else window,
                   "mesh_check": None if mesh_check else False}
        return _lab(kind, experiments[0] if isinstance(experiments, list | tuple)
                    else experiments, start=start, rules=rules, tissue=tissue, law=law,
                    max_effects=max_effects, substeps=substeps, progress=progress,
                    refused=refused)
    experiments = experiment_list(experiments)
    begun = start_model(experiments, model=start, rules=rules, tissue=tissue, tie=tie,
                        elements=elements, law=law, relaxation=relaxation,
                        stiffening=stiffening, progress=progress)
    check_fit_inputs(experiments, begun.model, substeps=substeps,
                     model_source=start if isinstance(start, str | os.PathLike) else None,
                     physical=begun.how in ("model", "rules"))
    require_motion(experiments)
    prior = None
    if localise:
        if begun.rules is None:
            raise InputError("needs a rule base to locate an inclusion with "
                             "(--rules R --tissue T)", key="--localise")
        prior = make_prior(begun, "auto")
    with explained("diagnosis", experiments, begun.model, substeps):
        found = diagnose(begun.model, experiments, max_effects=max_effects, substeps=substeps,
                         prior=prior, mesh_check=mesh_check, max_time=max_time, window=window,
                         progress=progress)
    check_outcome("diagnosis", experiments, begun.model, found.model_, found.rms_before,
                  found.rms_after, substeps)
    return DiagnosedData(diagnosis=found, start=begun, experiments=experiments)


def _lab(kind, experiment, *, start, rules, tissue, law, max_effects, substeps, progress,
         refused):
    """The diagnosis of one lab experiment of ``kind``
    (:func:`~neurofuzzy.pipeline.lab.lab_kind`), as the command runs it; ``refused``: the
    time series' options given."""
    from ..io import load_experiment
    from ..io.load_steps import load_load_steps
    from ..load_steps import LoadSteps
    from ..pipeline.lab import LOAD_STEPS, lab_steps, refuse_options
    from ..pipeline.load_steps import load_step_start
    from ..progress import note
    from ..rules import resolve

    refuse_options(refused, f"the diagnosis of time series under loads; {kind} are diagnosed "
                   "without it")
    steps = lab_steps(kind, substeps)
    say = (lambda text: note(True, text)) if progress else None
    rules = resolve(rules) if rules is not None else None
    if kind == LOAD_STEPS:
        from .load_steps import diagnose_load_steps

        data = experiment if isinstance(experiment, LoadSteps) else load_load_steps(experiment)
        model = load_step_start(data, start=start, rules=rules, tissue=tissue, law=law)
        return diagnose_load_steps(model, data, max_effects=max_effects, progress=say)
    from .moving import diagnose_moving

    data = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    model = load_step_start(data, start=start, rules=rules, tissue=tissue, law=law)
    return diagnose_moving(model, data, substeps=steps,
                           max_effects=max_effects, progress=say)
