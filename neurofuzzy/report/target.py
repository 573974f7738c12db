"""The report's section on a fit for a simulator's element and step (``fit --target``): the
markers' error of the model fitted for the simulator beside the naive export of the accurate
fit and our own model, and each region's values for the simulator beside the accurate ones."""

from __future__ import annotations

import html

import numpy as np

from .html import figure_html, table_html

__all__ = ["target_section"]

_NAMES = {"youngs_modulus": ("Young's modulus", "Pa"), "poisson_ratio": ("Poisson's ratio", ""),
          "viscosity": ("viscosity", "Pa·s")}


def target_section(plt, record: dict) -> tuple[str, str]:
    """(title, HTML) of a fit summary's ``target`` record
    (:meth:`~neurofuzzy.learn.target.TargetFit.record`)."""
    step = f"{1e3 * record['dt']:g} ms"
    simulator = record.get("name", record["simulator"])
    errors = [("fitted for the simulator", record["rms_error"]),
              ("the fit exported as it is", record["naive_rms_error"]),
              ("our model, our step", record["own_rms_error"])]
    figure, ax = plt.subplots(figsize=(7, 2.2))
    positions = np.arange(len(errors))[::-1]
    ax.barh(positions, [1e6 * value for _, value in errors],
            color=["tab:green", "tab:red", "tab:gray"])
    ax.set_yticks(positions, [label for label, _ in errors])
    ax.set_xlabel(f"RMS error per marker (µm), at the frames of a {step} step")
    ax.grid(True, axis="x", alpha=0.3)
    figure.tight_layout()
    ratio = record["naive_rms_error"] / max(record["rms_error"], 1e-300)
    text = (f"<p>The simulator steps at {step} with its <code>{html.escape(record['integrator'])}"
            "</code> integrator on its own element, so the values fitted with our step make it "
            "move differently from the tissue. Fitted for that element and step, the model "
            f"follows the markers to {1e6 * record['rms_error']:.1f} µm; the accurate fit "
            f"exported as it is, to {1e6 * record['naive_rms_error']:.1f} µm ({ratio:.2g}× "
            f"that); our own model at the same frames, to {1e6 * record['own_rms_error']:.1f} "
            "µm. The fitted model file holds the values for the simulator, and "
            + (f"<code>neurofuzzy simulate MODEL --integrator implicit --dt {record['dt']:g}"
               "</code> runs them." if record["simulator"] == "ours" else
               f"<code>neurofuzzy export --to {html.escape(record['simulator'])}</code> "
               "writes that step.") + "</p>")
    if record.get("at_bound"):
        text += ("<p class='note'>" + html.escape(", ".join(record["at_bound"])) + " ended at "
                 "the search's bound: at this step the integrator's own damping leaves it "
                 "untold.</p>")
    rows = []
    for region, values in record.get("values", {}).items():
        for key, (name, unit) in _NAMES.items():
            mine = values.get("target", {}).get(key)
            accurate = values.get("accurate", {}).get(key)
            change = (f"{100 * (mine / accurate - 1):+.1f} %" if mine is not None and accurate
                      else "")
            rows.append([region, f"{name}{f' ({unit})' if unit else ''}",
                         "" if accurate is None else f"{accurate:.4g}",
                         "" if mine is None else f"{mine:.4g}", change])
    if rows:
        text += table_html(["region", "parameter", "accurate fit", f"for {simulator} at {step}",
                            "change"], rows)
    return (f"For {simulator} at {step}",
            figure_html(figure, "marker error of the target fit, the naive export and our "
                        "model") + text)
