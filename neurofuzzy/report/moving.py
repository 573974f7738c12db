"""The report of a fit through implicit steps of a recording whose body a stage moved
(:func:`moving_report`): the values (start, fitted, extrapolated to a fine mesh, the words),
the load cell's force over time measured against the fitted model's, and the markers' error
per frame against the noise. It draws the fit it is handed (an ``ImplicitFit``) and the run
of its model, and imports nothing of the learners."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .html import figure_html, pyplot, table_html, write_report

__all__ = ["moving_report"]

NAMES = {"youngs_modulus": "Pa", "poisson_ratio": "", "viscosity": "Pa·s"}


def moving_report(start, fit, experiment, run, path, *, labels: dict | None = None,
                  notes=(), title: str = "neurofuzzy: a plate moved in time") -> Path:
    """Write the report of ``fit`` (an ``ImplicitFit``) of ``experiment`` from the model
    ``start``, ``run`` the fitted model's trajectory (its ``reactions`` or ``tool_forces``):
    ``path`` (HTML) and its JSON twin."""
    plt = pyplot()
    labels = labels or {}
    times = experiment.dt * np.arange(experiment.n_frames)
    predicted = run.tool_forces if experiment.tool is not None else run.reactions[:, 0]
    observation = experiment.observation
    error = np.sum(observation.residuals(run.positions) ** 2, axis=-1)
    seen = observation.seen
    rms = np.sqrt(np.divide(np.sum(np.where(seen, error, 0.0), axis=1), seen.sum(axis=1),
                            out=np.zeros(len(times)), where=seen.sum(axis=1) > 0))
    sections = [("Values", _values(start, fit, labels)),
                ("The load cell's force", _force(plt, times, predicted, experiment)),
                ("Markers at each frame", _markers(plt, times, rms, fit)),
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
    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    direction = np.asarray(predicted)[np.argmax(np.linalg.norm(predicted, axis=1))]
    direction = direction / max(np.linalg.norm(direction), 1e-300)
    ax.plot(times * 1e3, np.asarray(predicted) @ direction, "-", label="fitted model")
    if experiment.reaction is not None:
        ax.plot(times * 1e3, experiment.reaction @ direction, "k.", ms=3, label="load cell")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("force along its largest direction (N)")
    ax.legend(fontsize=8)
    text = ("" if experiment.reaction is not None else
            "<p class='note'>No force was measured: the curve is the model's prediction.</p>")
    return figure_html(figure, "force over time") + text


def _markers(plt, times, rms, fit) -> str:
    figure, ax = plt.subplots(figsize=(5.5, 3.2))
    ax.plot(times[1:] * 1e3, rms[1:] * 1e6, "-", label="fitted model")
    if fit.marker_noise is not None:
        ax.axhline(np.sqrt(3) * fit.marker_noise * 1e6, color="k", ls="--", lw=1,
                   label="the noise (per marker)")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("RMS marker error (µm)")
    ax.legend(fontsize=8)
    return figure_html(figure, "marker error per frame")
