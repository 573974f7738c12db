"""The lack of fit in a report: the verdict, where the misfit lives (every marker at rest,
coloured by its RMS error) and when (the RMS error per frame against the marker noise)."""

from __future__ import annotations

import html

import numpy as np

from .html import figure_html

__all__ = ["lack_of_fit_section"]


def lack_of_fit_section(plt, lack_of_fit, *, what: str = "the fitted model") -> tuple[str, str]:
    """``(heading, html)`` of a :class:`~neurofuzzy.learn.lack_of_fit.LackOfFit`."""
    text = (f"<p><b>{html.escape(lack_of_fit.verdict)}</b>.</p><p class='note'>RMS error per "
            "marker: the root mean square of the 3-D distance between simulated and measured "
            "marker positions over every measured frame (per coordinate it is 1/√3 of it). "
            f"Marker noise per marker: √3 σ, σ estimated from {html.escape(lack_of_fit.noise_how)}"
            f". Up to {lack_of_fit.explained_up_to}× the noise, a model explains the data.</p>")
    if not lack_of_fit.per_frame:
        return f"Lack of fit of {what}", text
    figure = plt.figure(figsize=(11, 4.2))
    where = figure.add_subplot(1, 2, 1, projection="3d")
    points = np.concatenate(lack_of_fit.marker_positions) * 1e3
    errors = np.concatenate(lack_of_fit.per_marker) * 1e6
    shown = where.scatter(*points.T, c=errors, cmap="magma_r", s=28, depthshade=False,
                          vmin=0.0)
    figure.colorbar(shown, ax=where, shrink=0.65, pad=0.14, label="RMS error per marker (µm)")
    where.set_xlabel("x (mm)")
    where.set_ylabel("y (mm)")
    where.set_zlabel("z (mm)")
    where.set_title("where: every marker at rest")
    when = figure.add_subplot(1, 2, 2)
    for index, (time, rms) in enumerate(zip(lack_of_fit.times, lack_of_fit.per_frame)):
        label = f"experiment {index + 1}" if len(lack_of_fit.times) > 1 else "RMS error"
        when.plot(time * 1e3, rms * 1e6, label=label, linewidth=1.2)
    if lack_of_fit.noise > 0:
        when.axhline(lack_of_fit.noise * 1e6, color="0.35", linestyle="--",
                     label=f"marker noise ({lack_of_fit.noise * 1e6:.3g} µm)")
    when.set_xlabel("time (ms)")
    when.set_ylabel("RMS error per marker (µm)")
    when.set_ylim(bottom=0)
    when.set_title("when: every frame")
    when.legend(fontsize=8)
    return (f"Lack of fit of {what}",
            text + figure_html(figure, "RMS error per marker and per frame"))
