"""The fit report: the expert's words before and after, the error curve, the learned
parameters, what the data determine, and where the tissue differs from its description."""

from __future__ import annotations

import html
import os
from pathlib import Path

import numpy as np

from ..constants import item_values
from ..formatting import length_text
from .html import figure_html, pyplot, table_html, write_report
from .lack_of_fit import lack_of_fit_section
from .laws import law_section
from .target import target_section

__all__ = ["fit_report", "identifiability_html", "prior_section"]


def identifiability_html(outcome) -> tuple[str, list]:
    """Standard errors and unidentifiable parameters in words, with a suggested load case
    (``outcome``: a :class:`~neurofuzzy.pipeline.FitOutcome`)."""
    identifiability = outcome.identifiability
    if identifiability is None:
        return "<p>The paper's learner does not estimate standard errors.</p>", []
    model = outcome.model
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
    text += _intervals_html(outcome)
    lack_of_fit = outcome.lack_of_fit
    if not lack_of_fit.explained:
        text += ("<p><b>But the model does not explain the data to the noise</b> ("
                 f"{html.escape(lack_of_fit.short)}): the values are what such a model sees, "
                 "biased by what it misses, and even these standard errors (the larger of the "
                 "plain and the cluster-robust estimate) understate how far they may be from "
                 "the tissue's. Run <code>neurofuzzy diagnose</code> to find what is "
                 "missing.</p>")
    return text, suggestions


def _intervals_html(outcome) -> str:
    """The 95 % intervals of an element model and what they hold (``intervals_hold``): the
    noise and the mesh (the move on the refined mesh, and how it was taken), or the noise
    alone and why (issue 48: a fit at the noise may still be biased by its mesh)."""
    bounds = outcome.intervals
    if not bounds or outcome.model.elements is None:
        return ""
    rows = [[name, f"{low:.4g} .. {high:.4g}"] for name, (low, high) in bounds.items()]
    text = table_html(["parameter", "95 % interval"], rows[:40])
    hold = html.escape(outcome.intervals_hold or "the noise alone")
    widened = ("; twice the move is added to the standard error in quadrature"
               if outcome.mesh_check is not None else "")
    return text + f"<p class='note'>These intervals hold {hold}{widened}.</p>"


def fit_report(outcome, path, *, title: str | None = None, files: dict | None = None) -> Path:
    """HTML + JSON report of a fit: ``outcome`` is what :func:`neurofuzzy.fit` returned (a
    :class:`~neurofuzzy.pipeline.FitOutcome`: its start, fitted model, history, lack of fit,
    identifiability and summary).

    With a rule base (``outcome.start.rules``; its file and checksum in the JSON's ``rules``),
    for every region with a tissue: the expert's words,
    the start and learned values, the learned words with degrees, each change highlighted, the
    input words that best reproduce the learned values, and the membership functions with the
    before and after values marked.
    Always: the error curve, the learned parameters and what the data cannot determine (with
    a suggested extra load case). ``files`` (label → path) are linked, relative to the report
    (e.g. the fitted model and the ParaView files of :func:`neurofuzzy.export.export_paraview`).
    From the summary: ``validation`` (:mod:`neurofuzzy.pipeline.validation`), the held-out
    data's prediction error beside the fitted one; ``target`` (``fit --target``'s record,
    :meth:`~neurofuzzy.learn.target.TargetFit.record`), the simulator's error beside the
    naive export's, and the values for it.
    """
    start, fitted = outcome.start, outcome.model
    validation = outcome.summary.get("validation")
    target = outcome.summary.get("target")
    plt = pyplot()
    sections, data = [], {}
    if start.rules is not None:
        regions = []
        for region, tissue in _tissues(start):
            words_sections, region_data = _words_sections(
                start.rules, region, tissue, start.model, fitted,
                masses_learned=outcome.learn_masses)
            sections += words_sections
            regions.append(region_data)
        data["regions"] = regions
        data["rules"] = start.rules.provenance()
    history = outcome.history
    figure, ax = plt.subplots(figsize=(8, 3.2))
    ax.semilogy(np.arange(1, len(history) + 1), np.maximum(history, 1e-30))
    ax.set_xlabel(outcome.cycle_name)
    ax.set_ylabel("E (eq. 2.2, mean spring lengths²)")
    ax.grid(True, which="both", alpha=0.3)
    sections.append(("Error per cycle", figure_html(figure, "error curve") +
                     f"<p>RMS error per marker {length_text(outcome.rms_error_initial)} → "
                     f"{length_text(outcome.rms_error)} in {outcome.n_cycles} cycles.</p>"))
    sections.append(lack_of_fit_section(plt, outcome.lack_of_fit))
    data["lack_of_fit"] = outcome.lack_of_fit.to_dict()
    if validation:
        what = (f"the frames from {validation['from_time']:g} s on"
                if "from_time" in validation else ", ".join(validation["experiments"]))
        times = (f" ({validation['times_noise']:.2f}× the noise)"
                 if "times_noise" in validation else "")
        sections.append(("Held-out data", html.escape(
            f"Kept out of the fit: {what}. The fitted model predicts them to an RMS of "
            f"{length_text(validation['rms_error'])} per marker{times}; it fits the rest to "
            f"{length_text(validation['fitted_rms_error'])}.").join(("<p>", "</p>"))))
        data["validation"] = validation
    if target:
        sections.append(target_section(plt, target))
        data["target"] = target
    sections.append(("Learned parameters", "<pre>" + html.escape(fitted.summary()) +
                     "</pre>"))
    law = law_section(plt, fitted)
    if law is not None:
        sections.append(law)
    if outcome.prior is not None:
        sections.append(prior_section(plt, fitted, outcome.prior, outcome.regions,
                                      outcome.prior_weight, data))
    text, suggestions = identifiability_html(outcome)
    sections.append(("What the data determine", text))
    data.update({"rms_error_initial": outcome.rms_error_initial,
                 "rms_error": outcome.rms_error, "history": history,
                 "cycles": outcome.n_cycles, "unidentifiable": suggestions})
    if outcome.identifiability is not None:
        data.update(outcome.identifiability.to_dict())
        data["unidentifiable"] = suggestions
    if outcome.intervals:
        data["intervals"] = {name: list(bounds) for name, bounds in outcome.intervals.items()}
        data["intervals_hold"] = outcome.intervals_hold
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
    named = f"neurofuzzy fit: {', '.join(tissues)}" if tissues else "neurofuzzy fit"
    return write_report(path, title or named, sections, data)


def prior_section(plt, model, prior, found, info, data) -> tuple[str, str]:
    """The regions found after a fit with the rule base as a prior: in words, and on the
    object (every element or spring of the fitted ``model`` coloured by its Young's modulus
    against the description of ``prior``, the regions ``found`` ringed; ``info``: the prior's
    weight, how it was chosen and the marker noise). ``data`` (the JSON twin) gets them."""
    data.update(prior=info, regions_found=found["regions"], regions_power=found.get("power"))
    kind, values = item_values(model)
    items = model.mesh.tetrahedra if kind == "elements" else model.mesh.springs
    centres = model.mesh.rest_positions[items].mean(axis=1)
    region = model.elements.region if kind == "elements" else model.springs.region
    centre = np.array([prior.sets[k]["youngs_modulus"].centre for k in region])
    figure = plt.figure(figsize=(6, 5))
    ax = figure.add_subplot(projection="3d")
    shown = ax.scatter(*centres.T, c=np.log10(values["youngs_modulus"]) - centre, cmap="coolwarm",
                       vmin=-1, vmax=1, s=12, depthshade=False)
    for entry in found["regions"]:
        ax.scatter(*centres[entry[kind]].T, s=70, facecolors="none", edgecolors="k")
    figure.colorbar(shown, ax=ax, shrink=0.6, label="log₁₀ (E / described E)")
    ax.set_title(f"{kind}: Young's modulus against the description")
    text = (f"<p>{html.escape(found['words'])}.</p><p>Prior weight α = "
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


def _words_sections(rules, region, tissue, start, fitted, *, masses_learned: bool):
    """Sections and JSON of one region: words, start and learned values, labels, plots (the
    density, when the masses were not learned, is the masses' and no finding of the fit)."""
    from ..tissues import material_values
    from ..tissues.values import DENSITY_NOT_LEARNED, LOCKED_POISSON_RATIO

    plt = pyplot()
    springs, nodes = start.region_springs(region), start.region_nodes(region)
    elements = start.region_elements(region)
    before = material_values(rules, start, springs, nodes, elements)
    after = material_values(rules, fitted, springs, nodes, elements)
    locked = []             # a spring network's ν = 1/4: neither described nor explained
    if start.elements is None:
        locked = [name for name in after if rules.outputs[name].quantity == "poisson_ratio"]
        before, after = ({k: v for k, v in values.items() if k not in locked}
                         for values in (before, after))
    labels_before = rules.describe(before)
    labels_after = rules.describe(after)
    # masses not learned: the density is theirs (the experiment's), shown but not explained
    given = [] if masses_learned else [name for name in after
                                       if rules.outputs[name].quantity == "density"]
    notes = {**{name: LOCKED_POISSON_RATIO for name in locked},
             **{name: DENSITY_NOT_LEARNED for name in given}}
    # the words that decide a learned quantity
    explained = rules.explain({k: v for k, v in after.items() if k not in given})
    words = {name: str(phrase) for name, phrase in rules.tissues[tissue].items()}
    where = f" ({html.escape(region)})" if len(start.region_names) > 1 else ""

    rows, changed, data_rows = [], [], []
    # the quantities the fitted model has (relaxation only when its elements relax)
    for name in (name for name in rules.outputs if name in labels_after):
        a = labels_after[name]
        b = labels_before.get(name, a)
        change = (f"{b.term} → {a.term} ({a.degree:.2f})" if a.term != b.term
                  else f"{a.term} ({a.degree:.2f})")
        unit = rules.outputs[name].unit
        rows.append([name, f"{b.value:.4g} {unit}", f"{a.value:.4g} {unit}", change,
                     ", ".join(f"{t} {d:.2f}" for t, d in sorted(a.degrees.items(),
                                                                 key=lambda kv: -kv[1]) if d > 0)])
        moved = a.term != b.term and name not in given
        changed.append(moved)
        data_rows.append({"quantity": name, "unit": unit, "before": b.value, "after": a.value,
                          "label_before": b.term, "degree_before": b.degree,
                          "label_after": a.term, "degree_after": a.degree,
                          "degrees_after": a.degrees, "changed": moved})
    sections = [("The expert's words" + where,
                 f"<p>Tissue <b>{html.escape(tissue)}</b> of <code>"
                 f"{html.escape(rules.source)}</code> (sha256 <code>"
                 f"{html.escape(str(rules.sha256))}</code>): " +
                 ", ".join(f"{html.escape(k)} is <b>{html.escape(v)}</b>"
                           for k, v in words.items()) + "</p>"),
                ("Start values, learned values, learned words" + where, table_html(
                    ["quantity", "start (from the words)", "learned", "label", "degrees"],
                    rows, changed) + "<p class='note'>Highlighted: the label changed." +
                 "".join(f" {html.escape(name)}: {html.escape(note)}."
                         for name, note in notes.items()) + "</p>"),
                ("The learned numbers in the expert's words" + where,
                 "<p>The input words that best reproduce the learned values: " +
                 ", ".join(f"{html.escape(k)} is <b>{html.escape(v)}</b>"
                           for k, v in explained["words"].items()) +
                 f" (distance {explained['distance']:.3f} universe spans).</p>")]
    shown = {name: variable for name, variable in rules.outputs.items() if name in after}
    figure, axes = plt.subplots(1, len(shown), figsize=(5 * len(shown), 3.4))
    for ax, (name, variable) in zip(np.atleast_1d(axes), shown.items()):
        x = variable.to_physical(variable.grid)
        for term in variable.terms.values():
            ax.plot(x, term.values, label=term.name)
        ax.axvline(after[name], color="crimson", linewidth=2, label="learned", zorder=3)
        ax.axvline(before.get(name, after[name]), color="0.2", linestyle="--", label="start",
                   zorder=4)
        if variable.scale == "log":
            ax.set_xscale("log")
        ax.set_title(f"{name} ({variable.unit})" if variable.unit else name)
        ax.set_ylim(0, 1.05)
        ax.set_ylabel("membership degree")
        ax.legend(fontsize=7)
    sections.append(("Membership functions with the start and learned values" + where,
                     figure_html(figure, "membership functions")))
    data = {"region": region, "tissue": tissue, "rules": rules.source, "words": words,
            "quantities": data_rows, "explained": explained,
            **({"notes": notes} if notes else {})}
    return sections, data
