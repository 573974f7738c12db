"""The fit of a recording in time whose body a stage moved (a plate ramped, a tool pressed), as
``neurofuzzy fit`` runs it: :func:`fit_moving_file` (where it starts, the fit through implicit
steps, its mesh check, the record with materials and words) — the counterpart of
:func:`~neurofuzzy.pipeline.load_steps.fit_load_step_file` for time series."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import InputError
from .load_steps import LoadStepOutcome, load_step_start

__all__ = ["fit_moving_file", "moving_fit_report", "moving_diagnosis_report", "AUTO_TETRAHEDRA",
           "SCHEME"]

#: ``mesh_check="auto"`` refits on the refined mesh where it has at most this many
#: tetrahedra: a fit through implicit steps costs a run with its derivatives per evaluation
#: (121 frames of the plate ramp: 4.8 s on 384 tetrahedra, 29 s on 3,072), so the refined
#: fit costs some six times the fit
AUTO_TETRAHEDRA = 3_072
#: the implicit scheme of the fit: second order, so a step of the recording's frame period
#: follows the motion the frames resolve
SCHEME = "bdf2"


def fit_moving_file(path, *, start=None, rules=None,
                    tissue: str | None = None, law: str | None = None,
                    mesh_check: bool | str = "auto", substeps: int = 1,
                    progress: Callable[[str], None] | None = None) -> LoadStepOutcome:
    """Read the experiment file ``path`` (or take an ``Experiment``; driven sets or a tool, one
    row per frame, and perhaps a load cell), fit E, ν and η through BDF2 steps of ``dt /
    substeps`` (:func:`~neurofuzzy.learn.implicit_fit.fit_implicit`) from ``start`` or
    ``rules`` and ``tissue`` (:func:`~.load_steps.load_step_start`), run the mesh check
    (``"auto"``: where the refined mesh has at most :data:`AUTO_TETRAHEDRA` tetrahedra;
    ``"step"``: one iteration of the refit; ``"refit"``; False: none) and make the record ``fit
    --json`` prints."""
    from ..io import load_experiment
    from ..learn.implicit_fit import fit_implicit
    from ..learn.implicit_mesh_check import implicit_mesh_check
    from ..tissues import materials

    from ..experiment import Experiment

    experiment = path if isinstance(path, Experiment) else load_experiment(path)
    if not experiment.driven and experiment.tool is None:
        raise InputError("has no driven sets or tool: fit it with the time-series fit",
                         source=str(path), key="driven")
    model = load_step_start(experiment, start=start, rules=rules, tissue=tissue, law=law)
    say = progress or (lambda text: None)
    say(f"fit through {SCHEME} steps of {experiment.dt / substeps:.3g} s: "
        f"{model.mesh.n_tetrahedra} tetrahedra, {experiment.n_frames} frames")
    result = fit_implicit(model, experiment, substeps=substeps, scheme=SCHEME)
    skipped = None
    if mesh_check == "auto":
        refined = 8 * model.mesh.n_tetrahedra
        mesh_check = "refit" if refined <= AUTO_TETRAHEDRA else False
        if not mesh_check:
            skipped = (f"the mesh refined once would have {refined} tetrahedra, more than the "
                       f"{AUTO_TETRAHEDRA} checked by default (--mesh-check runs it)")
    if mesh_check:
        say("mesh check: the refit on the mesh refined once")
        result = implicit_mesh_check(result, experiment, substeps=substeps, scheme=SCHEME,
                                     max_evaluations=2 if mesh_check in (True, "step")
                                     else 40)
    found = materials(result.model, rules, tissue)
    value = {name: float(np.asarray(v)[0]) for name, v in result.values.items()}
    notes = []
    if experiment.reaction is None:
        notes.append("no load cell: E and the viscosity are told by the inertia of the "
                     "motion alone, through the density")
    if result.estimated:
        notes.append("the noise of " + " and ".join(result.estimated) + " was estimated from "
                     "the third differences in time of the fit's residuals (a smooth misfit "
                     "drops out of them; one as fast as the frames would not): compare it with "
                     "what the instruments are known to do")
    if result.at_bound:
        notes.append("ended at a bound of the search: " + ", ".join(result.at_bound))
    record = {"kind": "moving boundaries", **value,
              "unidentifiable": [], "rms_error": result.rms_error,
              "marker_rms_error": result.rms_error, "marker_noise": result.marker_noise,
              "force_rms_error": result.force_rms_error, "force_noise": result.force_noise,
              "noise_estimated": list(result.estimated), "evaluations": result.evaluations,
              "reason": result.reason, "scheme": SCHEME, "step": experiment.dt / substeps,
              "mesh_check": _check_record(result.mesh_check), "mesh_check_skipped": skipped,
              "materials": found, "notes": notes}
    return LoadStepOutcome(model, experiment, result, record, rules)


def moving_fit_report(outcome: LoadStepOutcome, path, *, substeps: int = 1,
                      title: str | None = None):
    """Write the report of :func:`fit_moving_file`'s ``outcome`` to ``path`` (HTML, and its
    JSON twin): the fitted model run through the recording as it was fitted (its steps,
    solved), drawn against the measurement (:func:`~neurofuzzy.report.moving.moving_report`).
    """
    from ..report.moving import moving_report

    data, fit, record = outcome.data, outcome.result, outcome.record
    run = _run(fit.model, data, substeps, record["scheme"])
    labels = next(iter(record["materials"].values()), {}).get("labels", {})
    return moving_report(outcome.start, fit, data, run, path, labels=labels,
                         notes=record["notes"], **({} if title is None else {"title": title}))


def moving_diagnosis_report(diagnosis, experiment, path, *, substeps: int = 1,
                            title: str | None = None):
    """Write the report of ``diagnosis`` (:func:`~neurofuzzy.diagnosis.moving.diagnose_moving`
    of ``experiment``) to ``path`` (HTML, and its JSON twin): the base fit's model run through
    the recording and the answer's through the recording as the answer changed it (a plate
    let slide, say), each as fitted (:func:`~neurofuzzy.report.moving.moving_diagnosis_report`).
    """
    from ..report.moving import moving_diagnosis_report as report

    return report(diagnosis, experiment,
                  _run(diagnosis.before.model, experiment, substeps, SCHEME),
                  _run(diagnosis.after.model, diagnosis.data, substeps, SCHEME), path,
                  **({} if title is None else {"title": title}))


def _run(model, data, substeps: int, scheme: str):
    """``model`` run through the recording ``data`` as its fit ran it (steps solved)."""
    from ..simulation.implicit import simulate_implicit

    return simulate_implicit(model, dt=data.dt, n_frames=data.n_frames,
                             external_forces=data.external_forces,
                             initial_positions=data.initial_positions(), substeps=substeps,
                             iterations=50, tolerance=1e-11, scheme=scheme,
                             driven=data.driven, tool=data.tool)


def _check_record(check: dict | None) -> dict | None:
    """The mesh check as plain numbers (the first group's)."""
    if check is None:
        return None
    out = {"elements": list(check["elements"]), "seconds": check["seconds"],
           "rms_refined": check["rms_refined"]}
    for name, stages in check.items():
        if isinstance(stages, dict):
            out[name] = {stage: float(np.asarray(v)[0]) for stage, v in stages.items()}
    return out
