"""What a model of a compression test lacks, from its load steps: :func:`diagnose_load_steps`.

The fit from load steps (:func:`neurofuzzy.learn.load_step_fit.fit_load_steps`) leaves a
misfit; two things a lab's set-up often gets wrong are candidates, each refitted and scored
against the base fit with the noise the base fit estimated (so their costs compare):

- ``plate_slip``: the plate was taken as bonded, but the specimen slid on it (a lubricated or
  wet plate): the driven set held along the plate's motion only; ``plate_bonding`` the
  reverse;
- ``hyperelasticity``: another material law (neo-Hookean, Yeoh) in place of the model's:
  St. Venant–Kirchhoff softens under compression beyond about 20 %.

A candidate is named when it lowers the misfit's χ² by more than :data:`THRESHOLD` (none
adds a parameter, so this is the likelihood-ratio test at about 0.2 %); the best one is added
and the others tried again on top, until none helps; the answer is ``none`` when the first
round finds nothing.

Without a force measured (scans of a plate or of a tracked tool only), Young's modulus stays
unidentifiable in every refit: the answer gives ν and the law, and no value for E.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..forces.laws import LAW_RECORDS, LAWS
from ..learn.load_step_fit import fit_load_steps

__all__ = ["LoadStepDiagnosis", "diagnose_load_steps", "name_effects", "THRESHOLD"]

#: the fall of χ² a candidate must bring to be named (no candidate adds a parameter)
THRESHOLD = 10.0


@dataclass(frozen=True)
class LoadStepDiagnosis:
    """The answer (``names``: the effects added, in order, or ``["none"]``), the fits before
    and after, and every candidate's score (``candidates``: name → χ² fall)."""

    names: list
    before: object
    after: object
    data: object
    candidates: dict

    def to_dict(self) -> dict:
        return {"answer": self.names, "candidates": self.candidates,
                "rms_before": self.before.marker_rms_, "rms_after": self.after.marker_rms_,
                "noise": self.before.marker_scale,
                "youngs_modulus": (None if "youngs_modulus" in self.after.unidentifiable_
                                   else self.after.youngs_modulus_),
                "poisson_ratio": self.after.poisson_ratio_,
                "unidentifiable": list(self.after.unidentifiable_),
                "plate": (None if self.data.tool is not None or not self.data.driven
                          else self.data.driven[0].components),
                "law": _law(self.after.model_), "law_before": _law(self.before.model_),
                "threshold": THRESHOLD}

    def summary(self) -> str:
        lines = [f"answer: {', '.join(self.names)}",
                 f"  the fit with it ({_law(self.after.model_)}):", *self.after.value_lines(),
                 f"  markers: RMS {self.before.marker_rms_ * 1e6:.1f} -> "
                 f"{self.after.marker_rms_ * 1e6:.1f} µm per marker",
                 "  each candidate refitted; the fall of chi2 with the base fit's noise "
                 f"(named above {THRESHOLD:g}):"]
        for name, fall in sorted(self.candidates.items(), key=lambda item: -item[1]):
            lines.append(f"  {name:<28} chi2 falls by {fall:.1f}")
        return "\n".join(lines)


def _law(model) -> str:
    return LAWS[int(np.asarray(model.elements.law)[0])]


def _chi2(fit, data, sigma_m, sigma_f) -> float:
    """The misfit of ``fit`` with fixed noise levels (markers: registered, fitted steps)."""
    scans, model = fit.registered_, fit.markers_
    seen = np.isfinite(scans).all(axis=-1)
    total = 0.0 if not sigma_m else sum(
        float(np.sum((scans[s - 1] - model[s - 1])[seen[s - 1]] ** 2))
        for s in fit.fitted_steps_) / sigma_m**2
    if data.reaction is not None and sigma_f:
        rows = [s - 1 for s in fit.fitted_steps_]
        total += float(np.sum((np.asarray(data.reaction)[rows] - fit.reactions_[rows]) ** 2)
                       ) / sigma_f**2
    return total


def _candidates(model, data):
    """``(name, model, data)`` of every candidate change of the set-up."""
    out = []
    # with an indenter the driven sets hold the body (symmetry planes): no plate to slip
    path = data.driven[0] if data.driven and data.tool is None else None
    motion = np.zeros(3) if path is None else np.abs(np.asarray(path.displacement, float)[-1])
    axis = "xyz"[int(np.argmax(motion))]
    if path is None:
        pass
    elif path.components == "xyz":
        changed = replace(path, components=axis)
        out.append(("plate_slip", model, replace(data, driven=(changed, *data.driven[1:]))))
    elif len(path.components) < 3:
        changed = replace(path, components="xyz")
        out.append(("plate_bonding", model, replace(data, driven=(changed, *data.driven[1:]))))
    current = _law(model)
    for law in (record.name for record in LAW_RECORDS if record.switch):
        if law != current:
            out.append((f"hyperelasticity ({law})", model.with_elements(law=law), data))
    return out


def diagnose_load_steps(model, data, *, validate_on=(), max_effects: int = 2,
                        progress: Callable[[str], None] | None = None) -> LoadStepDiagnosis:
    """Fit ``model`` to ``data`` (``LoadSteps``), then name what the set-up's model lacks
    (module docstring)."""
    say = progress or (lambda message: None)
    say("diagnosis of load steps: the base fit")
    base = fit_load_steps(model, data, validate_on=validate_on)
    sigma_m, sigma_f = base.marker_noise_, base.force_noise_
    names, best, best_data, scores = name_effects(
        base, data, lambda fit: fit.model_,
        lambda candidate, candidate_data: fit_load_steps(
            candidate, candidate_data, validate_on=validate_on, marker_noise=sigma_m,
            force_noise=sigma_f),
        lambda fit, fitted: _chi2(fit, fitted, sigma_m, sigma_f), max_effects, say)
    return LoadStepDiagnosis(names, base, best, best_data, scores)


def name_effects(base, data, model_of, refit, chi2, max_effects: int, say):
    """The rounds of a diagnosis of the set-up (module docstring), for load steps and for
    recordings moved in time alike: ``(names or ["none"], the best fit, its data, every
    candidate's χ² fall)``, from the ``base`` fit of ``data``; ``model_of(fit)`` is a fit's
    model, ``refit(model, data)`` fits a candidate, ``chi2(fit, data)`` its misfit with the
    base fit's noise."""
    best, best_data, best_chi2 = base, data, chi2(base, data)
    names, scores, tried = [], {}, set()
    for _ in range(max_effects):
        round_best = None
        for name, candidate, candidate_data in _candidates(model_of(best), best_data):
            kind = name.split(" ")[0]
            if kind in tried:
                continue
            say(f"  refitting with {name}")
            fit = refit(candidate, candidate_data)
            fall = best_chi2 - chi2(fit, candidate_data)
            scores[name] = round(float(fall), 3)
            if fall > THRESHOLD and (round_best is None or fall > round_best[0]):
                round_best = (fall, name, fit, candidate_data)
        if round_best is None:
            break
        fall, name, best, best_data = round_best
        best_chi2 -= fall
        names.append(name)
        tried.add(name.split(" ")[0])
    return names or ["none"], best, best_data, scores
