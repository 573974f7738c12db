"""Score candidates against the residual force: regression on the model's own templates plus the
candidate's (sparse identification, as in SINDy), ranked by the Bayesian information criterion."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .residuals import Samples, templates

__all__ = ["INCLUSIONS", "Candidate", "score_candidates", "confidence", "initial_params",
           "significant", "gap", "nothing_left"]


#: The inclusions, stiff then soft: the diagnosis's effects that the regions found can
#: localise, named by the sign of their fitted extra stiffness.
INCLUSIONS = ("stiff_inclusion", "soft_inclusion")


@dataclass
class Candidate:
    """One effect scored against the residuals."""

    name: str
    score: float              # ΔBIC against the model alone (higher is better)
    explained: float          # fraction of the residual above the noise floor it removes
    effect: object = None     # the Effect to add (None for "none")
    springs: list = field(default_factory=list)
    nodes: list = field(default_factory=list)
    elements: list = field(default_factory=list)
    seeded: bool = False      # an inclusion given its region and sign by the per-item map

    def to_dict(self) -> dict:
        out = {"name": self.name, "score": self.score, "explained": self.explained,
               "springs": self.springs, "nodes": self.nodes}
        if self.elements:
            out["elements"] = self.elements
        if self.seeded:
            out["seeded"] = True
        return out


def score_candidates(model, samples: Samples, base: np.ndarray,
                     candidates) -> list[Candidate]:
    """Candidates ranked by ΔBIC against the model alone (best first), each with the fraction
    of the residual above the noise floor it explains."""
    target = samples.force.ravel()
    sigma2 = samples.noise_floor**2
    n = target.size
    rss_base = residual_sum_of_squares(base, target)
    excess = rss_base - n * sigma2        # what noise does not explain
    scored = []
    for effect in candidates:
        columns = templates(model, samples,
                             lambda p, v, e=effect: e.parameter_jacobian(model, p, v))
        rss = residual_sum_of_squares(np.concatenate([base, columns], axis=1), target)
        k = columns.shape[1]
        score = (rss_base - rss) / sigma2 - k * np.log(n)
        gain = rss_base - rss
        explained = gain / max(excess, gain) if gain > 0 else 0.0
        scored.append(Candidate(name=effect.name, score=float(score), explained=float(explained),
                                effect=effect, springs=[int(j) for j in effect.springs],
                                nodes=[int(i) for i in effect.nodes]))
    scored.sort(key=lambda c: -c.score)
    return scored


def residual_sum_of_squares(columns: np.ndarray, target: np.ndarray) -> float:
    norms = np.linalg.norm(columns, axis=0)
    usable = norms > 0
    if not usable.any():
        return float(target @ target)
    scaled = columns[:, usable] / norms[usable]
    solution, *_ = np.linalg.lstsq(scaled, target, rcond=None)
    residual = target - scaled @ solution
    return float(residual @ residual)


def confidence(ranked: list[Candidate]) -> float:
    """Posterior weight of the winner among the candidates and "none" (BIC weights)."""
    scores = np.array([c.score for c in ranked] + [0.0]) / 2.0
    scores -= scores.max()
    weights = np.exp(scores)
    return float(weights[0] / weights.sum())


def initial_params(effect, model, samples, base) -> np.ndarray:
    """Least-squares estimate of the effect's parameters together with the model templates."""
    columns = templates(model, samples, lambda p, v: effect.parameter_jacobian(model, p, v))
    both = np.concatenate([base, columns], axis=1)
    norms = np.linalg.norm(both, axis=0)
    norms[norms == 0] = 1.0
    solution, *_ = np.linalg.lstsq(both / norms, samples.force.ravel(), rcond=None)
    return (solution / norms)[base.shape[1]:]


def nothing_left(verdict, rms: float, n: int) -> bool:
    """Does the model explain the data to the noise with no significant excess (or noise-free
    data exactly, rounding left)? Then the answer is none, whatever a candidate scores."""
    exact = verdict.noise == 0
    return verdict.explained and (exact or not significant(rms, verdict.noise, n))


def significant(rms: float, noise_rms: float, n: int) -> bool:
    """Is the squared error above the noise by more than 5 sampling standard deviations?"""
    return rms**2 - noise_rms**2 > 5.0 * np.sqrt(2.0 / max(n, 1)) * noise_rms**2


def gap(rms: float, noise_rms: float) -> float:
    """RMS error above what marker noise explains."""
    return float(np.sqrt(max(rms**2 - noise_rms**2, 0.0)))
