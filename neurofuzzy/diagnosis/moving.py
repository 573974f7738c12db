"""What a model of a recording moved in time lacks (a plate ramped, a tool pressed):
:func:`diagnose_moving`.

The candidates are the load-step diagnosis's (:mod:`.load_steps`): ``plate_slip`` (a plate
taken as bonded that the specimen slid on), ``plate_bonding`` (the reverse) and
``hyperelasticity (LAW)`` (another material law). Each is refitted through the same implicit
steps as the base fit (:func:`~neurofuzzy.learn.implicit_fit.fit_implicit`, BDF2) and scored
by the fall of χ² with the base fit's noise, so the scores compare; one is named when its χ²
falls by more than :data:`~.load_steps.THRESHOLD` (none adds a parameter), the best added and
the others tried again on top of it, until none helps.

Without a load cell, the base fit's noise is the markers' RMS residual per coordinate: a
misfit the candidates remove still scores, against a noise that holds it too (a conservative
test).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..learn.implicit_fit import fit_implicit
from .load_steps import THRESHOLD, _law, name_effects

__all__ = ["MovingDiagnosis", "diagnose_moving"]

#: the implicit scheme of the refits: the fit's (:data:`neurofuzzy.pipeline.moving.SCHEME`)
SCHEME = "bdf2"


@dataclass(frozen=True)
class MovingDiagnosis:
    """The answer (``names``: the effects added, in order, or ``["none"]``), the fits before
    and after (``ImplicitFit``), the experiment as the answer changed it, and every
    candidate's score (``candidates``: name → χ² fall)."""

    names: list
    before: object
    after: object
    data: object
    candidates: dict

    def to_dict(self) -> dict:
        values = {name: float(np.asarray(value)[0]) for name, value in self.after.values.items()}
        return {"answer": self.names, "candidates": self.candidates,
                "rms_before": self.before.rms_error, "rms_after": self.after.rms_error,
                "force_rms_before": self.before.force_rms_error,
                "force_rms_after": self.after.force_rms_error, **values,
                "plate": (None if self.data.tool is not None or not self.data.driven
                          else self.data.driven[0].components),
                "law": _law(self.after.model), "law_before": _law(self.before.model),
                "threshold": THRESHOLD}

    def summary(self) -> str:
        values = self.to_dict()
        lines = [f"answer: {', '.join(self.names)}",
                 f"  the fit with it ({values['law']}): E {values['youngs_modulus']:.4g} Pa, "
                 f"nu {values['poisson_ratio']:.4f}, viscosity {values['viscosity']:.4g} Pa s",
                 f"  markers: RMS {self.before.rms_error * 1e6:.1f} -> "
                 f"{self.after.rms_error * 1e6:.1f} µm per marker"]
        if self.before.force_rms_error is not None:
            lines.append(f"  load cell: RMS {self.before.force_rms_error * 1e3:.3g} -> "
                         f"{self.after.force_rms_error * 1e3:.3g} mN")
        lines.append("  each candidate refitted; the fall of chi2 with the base fit's noise "
                     f"(named above {THRESHOLD:g}):")
        for name, fall in sorted(self.candidates.items(), key=lambda item: -item[1]):
            lines.append(f"  {name:<28} chi2 falls by {fall:.1f}")
        return "\n".join(lines)


def _chi2(fit, experiment, sigma_m: float, sigma_f: float | None) -> float:
    """The misfit of ``fit`` with fixed noise levels: its squared residuals (markers from
    frame 1 on, and the load cell's) over the noise's squares."""
    seen = int(experiment.observation.seen[1:].sum())
    total = fit.rms_error**2 * seen / sigma_m**2
    if fit.force_rms_error is not None and sigma_f:
        total += fit.force_rms_error**2 * 3 * (experiment.n_frames - 1) / sigma_f**2
    return float(total)


def diagnose_moving(model, experiment, *, substeps: int = 1, max_effects: int = 2,
                    progress: Callable[[str], None] | None = None) -> MovingDiagnosis:
    """Fit ``model`` to ``experiment`` (an ``Experiment`` with driven sets or a tool) through
    BDF2 steps of ``dt / substeps``, then name what the set-up's model lacks (module
    docstring)."""
    say = progress or (lambda message: None)

    def refit(candidate, data, **noise):
        return fit_implicit(candidate, data, substeps=substeps, scheme=SCHEME, **noise)

    say("diagnosis in time: the base fit")
    base = refit(model, experiment)
    sigma_m = base.marker_noise or max(base.rms_error / np.sqrt(3.0), 1e-300)
    sigma_f = base.force_noise
    names, best, best_data, scores = name_effects(
        base, experiment, lambda fit: fit.model,
        lambda candidate, data: refit(candidate, data, marker_noise=sigma_m,
                                      force_noise=sigma_f),
        lambda fit, data: _chi2(fit, data, sigma_m, sigma_f), max_effects, say)
    return MovingDiagnosis(names, base, best, best_data, scores)
