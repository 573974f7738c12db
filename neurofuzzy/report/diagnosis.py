"""The diagnosis report: the answer, where and when the residual lives, the candidates' scores,
the gap before and after each effect."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .fit import prior_section
from .html import figure_html, pyplot, table_html, write_report
from .lack_of_fit import lack_of_fit_section

__all__ = ["diagnosis_report"]


def _object_plot(ax, model, node_values, highlight_springs=(), highlight_nodes=(), label=""):
    """The object in 3-D: springs as lines, nodes coloured by ``node_values``."""
    positions = model.mesh.rest_positions
    for j, (a, b) in enumerate(model.mesh.springs):
        special = j in highlight_springs
        ax.plot(*positions[[a, b]].T, color="crimson" if special else "0.75",
                linewidth=2.2 if special else 0.6, zorder=2 if special else 1)
    scatter = ax.scatter(*positions.T, c=node_values, cmap="viridis", s=60, depthshade=False)
    for node in highlight_nodes:
        ax.scatter(*positions[node], s=220, facecolors="none", edgecolors="crimson",
                   linewidths=2)
    ax.set_title(label)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_zticks([])
    return scatter


def _where(finding) -> str:
    """Where a located effect acts (the report's summary table)."""
    parts = [f"{key} {values}" if len(values) <= 12 else f"{len(values)} {key}"
             for key in ("springs", "elements", "nodes") if (values := getattr(finding, key))]
    if finding.centroid is not None:
        parts.append("centroid (" + ", ".join(f"{1e3 * c:.1f}" for c in finding.centroid)
                     + ") mm")
    return "; ".join(parts)


def diagnosis_report(diagnosis, path, *, title: str = "neurofuzzy diagnosis") -> Path:
    """HTML + JSON report of a :class:`~neurofuzzy.diagnosis.Diagnosis`."""
    plt = pyplot()
    model = diagnosis.model_
    sections = []
    names = ", ".join(diagnosis.names)
    rows = [[f.name, f"{f.confidence:.3f}", f.runner_up,
             "; ".join(f"{k} = {v:.4g}" for k, v in f.parameters.items()), _where(f),
             f.rms_before, f.rms_after] for f in diagnosis.effects]
    summary = (f"<p>Answer: <b>{html.escape(names)}</b>: {html.escape(diagnosis.verdict)}."
               f"</p><p>RMS error per marker of the fitted model {diagnosis.rms_before * 1e6:.4g}"
               f" µm → {diagnosis.rms_after * 1e6:.4g} µm (marker noise alone: "
               f"{diagnosis.noise_rms * 1e6:.3g} µm).</p>")
    if rows:
        summary += table_html(["effect", "confidence", "runner-up", "parameters", "where",
                               "RMS before", "RMS after"], rows)
    sections.append(("Summary", summary))
    if diagnosis.lack_of_fit is not None:
        sections.append(lack_of_fit_section(plt, diagnosis.lack_of_fit,
                                            what="the final model"))

    first = diagnosis.rounds[0]["residuals"]
    forces = first.kind == "force"
    figure = plt.figure(figsize=(11, 4.6))
    ax = figure.add_subplot(1, 2, 1, projection="3d")
    springs = set(j for f in diagnosis.effects for j in f.springs)
    nodes = [n for f in diagnosis.effects for n in f.nodes]
    scatter = _object_plot(ax, model, first.per_node if forces else first.per_node * 1e6,
                           springs, nodes, "one-step residual force per node (N)" if forces
                           else "marker error per node (µm)")
    figure.colorbar(scatter, ax=ax, shrink=0.7)
    ax = figure.add_subplot(1, 2, 2, projection="3d")
    scatter = _object_plot(ax, model, first.per_node_error * 1e3, springs, nodes,
                           "trajectory error per node (mm)")
    figure.colorbar(scatter, ax=ax, shrink=0.7)
    marked = ("Red: springs and nodes of the effects found." if springs or nodes else
              "No effect found acts at a place, so nothing is marked.")
    sections.append(("Where: residual on the object (before any effect was added)",
                     figure_html(figure, "residual per node") +
                     f"<p class='note'>{marked}</p>"))

    figure, ax = plt.subplots(figsize=(9, 3.4))
    for index, round_info in enumerate(diagnosis.rounds):
        ax.semilogy(np.maximum(round_info["residuals"].per_frame, 1e-30),
                    label=f"round {index + 1}" + (f" (then added {round_info['winner']})"
                                                  if round_info["winner"] != "none" else ""))
        ax.axhline(round_info["residuals"].noise_floor, color="0.5", linestyle=":",
                   linewidth=0.8, label="noise floor" if index == 0 else None)
    ax.set_xlabel("frame")
    ax.set_ylabel("RMS residual force (N)" if forces else "RMS marker error (m)")
    ax.legend()
    sections.append(("When: residual over time", figure_html(figure, "residual over time") +
                     "<p class='note'>Dotted: the noise floor.</p>"))

    candidates = diagnosis.rounds[0]["candidates"]
    if candidates:
        figure, ax = plt.subplots(figsize=(9, 3.4))
        labels = [c.name + (f" @{c.nodes[0]}" if c.nodes else "") for c in candidates]
        scores = [max(c.score, 1e-3) for c in candidates]
        ax.barh(labels[::-1], scores[::-1], color="steelblue")
        ax.set_xscale("log")
        ax.set_xlabel("ΔBIC against the model alone (higher: better explanation)")
        table = table_html(["candidate", "ΔBIC", "explained"],
                           [[l, c.score, f"{c.explained:.0%}"] for l, c in zip(labels, candidates)])
        sections.append(("Which: candidate scores (first round)",
                         figure_html(figure, "candidate scores") + table))

    if diagnosis.localisation is not None:
        fitted = diagnosis.localisation.learner
        heading, text = prior_section(plt, fitted.model_, fitted.prior, fitted.regions_,
                                      fitted.prior_, {})
        covered = ", ".join(f"{share:.0%}" for share in diagnosis.localisation.overlap)
        sections.append((f"{heading}: the inclusion item by item",
                         "<p>Every element (or spring) of the start model fitted with the rule "
                         "base as a prior; share of the diagnosis's inclusion inside the "
                         f"regions found: {covered}.</p>" + text))

    stages = ["fitted model"] + [f"+ {f.name}" for f in diagnosis.effects]
    values = [diagnosis.rms_before] + [f.rms_after for f in diagnosis.effects]
    figure, ax = plt.subplots(figsize=(7, 3.2))
    # bars below a millionth of the largest are drawn at that floor (rounding, not physics)
    floor = 1e-6 * max(max(values), diagnosis.noise_rms, 1e-300)
    ax.bar(stages, np.maximum(values, floor), color="darkorange")
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor / 2)
    if diagnosis.noise_rms > floor:
        ax.axhline(diagnosis.noise_rms, color="0.4", linestyle=":", label="marker noise")
        ax.legend()
    ax.set_ylabel("RMS error per marker (m)")
    sections.append(("The gap before and after each added effect",
                     figure_html(figure, "error before and after")))
    sections.append(("Model equations", "<pre>" + html.escape(model.summary()) + "</pre>"))
    return write_report(path, title, sections, diagnosis.to_dict())
