"""The report of a fit from load steps (:func:`load_steps_report`): the values and what the data
could not tell, the plate's force against its displacement (measured and fitted), the markers'
error at each step (fitted and held out) against the noise, and each scan's registration.
It draws the result object it is handed (a ``LoadStepFit``) and imports nothing of the
learners."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .answer import answer_label, answer_section
from .html import figure_html, pyplot, table_html, write_report

__all__ = ["load_steps_report", "load_step_diagnosis_report"]


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


def load_step_diagnosis_report(diagnosis, data, path, *,
                               title: str = "neurofuzzy: what the model of the load steps "
                               "lacks") -> Path:
    """Write the report of ``diagnosis`` (a ``LoadStepDiagnosis``) of ``data`` (the load steps
    as the lab gave them): the answer and every candidate's χ² fall, the values and misfits
    of the base fit and of the fit with the answer, the force against the displacement and
    the markers' error at each step of both: ``path`` (HTML) and its JSON twin."""
    plt = pyplot()
    record = diagnosis.to_dict()
    before, after = diagnosis.before, diagnosis.after
    answer = answer_label(diagnosis.names)
    fits = {"base fit": before, answer: after}
    sections = [("Answer", answer_section(plt, diagnosis.names, record)),
                ("Before and after", _before_after(before, after, record)),
                (f"The {'plate' if data.tool is None else data.tool.name}'s force",
                 _forces(plt, fits, data))]
    if data.markers is not None:
        rms = {label: _step_rms(fit) for label, fit in fits.items()}
        sections.append(("Markers at each step", _step_bars(plt, rms, before.marker_noise_)))
        record.update({"marker_rms_per_step_before": rms["base fit"],
                       "marker_rms_per_step_after": rms[answer]})
    record.update({"measured_force": data.reaction, "predicted_force_before":
                   before.reactions_, "predicted_force_after": after.reactions_})
    return write_report(path, title, sections, record)


def _before_after(before, after, record) -> str:
    """The values and misfits of the base fit and of the fit with the answer."""
    def value(fit, name):
        return ("not identifiable" if name in fit.unidentifiable_ else
                float(getattr(fit, name + "_")))

    rows = [[name, value(before, name), value(after, name)]
            for name in ("youngs_modulus", "poisson_ratio")]
    rows.append(["law", record["law_before"], record["law"]])
    if before.marker_rms_ is not None:
        rows.append(["RMS marker error (µm)", 1e6 * before.marker_rms_,
                     1e6 * after.marker_rms_])
    if before.force_rms_ is not None:
        rows.append(["RMS load-cell error (N)", before.force_rms_, after.force_rms_])
    return table_html(["quantity", "base fit", "with the answer"], rows)


def _forces(plt, fits, data) -> str:
    """The force against the displacement of each fit (``fits``: label → fit) and of the
    load cell."""
    depth, direction = _drive(data)
    what = "plate" if data.tool is None else data.tool.name
    figure, ax = plt.subplots(figsize=(5.5, 3.6))
    for label, fit in fits.items():
        ax.plot(np.r_[0, depth] * 1e3, np.r_[0, np.asarray(fit.reactions_) @ direction], "o-",
                label=label)
    if data.reaction is not None:
        ax.plot(np.r_[0, depth] * 1e3, np.r_[0, np.asarray(data.reaction) @ direction], "ks",
                label="load cell")
    ax.set_xlabel(f"{what} displacement (mm)")
    ax.set_ylabel(f"{what} force along its motion (N)")
    ax.legend(fontsize=8)
    unknown = any("youngs_modulus" in fit.unidentifiable_ for fit in fits.values())
    text = ("" if not unknown else "<p class='note'>No force was measured: E is not "
            "identified, and the curves are at the start's E (their shape is the finding, not "
            "their scale).</p>")
    return figure_html(figure, f"{what} force against displacement") + text


def _step_rms(fit) -> np.ndarray:
    """A fit's RMS marker error per load step, each scan registered."""
    scans = fit.registered_
    seen = np.isfinite(scans).all(axis=-1)
    return np.array([np.sqrt(np.mean(np.sum((scans[k] - fit.markers_[k])[seen[k]] ** 2,
                                            axis=-1))) for k in range(len(scans))])


def _step_bars(plt, rms, noise) -> str:
    """Each fit's RMS marker error per step (``rms``: label → per step) side by side."""
    figure, ax = plt.subplots(figsize=(5.5, 3.2))
    width = 0.8 / len(rms)
    for index, (label, values) in enumerate(rms.items()):
        steps = np.arange(1, len(values) + 1)
        ax.bar(steps + (index - (len(rms) - 1) / 2) * width, values * 1e6, width, label=label)
    ax.axhline(np.sqrt(3) * noise * 1e6, color="k", ls="--", lw=1,
               label="the noise the candidates were scored with (per marker)")
    ax.set_xlabel("load step")
    ax.set_ylabel("RMS marker error (µm)")
    ax.set_xticks(steps)
    ax.legend(fontsize=8)
    return figure_html(figure, "marker error per load step")


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
    rms = _step_rms(fit)
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
