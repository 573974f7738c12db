"""The report of a fit through implicit steps of a recording whose body a stage moved
(:func:`moving_report`): the values (start, fitted, extrapolated to a fine mesh, the words),
the load cell's force over time measured against the fitted model's, and the markers' error
per frame against the noise. It draws the fit it is handed (an ``ImplicitFit``) and the run
of its model, and imports nothing of the learners."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .answer import answer_label, answer_section
from .html import figure_html, pyplot, table_html, write_report

__all__ = ["moving_report", "moving_diagnosis_report"]

NAMES = {"youngs_modulus": "Pa", "poisson_ratio": "", "viscosity": "Pa·s"}


def moving_report(start, fit, experiment, run, path, *, labels: dict | None = None,
                  notes=(), title: str = "neurofuzzy: a plate moved in time") -> Path:
    """Write the report of ``fit`` (an ``ImplicitFit``) of ``experiment`` from the model
    ``start``, ``run`` the fitted model's trajectory (its ``reactions`` or ``tool_forces``):
    ``path`` (HTML) and its JSON twin."""
    plt = pyplot()
    labels = labels or {}
    times = experiment.dt * np.arange(experiment.n_frames)
    predicted, rms = _force_of(run, experiment), _marker_rms(run, experiment)
    sections = [("Values", _values(start, fit, labels)),
                ("The load cell's force", _force(plt, times, {"fitted model": predicted},
                                                 experiment)),
                ("Markers at each frame", _markers(plt, times, {"fitted model": rms},
                                                   fit.marker_noise)),
                ("Notes", "".join(f"<p class='note'>{html.escape(n)}</p>" for n in notes))]
    record = {**{name: float(np.asarray(fit.values[name])[0]) for name in NAMES},
              "times": times, "predicted_force": predicted,
              "measured_force": experiment.reaction, "marker_rms_per_frame": rms,
              "marker_rms_error": fit.rms_error, "marker_noise": fit.marker_noise,
              "force_rms_error": fit.force_rms_error, "force_noise": fit.force_noise,
              "labels": labels, "mesh_check": None if fit.mesh_check is None else {
                  name: {stage: float(np.asarray(v)[0]) for stage, v in stages.items()}
                  for name, stages in fit.mesh_check.items() if isinstance(stages, dict)}}
    return write_report(path, title, sections, record)


def moving_diagnosis_report(diagnosis, experiment, run_before, run_after, path, *,
                            title: str = "neurofuzzy: what the model of a moved recording "
                            "lacks") -> Path:
    """Write the report of ``diagnosis`` (a ``MovingDiagnosis``) of ``experiment`` (the
    recording as the lab gave it): the answer and every candidate's χ² fall, the values and
    misfits before and after, and the load cell's force and the markers' error over time of
    the base fit's model (``run_before``, run through ``experiment``) and the answer's
    (``run_after``, through the experiment as the answer changed it): ``path`` (HTML) and its
    JSON twin."""
    plt = pyplot()
    record = diagnosis.to_dict()
    times = experiment.dt * np.arange(experiment.n_frames)
    before, after = diagnosis.before, diagnosis.after
    answer = answer_label(diagnosis.names)
    forces = {"base fit": _force_of(run_before, experiment),
              answer: _force_of(run_after, diagnosis.data)}
    rms = {"base fit": _marker_rms(run_before, experiment),
           answer: _marker_rms(run_after, diagnosis.data)}
    sections = [("Answer", answer_section(plt, diagnosis.names, record)),
                ("Before and after", _before_after(before, after, record)),
                ("The load cell's force", _force(plt, times, forces, experiment)),
                ("Markers at each frame", _markers(plt, times, rms, before.marker_noise,
                                                   "the noise the candidates were scored "
                                                   "with (per marker)"))]
    record.update({"times": times, "measured_force": experiment.reaction,
                   "predicted_force_before": forces["base fit"],
                   "predicted_force_after": forces[answer],
                   "marker_rms_per_frame_before": rms["base fit"],
                   "marker_rms_per_frame_after": rms[answer]})
    return write_report(path, title, sections, record)


def _before_after(before, after, record) -> str:
    """The values and misfits of the base fit and of the fit with the answer."""
    rows = [[f"{name} ({unit})" if unit else name, float(np.asarray(before.values[name])[0]),
             float(np.asarray(after.values[name])[0])] for name, unit in NAMES.items()]
    rows.append(["law", record["law_before"], record["law"]])
    rows.append(["RMS marker error (µm)", 1e6 * before.rms_error, 1e6 * after.rms_error])
    if before.force_rms_error is not None:
        rows.append(["RMS load-cell error (mN)", 1e3 * before.force_rms_error,
                     1e3 * after.force_rms_error])
    return table_html(["quantity", "base fit", "with the answer"], rows)


def _force_of(run, experiment) -> np.ndarray:
    """The force a run's model puts on the tool, or on the first driven set (the plate)."""
    return run.tool_forces if experiment.tool is not None else run.reactions[:, 0]


def _marker_rms(run, experiment) -> np.ndarray:
    """The RMS error per frame of the markers a run's model puts where they were seen."""
    observation = experiment.observation
    error = np.sum(observation.residuals(run.positions) ** 2, axis=-1)
    seen = observation.seen
    return np.sqrt(np.divide(np.sum(np.where(seen, error, 0.0), axis=1), seen.sum(axis=1),
                             out=np.zeros(experiment.n_frames), where=seen.sum(axis=1) > 0))


def _values(start, fit, labels) -> str:
    rows = []
    for name, unit in NAMES.items():
        ahead = None if fit.mesh_check is None else fit.extrapolated(name)[0]
        rows.append([f"{name} ({unit})" if unit else name,
                     float(np.mean(getattr(start.elements, name))),
                     float(np.asarray(fit.values[name])[0]),
                     "-" if ahead is None else f"{ahead:.4g}", labels.get(name, "-")])
    check = ("<p class='note'>No mesh check ran: the values are the fitted mesh's.</p>"
             if fit.mesh_check is None else
             f"<p class='note'>Extrapolated from the fit on {fit.mesh_check['elements'][0]} "
             f"tetrahedra and its refit on {fit.mesh_check['elements'][1]} (Richardson, "
             "first order).</p>")
    return table_html(["quantity", "start", "fitted", "extrapolated to a fine mesh", "word"],
                      rows) + check


def _force(plt, times, predicted, experiment) -> str:
    """The load cell's force over time against each model's (``predicted``: label → (frames,
    3) forces), along the largest force's direction."""
    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    largest = max(predicted.values(), key=lambda f: np.abs(f).max())
    direction = np.asarray(largest)[np.argmax(np.linalg.norm(largest, axis=1))]
    direction = direction / max(np.linalg.norm(direction), 1e-300)
    for label, force in predicted.items():
        ax.plot(times * 1e3, np.asarray(force) @ direction, "-", label=label)
    if experiment.reaction is not None:
        ax.plot(times * 1e3, experiment.reaction @ direction, "k.", ms=3, label="load cell")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("force along its largest direction (N)")
    ax.legend(fontsize=8)
    text = ("" if experiment.reaction is not None else
            "<p class='note'>No force was measured: the curves are the models' predictions."
            "</p>")
    return figure_html(figure, "force over time") + text


def _markers(plt, times, rms, noise, noise_label="the noise (per marker)") -> str:
    """Each model's RMS marker error per frame (``rms``: label → (frames,)) against the
    noise per marker (``noise`` per coordinate, or None)."""
    figure, ax = plt.subplots(figsize=(5.5, 3.2))
    for label, values in rms.items():
        ax.plot(times[1:] * 1e3, values[1:] * 1e6, "-", label=label)
    if noise is not None:
        ax.axhline(np.sqrt(3) * noise * 1e6, color="k", ls="--", lw=1, label=noise_label)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("RMS marker error (µm)")
    ax.legend(fontsize=8)
    return figure_html(figure, "marker error per frame")
