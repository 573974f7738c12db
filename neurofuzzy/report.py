"""Self-contained HTML reports (plots embedded as PNG) with a JSON twin.

:func:`write_report` writes ``report.html`` and ``report.json`` atomically; the builders
(:func:`diagnosis_report`, and :func:`fit_report` in :mod:`neurofuzzy.rules_report`) turn results
into sections. matplotlib is imported only inside the functions that plot.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
from pathlib import Path

import numpy as np

from .serialization import json_safe
from .serialization import atomic_write

__all__ = ["write_report", "figure_html", "table_html", "fit_report", "diagnosis_report"]

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; margin: 0.8em 0; } td, th { padding: 4px 10px; border: 1px solid #ddd; }
th { background: #f4f4f4; text-align: left; } .changed { background: #fff3c4; font-weight: 600; }
.note { color: #555; font-size: 0.92em; } img { max-width: 100%; }
"""


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_html(figure, alt: str) -> str:
    """Embed a matplotlib figure as a PNG data URI and close it."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    _pyplot().close(figure)
    encoded = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{encoded}">'


def table_html(header: list[str], rows: list[list], highlight: list[bool] | None = None) -> str:
    """An HTML table; rows flagged in ``highlight`` are marked as changed. Cells are text,
    except values with an ``__html__`` method, whose markup is used as it is."""
    out = ["<table><tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>"]
    for index, row in enumerate(rows):
        css = ' class="changed"' if highlight and highlight[index] else ""
        out.append(f"<tr{css}>" + "".join(f"<td>{_cell(c)}</td>" for c in row) + "</tr>")
    return "".join(out) + "</table>"


def _cell(value) -> str:
    """A cell's HTML: escaped text, or the markup of a value that has ``__html__`` (a link)."""
    return value.__html__() if hasattr(value, "__html__") else html.escape(_fmt(value))


def _fmt(value) -> str:
    if isinstance(value, (float, np.floating)):
        return f"{value:.4g}"
    return str(value)


#: the key of a report's JSON twin that says neurofuzzy wrote it (the command line replaces
#: an existing twin only if it has it)
REPORT_MARKER = "generator"


def write_report(path, title: str, sections: list[tuple[str, str]], data: dict) -> Path:
    """Write ``path`` (HTML) and its JSON twin (same name, ``.json``) atomically."""
    path = Path(path)
    data = {REPORT_MARKER: f"neurofuzzy report: {title}", **data}
    body = "".join(f"<h2>{html.escape(heading)}</h2>{content}" for heading, content in sections)
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{_STYLE}</style></head><body><h1>{html.escape(title)}</h1>"
            f"{body}</body></html>")
    twin = path.with_suffix(".json")
    with atomic_write(twin, "w") as handle:
        json.dump(json_safe(data), handle, indent=2)
    with atomic_write(path, "w") as handle:
        handle.write(page)
    return path


# -- diagnosis --------------------------------------------------------------------------------
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
    plt = _pyplot()
    model = diagnosis.model_
    sections = []
    names = ", ".join(diagnosis.names)
    rows = [[f.name, f"{f.confidence:.3f}", f.runner_up,
             "; ".join(f"{k} = {v:.4g}" for k, v in f.parameters.items()), _where(f),
             f.rms_before, f.rms_after] for f in diagnosis.effects]
    summary = (f"<p>Answer: <b>{html.escape(names)}</b>. RMS error of the fitted model "
               f"{diagnosis.rms_before:.4g} → {diagnosis.rms_after:.4g} (marker noise alone: "
               f"{diagnosis.noise_rms:.3g}).</p>")
    if rows:
        summary += table_html(["effect", "confidence", "runner-up", "parameters", "where",
                               "RMS before", "RMS after"], rows)
    sections.append(("Summary", summary))

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
    sections.append(("Where: residual on the object (before any effect was added)",
                     figure_html(figure, "residual per node") +
                     "<p class='note'>Red: springs and nodes of the effects found.</p>"))

    figure, ax = plt.subplots(figsize=(9, 3.4))
    for index, round_info in enumerate(diagnosis.rounds):
        ax.semilogy(np.maximum(round_info["residuals"].per_frame, 1e-30),
                    label=f"round {index + 1}" + (f" (then added {round_info['winner']})"
                                                  if round_info["winner"] != "none" else ""))
        ax.axhline(round_info["residuals"].noise_floor, color="0.5", linestyle=":",
                   linewidth=0.8)
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
        heading, text = _prior_section(plt, diagnosis.localisation.learner, {})
        covered = ", ".join(f"{share:.0%}" for share in diagnosis.localisation.overlap)
        sections.append((f"{heading}: the inclusion item by item",
                         "<p>Every element (or spring) of the start model fitted with the rule "
                         "base as a prior; share of the diagnosis's inclusion inside the "
                         f"regions found: {covered}.</p>" + text))

    stages = ["fitted model"] + [f"+ {f.name}" for f in diagnosis.effects]
    values = [diagnosis.rms_before] + [f.rms_after for f in diagnosis.effects]
    figure, ax = plt.subplots(figsize=(7, 3.2))
    ax.bar(stages, np.maximum(values, 1e-30), color="darkorange")
    ax.set_yscale("log")
    ax.axhline(max(diagnosis.noise_rms, 1e-30), color="0.4", linestyle=":", label="marker noise")
    ax.set_ylabel("RMS trajectory error")
    ax.legend()
    sections.append(("The gap before and after each added effect",
                     figure_html(figure, "error before and after")))
    sections.append(("Model equations", "<pre>" + html.escape(model.summary()) + "</pre>"))
    return write_report(path, title, sections, diagnosis.to_dict())


# -- fits: before and after, identifiability, words ---------------------------------------------
def identifiability_html(learner) -> tuple[str, list]:
    """Standard errors and unidentifiable parameters in words, with a suggested load case."""
    identifiability = getattr(learner, "identifiability_", None)
    if identifiability is None:
        return "<p>The paper's learner does not estimate standard errors.</p>", []
    model = learner.model_
    rows = [[name, f"{value:.3g}" if np.isfinite(value) else "undetermined"]
            for name, value in zip(identifiability.names, identifiability.std_errors)]
    text = table_html(["parameter", "standard error (relative)"], rows[:40])
    if len(rows) > 40:
        text += f"<p class='note'>… and {len(rows) - 40} more in the JSON twin.</p>"
    suggestions = []
    for entry in identifiability.unidentifiable:
        springs = entry["springs"]
        ends = [int(n) for j in springs for n in model.mesh.springs[j]
                if model.mesh.free[n]]
        if not ends:
            advice = ("no load case can: both ends of these springs are fixed. Free one end in "
                      "the experiment, or give them values from the rule base.")
        else:
            advice = (f"add a load case that pushes or pulls node {ends[0]} sideways (not "
                      "along the present load), so that these springs stretch by different "
                      "amounts.")
        suggestions.append({**entry, "suggestion": advice})
    if suggestions:
        items = "".join(f"<li><b>{html.escape(', '.join(e['parameters'][:6]))}"
                        f"{' …' if len(e['parameters']) > 6 else ''}</b>: "
                        f"{html.escape(e['why'])}. Suggestion: {html.escape(e['suggestion'])}"
                        "</li>" for e in suggestions)
        text += f"<p>What the data cannot determine:</p><ul>{items}</ul>"
    else:
        text += "<p>Every parameter is determined by the data.</p>"
    return text, suggestions


def fit_report(start, learner, path, *, title: str | None = None,
               files: dict | None = None) -> Path:
    """HTML + JSON report of a fit from ``start`` (a :class:`~neurofuzzy.learn.StartModel`).

    With a rule base (``start.rules``), for every region with a tissue: the expert's words,
    the start and learned values, the learned words with degrees, each change highlighted, the
    input words that best reproduce the learned values, and the membership functions with the
    before and after values marked.
    Always: the error curve, the learned parameters and what the data cannot determine (with
    a suggested extra load case). ``files`` (label → path) are linked, relative to the report
    (e.g. the fitted model and the ParaView files of :func:`neurofuzzy.export.export_paraview`).
    """
    plt = _pyplot()
    sections, data = [], {}
    if start.rules is not None:
        regions = []
        for region, tissue in _tissues(start):
            words_sections, region_data = _words_sections(start.rules, region, tissue,
                                                          start.model, learner.model_)
            sections += words_sections
            regions.append(region_data)
        data["regions"] = regions
    history = np.asarray(learner.history_)
    figure, ax = plt.subplots(figsize=(8, 3.2))
    ax.semilogy(np.arange(1, len(history) + 1), np.maximum(history, 1e-30))
    ax.set_xlabel(learner.cycle_name)
    ax.set_ylabel("E (eq. 2.2, mean spring lengths²)")
    ax.grid(True, which="both", alpha=0.3)
    sections.append(("Error per cycle", figure_html(figure, "error curve") +
                     f"<p>RMS error {learner.rms_error_initial_:.4g} → {learner.rms_error_:.4g}"
                     f" in {learner.n_cycles_} cycles.</p>"))
    sections.append(("Learned parameters", "<pre>" + html.escape(learner.model_.summary()) +
                     "</pre>"))
    if getattr(learner, "prior", None) is not None:
        sections.append(_prior_section(plt, learner, data))
    text, suggestions = identifiability_html(learner)
    sections.append(("What the data determine", text))
    data.update({"rms_error_initial": learner.rms_error_initial_,
                 "rms_error": learner.rms_error_, "history": history,
                 "cycles": learner.n_cycles_, "unidentifiable": suggestions})
    if getattr(learner, "identifiability_", None) is not None:
        data.update(learner.identifiability_.to_dict())
        data["unidentifiable"] = suggestions
    if files:
        links = {label: _relative(target, Path(path).parent) for label, target in files.items()}
        sections.append(("Files", "<ul>" + "".join(
            f'<li>{html.escape(label)}: <a href="{html.escape(link)}">{html.escape(link)}</a>'
            "</li>" for label, link in links.items()) + "</ul>"
            "<p>Open the <code>.pvd</code> in ParaView to play the simulated motion (arrays "
            "<code>measured</code>, <code>error</code>, <code>strain</code>, "
            "<code>stiffness</code> per frame); the <code>.xdmf</code> holds the same on the "
            "rest shape (apply Warp By Vector with <code>displacement_simulated</code>).</p>"))
        data["files"] = links
    tissues = sorted({tissue for _, tissue in _tissues(start)})
    return write_report(path, title or f"neurofuzzy fit{': ' + ', '.join(tissues) if tissues else ''}",
                        sections, data)


def _prior_section(plt, learner, data) -> tuple[str, str]:
    """The regions found after a fit with the rule base as a prior: in words, and on the
    object (every element or spring coloured by its Young's modulus against the
    description, the regions found ringed)."""
    from .learn.regions import describe_regions, item_values, regions_found

    found = regions_found(learner.model_, learner.prior)
    data.update(prior=learner.prior_, regions_found=found["regions"])
    model, prior = learner.model_, learner.prior
    kind, values = item_values(model)
    items = model.mesh.tetrahedra if kind == "elements" else model.mesh.springs
    centres = model.mesh.rest_positions[items].mean(axis=1)
    region = model.element_region if kind == "elements" else model.spring_region
    centre = np.array([prior.sets[k]["youngs_modulus"].centre for k in region])
    figure = plt.figure(figsize=(6, 5))
    ax = figure.add_subplot(projection="3d")
    shown = ax.scatter(*centres.T, c=np.log10(values["youngs_modulus"]) - centre, cmap="coolwarm",
                       vmin=-1, vmax=1, s=12, depthshade=False)
    for entry in found["regions"]:
        ax.scatter(*centres[entry[kind]].T, s=70, facecolors="none", edgecolors="k")
    figure.colorbar(shown, ax=ax, shrink=0.6, label="log₁₀ (E / described E)")
    ax.set_title(f"{kind}: Young's modulus against the description")
    info = learner.prior_
    text = (f"<p>{html.escape(describe_regions(found))}.</p><p>Prior weight α = "
            f"{info['alpha']:.3g} ({html.escape(info['how'])}; marker noise "
            f"{info['noise'] * 1e6:.3g} µm).</p>")
    return "Where the tissue differs from its description", text + figure_html(
        figure, "fitted Young's modulus per item against the description")


def _tissues(start) -> list[tuple[str, str]]:
    """(region, tissue) for every region of the start model that has a tissue."""
    model = start.model
    pairs = [(region, tissue or start.tissue)
             for region, tissue in zip(model.region_names, model.region_tissues)]
    return [(region, tissue) for region, tissue in pairs
            if tissue and tissue in start.rules.tissues]


def _relative(target, folder: Path) -> str:
    try:
        return Path(os.path.relpath(Path(target).resolve(), folder.resolve())).as_posix()
    except ValueError:          # another drive (Windows)
        return Path(target).resolve().as_posix()


def _words_sections(rules, region, tissue, start, fitted):
    """Sections and JSON of one region: words, start and learned values, labels, plots."""
    from .rules import material_values

    plt = _pyplot()
    springs, nodes = start.region_springs(region), start.region_nodes(region)
    elements = start.region_elements(region)
    before = material_values(rules, start, springs, nodes, elements)
    after = material_values(rules, fitted, springs, nodes, elements)
    labels_before = rules.describe(before)
    labels_after = rules.describe(after)
    explained = rules.explain(after)
    words = {name: str(phrase) for name, phrase in rules.tissues[tissue].items()}
    where = f" ({html.escape(region)})" if len(start.region_names) > 1 else ""

    rows, changed, data_rows = [], [], []
    for name in rules.outputs:
        b, a = labels_before[name], labels_after[name]
        change = (f"{b.term} → {a.term} ({a.degree:.2f})" if a.term != b.term
                  else f"{a.term} ({a.degree:.2f})")
        unit = rules.outputs[name].unit
        rows.append([name, f"{b.value:.4g} {unit}", f"{a.value:.4g} {unit}", change,
                     ", ".join(f"{t} {d:.2f}" for t, d in sorted(a.degrees.items(),
                                                                 key=lambda kv: -kv[1]) if d > 0)])
        changed.append(a.term != b.term)
        data_rows.append({"quantity": name, "unit": unit, "before": b.value, "after": a.value,
                          "label_before": b.term, "degree_before": b.degree,
                          "label_after": a.term, "degree_after": a.degree,
                          "degrees_after": a.degrees, "changed": a.term != b.term})
    sections = [("The expert's words" + where,
                 f"<p>Tissue <b>{html.escape(tissue)}</b> of <code>"
                 f"{html.escape(rules.source)}</code>: " +
                 ", ".join(f"{html.escape(k)} is <b>{html.escape(v)}</b>"
                           for k, v in words.items()) + "</p>"),
                ("Start values, learned values, learned words" + where, table_html(
                    ["quantity", "start (from the words)", "learned", "label", "degrees"],
                    rows, changed) + "<p class='note'>Highlighted: the label changed.</p>"),
                ("The learned numbers in the expert's words" + where,
                 "<p>The input words that best reproduce the learned values: " +
                 ", ".join(f"{html.escape(k)} is <b>{html.escape(v)}</b>"
                           for k, v in explained["words"].items()) +
                 f" (distance {explained['distance']:.3f} universe spans).</p>")]
    figure, axes = plt.subplots(1, len(rules.outputs), figsize=(5 * len(rules.outputs), 3.4))
    for ax, (name, variable) in zip(np.atleast_1d(axes), rules.outputs.items()):
        x = variable.to_physical(variable.grid)
        for term in variable.terms.values():
            ax.plot(x, term.values, label=term.name)
        ax.axvline(before[name], color="0.3", linestyle="--", label="start")
        ax.axvline(after[name], color="crimson", linewidth=2, label="learned")
        if variable.scale == "log":
            ax.set_xscale("log")
        ax.set_title(f"{name} ({variable.unit})" if variable.unit else name)
        ax.set_ylim(0, 1.05)
        ax.legend(fontsize=7)
    sections.append(("Membership functions with the start and learned values" + where,
                     figure_html(figure, "membership functions")))
    data = {"region": region, "tissue": tissue, "rules": rules.source, "words": words,
            "quantities": data_rows, "explained": explained}
    return sections, data
