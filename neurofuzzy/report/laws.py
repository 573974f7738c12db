"""The report's section on the elements' material law: the stress–strain curve each region's
fitted material stands for (uniaxial, free sides, from 35 % compression to 25 % stretch) under
its law, beside the other laws with the same E and ν (Yeoh's with the region's fitted
``C₂₀/C₁₀``, else the default); for elements that relax, the relaxation
modulus ``E G(t)`` of each region (:mod:`neurofuzzy.forces.relaxation`)."""

from __future__ import annotations

import numpy as np

from ..forces.laws import DEFAULT_STIFFENING, LAWS, STIFFENING_CONSTANT, uniaxial_stress
from .html import figure_html

__all__ = ["law_section"]

#: engineering strains of the curves: a probe's compression to a stretch
STRAINS = np.linspace(-0.35, 0.25, 61)


def law_section(plt, model) -> tuple[str, str] | None:
    """``(title, html)`` for an element model, None for a spring network."""
    if model.elements is None:
        return None
    figure, ax = plt.subplots(figsize=(6.5, 3.6))
    for r, name in enumerate(model.region_names):
        chosen = model.elements.region == r
        if not chosen.any():
            continue
        E = float(np.median(model.elements.youngs_modulus[chosen]))
        nu = float(np.median(model.elements.poisson_ratio[chosen]))
        laws = np.unique(model.elements.law[chosen])
        own = LAWS[int(laws[0])] if len(laws) == 1 else None
        stiffening = chosen & model.elements.stiffens
        fitted_c = float(np.median(model.elements.stiffening[stiffening])) \
            if stiffening.any() else DEFAULT_STIFFENING
        for number, law in enumerate(LAWS):
            fitted = law == own
            c = fitted_c if fitted else DEFAULT_STIFFENING       # another law's: its default
            curve = uniaxial_stress(law, E, nu, 1.0 + STRAINS, c)
            constant = STIFFENING_CONSTANT.get(number)
            style = "-" if fitted else (":" if constant else "--")
            ax.plot(100 * STRAINS, curve / 1e3, style, color=f"C{r % 10}",
                    label=f"{name}: {law}" + (f" ({constant} {c:.3g})" if constant else "")
                    + (" (fitted)" if fitted else ""))
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("engineering strain along the load (%)")
    ax.set_ylabel("nominal stress (kPa)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    text = (f"<p>Material law of the elements: {model.elements.law_names()}. The curves are the "
            "uniaxial stress of each region's fitted E and ν (the median of its elements) "
            "under its law (solid) and under the other laws (dashed; dotted for a law with a "
            "constant of its own, at the fitted value for the region's law, else at its "
            f"default {DEFAULT_STIFFENING:g}; same colour): the same slope at rest, apart "
            "under strong compression, where St. Venant–Kirchhoff softens (its curve turns "
            "back, or ends where it has no state with free sides), neo-Hookean stiffens, "
            "Yeoh stiffens more, by its C20/C10, and Mooney–Rivlin's C01/C10 makes it "
            "stiffer than neo-Hookean in compression and softer in tension.</p>")
    return "Material law", (text + figure_html(figure, "uniaxial stress-strain curves")
                            + _relaxation(plt, model))


def _relaxation(plt, model) -> str:
    """The relaxation modulus ``E (1 + Σᵢ gᵢ e^(-t/τᵢ))`` of each region over four of its
    longest times (medians over its elements), or "" when the elements do not relax."""
    if not model.n_relaxation_terms:
        return ""
    figure, ax = plt.subplots(figsize=(6.5, 3.2))
    longest = float(np.max(model.elements.relaxation_times[np.isfinite(
        model.elements.relaxation_times)], initial=1.0))
    t = np.linspace(0.0, 4.0 * longest, 200)
    for r, name in enumerate(model.region_names):
        chosen = model.elements.region == r
        if not chosen.any():
            continue
        E = float(np.median(model.elements.youngs_modulus[chosen]))
        g = np.median(model.elements.relaxation_moduli[chosen], axis=0)
        tau = np.median(model.elements.relaxation_times[chosen], axis=0)
        modulus = E * (1.0 + np.sum(g[:, None] * np.exp(-t[None, :] / tau[:, None]), axis=0))
        ax.plot(1e3 * t, modulus / 1e3, color=f"C{r % 10}",
                label=f"{name}: g {', '.join(f'{x:.3g}' for x in g)}, "
                      f"tau {', '.join(f'{1e3 * x:.3g} ms' for x in tau)}")
        ax.axhline(E / 1e3, color=f"C{r % 10}", ls=":", lw=0.8)
    ax.set_xlabel("time after a sudden strain (ms)")
    ax.set_ylabel("relaxation modulus E G(t) (kPa)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return ("<p>The elements relax (Prony series, FEBio's convention): after a sudden strain "
            "each region's stiffness falls from E (1 + Σ g) to its long-term E (dotted).</p>"
            + figure_html(figure, "relaxation modulus"))
