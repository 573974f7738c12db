"""One specimen's fit, run on a Dask worker: :func:`fit_specimen`.

The fit is the one of ``neurofuzzy fit``, the library's pipeline :func:`neurofuzzy.pipeline.fit`
(start, prior, learner, outcome check, summary with materials and words), then
:func:`~neurofuzzy.report.fit_report`; optionally :func:`~neurofuzzy.diagnosis.diagnose`. A fit
that diverged or explains the data worse than a model that never moves is a failed specimen,
as it is an error of ``neurofuzzy fit``. The task reads its inputs from their paths and
returns every output as bytes: the command writes them, so workers need to see the inputs
(a shared file system on a cluster), not the output folder.
"""

from __future__ import annotations

import os
import socket
import tempfile
import time
import traceback
from pathlib import Path

from ..errors import NeurofuzzyError
from .manifest import Specimen, relative_path

__all__ = ["fit_specimen", "fit_quality", "load_specimen_experiments", "OUTPUT_FILES"]

#: the files a finished specimen's folder holds beside ``fit.json`` (diagnosis files only
#: when asked for)
OUTPUT_FILES = ("fitted.yaml", "report.html", "report.json", "diagnosis.html",
                "diagnosis.json")


def fit_specimen(specimen: Specimen) -> dict:
    """Fit one specimen; never raises for a failure of its own.

    Parameters
    ----------
    specimen : Specimen

    Returns
    -------
    dict
        ``{"id", "status": "ok", "fit": {…}, "files": {name: bytes}, "seconds", "worker"}``
        (``worker``: ``HOST:PID`` of the process that ran it), where
        ``fit`` is the object of ``neurofuzzy fit --json`` plus ``quality`` (:func:`fit_quality`)
        and, when asked for, ``diagnosis``; or ``{"id", "status": "failed", "error",
        "kind": "input" | "fit" | "error", "traceback" (for "error" only), "seconds"}``:
        ``"fit"`` for a fit that ran but failed (diverged, or worse than a model that never
        moves: :class:`~neurofuzzy.pipeline.FitFailedError`).
    """
    started = time.perf_counter()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    from ..pipeline import FitFailedError

    try:
        fit, files = _fit(specimen)
    except FitFailedError as error:
        # the fit ran and failed: recorded as failed with the reason, as `fit` would exit 2
        return {"id": specimen.id, "status": "failed", "kind": "fit", "error": str(error),
                "seconds": time.perf_counter() - started, "worker": worker}
    except NeurofuzzyError as error:
        # bad input of this one specimen (a corrupt file, an unstable start): recorded with
        # its message, and the batch goes on
        return {"id": specimen.id, "status": "failed", "kind": "input", "error": str(error),
                "seconds": time.perf_counter() - started, "worker": worker}
    except Exception as error:  # noqa: BLE001
        # deliberately broad: whatever else stops one specimen (a bug, a fit that runs out
        # of memory) is recorded with its traceback, and the other specimens go on
        return {"id": specimen.id, "status": "failed", "kind": "error",
                "error": f"{type(error).__name__}: {error}",
                "traceback": traceback.format_exc(), "seconds": time.perf_counter() - started,
                "worker": worker}
    return {"id": specimen.id, "status": "ok", "fit": fit, "files": files,
            "seconds": time.perf_counter() - started, "worker": worker}


def _fit(specimen: Specimen) -> tuple[dict, dict[str, bytes]]:
    from ..io.load_steps import is_load_steps_file
    from ..io.paths import is_moved_file

    if len(specimen.experiments) == 1 and is_load_steps_file(specimen.experiments[0]):
        return _fit_load_steps(specimen)
    if any(is_moved_file(path) for path in specimen.experiments):
        return _fit_moved(specimen)
    return _fit_time_series(specimen)


def _fit_moved(specimen: Specimen) -> tuple[dict, dict[str, bytes]]:
    """A specimen whose body a stage moved in time (a plate ramped, a tool pressed): the fit
    of ``neurofuzzy fit MOVED.npz`` through implicit steps
    (:func:`neurofuzzy.pipeline.moving.fit_moving_file`) and its report."""
    from ..errors import InputError
    from ..io import save_model
    from ..formatting import json_safe
    from ..pipeline.moving import fit_moving_file, moving_fit_report
    from ..rules import resolve

    options = specimen.options
    if len(specimen.experiments) != 1:
        raise InputError("a recording whose body a stage moved is fitted one at a time: give "
                         "this specimen one experiment file", key="experiments")
    substeps = options.get("substeps", "auto")
    substeps = 1 if substeps in (None, "auto") else int(substeps)
    rules = resolve(specimen.rules) if specimen.rules else None
    outcome = fit_moving_file(specimen.experiments[0], start=specimen.start, rules=rules,
                              tissue=specimen.tissue, law=options.get("law"),
                              substeps=substeps)
    fit = dict(outcome.record)
    with tempfile.TemporaryDirectory(prefix="neurofuzzy-fit-many-") as folder:
        folder = Path(folder)
        save_model(outcome.result.model, folder / "fitted.yaml")
        moving_fit_report(outcome, folder / "report.html", substeps=substeps,
                          title=f"neurofuzzy fit: specimen {specimen.id} ({specimen.group})")
        if options.get("diagnose"):
            from ..diagnosis.moving import diagnose_moving
            from ..pipeline.moving import moving_diagnosis_report

            diagnosis = diagnose_moving(outcome.start, outcome.data, substeps=substeps)
            fit["diagnosis"] = {"effects": diagnosis.names,
                                "rms_before": diagnosis.before.rms_error,
                                "rms_after": diagnosis.after.rms_error}
            moving_diagnosis_report(diagnosis, outcome.data, folder / "diagnosis.html",
                                    substeps=substeps, title=f"neurofuzzy diagnosis: specimen "
                                    f"{specimen.id} ({specimen.group})")
        files = {name: (folder / name).read_bytes() for name in OUTPUT_FILES
                 if (folder / name).exists()}
    return json_safe(fit), files


def _fit_load_steps(specimen: Specimen) -> tuple[dict, dict[str, bytes]]:
    """A specimen measured at load steps (a compression test between plates): the fit of
    ``neurofuzzy fit STEPS.npz`` (:func:`neurofuzzy.pipeline.load_steps.fit_load_step_file`),
    its report and, when asked for, the load-step diagnosis."""
    from ..io import save_model
    from ..formatting import json_safe
    from ..pipeline.load_steps import fit_load_step_file
    from ..report.load_steps import load_steps_report
    from ..rules import resolve

    options = specimen.options
    rules = resolve(specimen.rules) if specimen.rules else None
    outcome = fit_load_step_file(specimen.experiments[0], start=specimen.start, rules=rules,
                                 tissue=specimen.tissue, law=options.get("law"))
    fit = dict(outcome.record)
    with tempfile.TemporaryDirectory(prefix="neurofuzzy-fit-many-") as folder:
        folder = Path(folder)
        save_model(outcome.result.model_, folder / "fitted.yaml")
        labels = next(iter(fit["materials"].values()), {}).get("labels", {})
        load_steps_report(outcome.start, outcome.result, outcome.data, folder / "report.html",
                          title=f"neurofuzzy fit: specimen {specimen.id} ({specimen.group})",
                          labels=labels)
        if options.get("diagnose"):
            from ..diagnosis.load_steps import diagnose_load_steps
            from ..report.load_steps import load_step_diagnosis_report

            diagnosis = diagnose_load_steps(outcome.start, outcome.data)
            fit["diagnosis"] = {"effects": diagnosis.names,
                                "rms_before": diagnosis.before.marker_rms_,
                                "rms_after": diagnosis.after.marker_rms_}
            load_step_diagnosis_report(diagnosis, outcome.data, folder / "diagnosis.html",
                                       title=f"neurofuzzy diagnosis: specimen {specimen.id} "
                                       f"({specimen.group})")
        files = {name: (folder / name).read_bytes() for name in OUTPUT_FILES
                 if (folder / name).exists()}
    return json_safe(fit), files


def _fit_time_series(specimen: Specimen) -> tuple[dict, dict[str, bytes]]:
    from ..io import save_model
    from ..pipeline import fit as fit_pipeline
    from ..report import fit_report
    from ..formatting import json_safe

    options = specimen.options
    experiments = load_specimen_experiments(specimen)
    base = Path(specimen.source).parent
    inputs = [relative_path(path, base) for path in specimen.experiments or specimen.markers]
    outcome = fit_pipeline(experiments, start=specimen.start, rules=specimen.rules,
                           tissue=specimen.tissue, tie=options.get("tie"),
                           law=options.get("law"), stiffening=options.get("stiffening"),
                           relaxation=options.get("relaxation"),
                           prior=options.get("prior", "default"),
                           method=options.get("method", "gradient"), cycles=options.get("cycles"),
                           learn_masses=options.get("learn_masses", False),
                           substeps=options.get("substeps", "auto"), names=inputs)
    fit = dict(outcome.summary)
    fit["quality"] = fit_quality(outcome.model, experiments, outcome.substeps,
                                 lack_of_fit=outcome.lack_of_fit)
    with tempfile.TemporaryDirectory(prefix="neurofuzzy-fit-many-") as folder:
        folder = Path(folder)
        save_model(outcome.model, folder / "fitted.yaml")
        fit_report(outcome, folder / "report.html",
                   title=f"neurofuzzy fit: specimen {specimen.id} ({specimen.group})",
                   files={"fitted model": folder / "fitted.yaml"})
        if options.get("diagnose"):
            from ..diagnosis import diagnose
            from ..report import diagnosis_report

            diagnosis = diagnose(outcome.model, experiments,
                                 substeps=options.get("substeps", "auto"))
            diagnosis_report(diagnosis, folder / "diagnosis.html",
                             title=f"neurofuzzy diagnosis: specimen {specimen.id}")
            fit["diagnosis"] = {"effects": diagnosis.names, "rms_before": diagnosis.rms_before,
                                "rms_after": diagnosis.rms_after,
                                "noise_rms": diagnosis.noise_rms}
        files = {name: (folder / name).read_bytes() for name in OUTPUT_FILES
                 if (folder / name).exists()}
    return json_safe(fit), files


def load_specimen_experiments(specimen: Specimen) -> list:
    """The specimen's experiments: its experiment files, or its marker recordings (with
    their force files) on the start model's mesh.

    Returns
    -------
    list of Experiment
    """
    from ..io import load_experiment

    if specimen.experiments:
        return [load_experiment(path) for path in specimen.experiments]
    from ..io import load_model
    from ..markers import markers_to_experiment, read_markers
    from ..plausibility import check_recording

    model = load_model(specimen.start)
    forces = specimen.forces or (None,) * len(specimen.markers)
    experiments = []
    for path, force in zip(specimen.markers, forces):
        markers = read_markers(path, units=specimen.options.get("units"))
        check_recording(markers, model.mesh, dt=specimen.options.get("dt"), model=model,
                        topology=str(specimen.start),
                        dt_option="dt" if specimen.options.get("dt") else None)
        experiments.append(markers_to_experiment(
            markers, model.mesh, dt=specimen.options.get("dt"), forces=force,
            node_mass=model.node_mass, source=str(path)).experiment)
    return experiments


def fit_quality(model, experiments, substeps: int = 1, *, lack_of_fit=None) -> dict:
    """How well ``model`` explains ``experiments``, against the markers' own noise: the lack
    of fit of every fit (:mod:`neurofuzzy.learn.lack_of_fit`) in the table's columns.

    Parameters
    ----------
    model : Model
        The fitted model.
    experiments : sequence of Experiment
    substeps : int
        Integration steps per frame with which ``model`` reproduces the data.
    lack_of_fit : LackOfFit, optional
        The fit's own (computed otherwise).

    Returns
    -------
    dict
        ``rms_error`` (m, per marker), ``noise_rms`` (m: ``σ√3``, what noise alone adds to a
        marker's 3-D RMS error), ``noise_ratio`` (``rms_error / noise_rms``: 1 means the fit
        explains everything but the noise; None for noise-free data), ``explained`` and
        ``verdict``.
    """
    from ..learn.lack_of_fit import model_lack_of_fit

    if lack_of_fit is None:
        lack_of_fit = model_lack_of_fit(model, experiments, substeps=substeps)
    ratio = lack_of_fit.ratio if lack_of_fit.noise > 0 else None
    return {"rms_error": lack_of_fit.rms, "noise_rms": lack_of_fit.noise, "noise_ratio": ratio,
            "explained": lack_of_fit.explained, "verdict": lack_of_fit.verdict}
