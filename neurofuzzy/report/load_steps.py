"""The report of a fit from load steps (:func:`load_steps_report`): the values and what the data
could not tell, the plate's force against its displacement (measured and fitted), the markers'
error at each step (fitted and held out) against the noise, and each scan's registration.
It draws the result object it is handed (a ``LoadStepFit``) and imports nothing of the
learners."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .html import figure_html, pyplot, table_html, write_report

__all__ = ["load_steps_report"]


def load_steps_report(start, fit, data, path, *, title: str = "neurofuzzy: load steps",
                      labels: dict | None = None) -> Path:
    """Write the report of ``fit`` (a ``LoadStepFit``) of ``data`` (``LoadSteps``) from the
    model ``start``: ``path`` (HTML) and its JSON twin. ``labels``: the words of the fitted
    values (quantity → word), none for what is not identifiable."""
    plt = pyplot()
    labels = labels or {}
    sections = [("Values", _values(start, fit, labels)),
                (f"The {'plate' if data.tool is None else data.tool.name}'s force",
                 _force(plt, fit, data))]
    if data.markers is not None:
        sections += [("Markers at each step", _markers(plt, fit, data)),
                     ("Registration of the scans", _registration(fit))]
    notes = "".join(f"<p class='note'>{html.escape(note)}</p>" for note in fit.notes_)
    sections.append(("Notes", notes))
    record = {"youngs_modulus": fit.youngs_modulus_, "poisson_ratio": fit.poisson_ratio_,
              "unidentifiable": list(fit.unidentifiable_),
              "standard_errors": fit.standard_errors_, "marker_rms_error": fit.marker_rms_,
              "marker_noise": fit.marker_noise_, "force_rms_error": fit.force_rms_,
              "validation": fit.validation_, "steps": data.n_steps,
              "predicted_force": fit.reactions_,
              "measured_force": data.reaction, "labels": labels,
              "intervals_hold": fit.intervals_hold,
              "mesh_check": None if fit.mesh_check_ is None else fit.mesh_check_.to_dict()}
    return write_report(path, title, sections, record)


def _values(start, fit, labels) -> str:
    rows = []
    before = {"youngs_modulus": float(np.mean(start.elements.youngs_modulus)),
              "poisson_ratio": float(np.mean(start.elements.poisson_ratio))}
    after = {"youngs_modulus": fit.youngs_modulus_, "poisson_ratio": fit.poisson_ratio_}
    for name in ("youngs_modulus", "poisson_ratio", "viscosity", "density"):
        if name in fit.fixed_:
            rows.append([name, before[name], after[name], "fixed", "-",
                         labels.get(name, "-")])
            continue
        if name in fit.unidentifiable_:
            rows.append([name, before.get(name, "-"), "not identifiable", "-", "-",
                         "(no word)"])
            continue
        half = fit.interval(name)
        ahead = fit.extrapolated(name)
        rows.append([name, before[name], after[name],
                     "-" if half is None else f"± {half:.3g}",
                     "-" if ahead is None else f"{ahead:.4g}", labels.get(name, "-")])
    held = f"<p class='note'>The 95 % intervals hold {html.escape(fit.intervals_hold)}.</p>"
    return table_html(["quantity", "start", "fitted", "95 % interval",
                       "extrapolated to a fine mesh", "word"], rows) + held


def _drive(data) -> tuple[np.ndarray, np.ndarray]:
    """The indenter's or the first driven set's displacement magnitude per step (m) and its
    direction."""
    if data.tool is not None:
        positions = np.asarray(data.tool.positions, float)
        displacement = positions[1:] - positions[0]
    else:
        displacement = np.asarray(data.driven[0].displacement, float)
    direction = displacement[-1] / max(np.linalg.norm(displacement[-1]), 1e-300)
    return displacement @ direction, direction


def _force(plt, fit, data) -> str:
    depth, direction = _drive(data)
    what = "plate" if data.tool is None else data.tool.name
    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    predicted = np.asarray(fit.reactions_) @ direction
    scale = "" if "youngs_modulus" not in fit.unidentifiable_ else (
        " (at the start E: the force's scale is not identified)")
    ax.plot(np.r_[0, depth] * 1e3, np.r_[0, predicted], "o-", label="fitted model" + scale)
    if data.reaction is not None:
        measured = np.asarray(data.reaction) @ direction
        ax.plot(np.r_[0, depth] * 1e3, np.r_[0, measured], "ks", label="load cell")
    ax.set_xlabel(f"{what} displacement (mm)")
    ax.set_ylabel(f"{what} force along its motion (N)")
    ax.legend(fontsize=8)
    text = ("" if data.reaction is not None else
            "<p class='note'>No force was measured: the curve is the model's prediction.</p>")
    return figure_html(figure, f"{what} force against displacement") + text


def _markers(plt, fit, data) -> str:
    scans = fit.registered_
    seen = np.isfinite(scans).all(axis=-1)
    rms = [float(np.sqrt(np.mean(np.sum((scans[k] - fit.markers_[k])[seen[k]] ** 2, axis=-1))))
           for k in range(data.n_steps)]
    steps = np.arange(1, data.n_steps + 1)
    held = [s not in fit.fitted_steps_ for s in steps]
    figure, ax = plt.subplots(figsize=(5.5, 3.2))
    ax.bar(steps, np.array(rms) * 1e6, color=["tab:orange" if h else "tab:blue" for h in held])
    ax.axhline(np.sqrt(3) * fit.marker_noise_ * 1e6, color="k", ls="--", lw=1,
               label="the noise (per marker)")
    ax.set_xlabel("load step (orange: held out)")
    ax.set_ylabel("RMS marker error (µm)")
    ax.set_xticks(steps)
    ax.legend(fontsize=8)
    rows = [[int(s), r * 1e6, "held out" if h else "fitted"] for s, r, h in zip(steps, rms, held)]
    return figure_html(figure, "marker error per load step") + table_html(
        ["step", "RMS per marker (µm)", ""], rows)


def _registration(fit) -> str:
    rows = []
    for k, transform in enumerate(fit.registration_, start=1):
        cosine = np.clip((np.trace(transform[:3, :3]) - 1) / 2, -1.0, 1.0)
        rows.append([k, float(np.degrees(np.arccos(cosine))),
                     float(np.linalg.norm(transform[:3, 3]) * 1e3)])
    return ("<p class='note'>Each scan moved onto the model's markers by a rigid transform "
            "before its error is taken.</p>"
            + table_html(["step", "rotation (°)", "translation (mm)"], rows))
