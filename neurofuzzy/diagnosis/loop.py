"""The diagnosis loop: fit, analyse the residuals, score the candidates, add the winner, refit."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..serialization import json_safe
from ..effects import SoftInclusion, StiffInclusion
from ..experiment import Experiment, check_experiments, require_node_observations
from ..learn import GradientLearner
from ..model import SpringMassModel
from ..progress import note
from .candidates import propose_candidates
from .residuals import model_templates, residual_analysis
from .scoring import Candidate, confidence, initial_params, score_candidates

__all__ = ["diagnose", "Diagnosis", "Finding"]

#: A candidate must explain at least this fraction of the residual force above the noise…
MIN_EXPLAINED = 0.3
#: …with at least this much evidence (ΔBIC; 10 is "very strong" on Kass & Raftery's scale).
MIN_EVIDENCE = 10.0
#: …and refitting with it must shrink the gap above the noise floor at least this many times.
MIN_SHRINK = 1.5
#: Candidates refitted per round, best-scored first, until one passes the refit test: with
#: noisy accelerations the one-step scores can rank a wrong local effect above the global one.
MAX_REFITS = 3


@dataclass
class Finding:
    """An effect the diagnosis added to the model."""

    name: str
    confidence: float
    parameters: dict
    springs: list
    nodes: list
    rms_before: float
    rms_after: float
    gap_before: float
    gap_after: float
    runner_up: str
    candidates: list

    def to_dict(self) -> dict:
        out = {"name": self.name, "confidence": self.confidence, "parameters": self.parameters,
               "rms_before": self.rms_before, "rms_after": self.rms_after,
               "gap_before": self.gap_before, "gap_after": self.gap_after,
               "runner_up": self.runner_up}
        if self.springs:
            out["springs"] = self.springs
        if self.nodes:
            out["nodes"] = self.nodes
        return out


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    effects : list of Finding
        Effects found, in the order found (empty when the answer is ``none``).
    model_ : SpringMassModel
        The final model, with the effects, refitted.
    rms_before, rms_after : float
        RMS trajectory error of the fitted model without and with the effects.
    noise_rms : float
        RMS error that marker noise alone explains.
    candidates : list of Candidate
        The ranked candidates of the last round (the one that answered ``none``, or the last
        effect's round).
    rounds : list of dict
        Per round: the residuals, ranked candidates, and the RMS before and after.
    """

    effects: list
    model_: SpringMassModel
    rms_before: float
    rms_after: float
    noise_rms: float
    candidates: list
    rounds: list

    @property
    def names(self) -> list[str]:
        return [finding.name for finding in self.effects] or ["none"]

    def to_dict(self) -> dict:
        """JSON-ready summary (non-finite numbers become None)."""
        return json_safe({
            "effects": [f.to_dict() for f in self.effects], "answer": self.names,
            "rms_before": self.rms_before, "rms_after": self.rms_after,
            "noise_rms": self.noise_rms, "candidates": [c.to_dict() for c in self.candidates],
            "rounds": [{"candidates": [c.to_dict() for c in r["candidates"]], "rms": r["rms"],
                        "winner": r["winner"]} for r in self.rounds]})


def diagnose(model: SpringMassModel, experiments: Experiment | Sequence[Experiment], *,
             max_effects: int = 3, substeps: int | str = "auto",
             progress: bool = False) -> Diagnosis:
    """Find, name and add the effects the model lacks (see the module docstring).

    Parameters
    ----------
    model : SpringMassModel
        Start model (topology, tying, masses, start values); it is fitted first.
    experiments : Experiment or sequence of Experiment
    max_effects : int
        Stop after this many effects.
    substeps : int or "auto"
        As in :class:`~neurofuzzy.learn.GradientLearner`; ``"auto"`` decides afresh at every
        fit whether the data follow our discrete network or continuous physics (a model that
        lacks an effect fits neither exactly).
    progress : bool
        Report each round on stderr.
    """
    experiments = check_experiments(model, experiments)
    require_node_observations(experiments, "the diagnosis reads node accelerations from node "
                                           "trajectories (embedded markers are not yet supported)")

    def say(message):
        note(progress, message)

    fitted = GradientLearner(substeps=substeps).fit(model, experiments)
    current, rms, steps = fitted.model_, fitted.rms_error_, fitted.substeps_
    rms_start = rms
    say(f"diagnose: fitted the model as it is, RMS {rms:.3g}")
    findings, rounds = [], []
    ranked: list[Candidate] = []
    noise_rms = 0.0
    for _ in range(max_effects):
        residuals = residual_analysis(current, experiments, substeps=steps)
        samples = residuals.samples
        noise_rms = samples.marker_noise * np.sqrt(3.0)
        base = model_templates(current, samples)
        ranked = score_candidates(current, samples, base,
                                  propose_candidates(current, samples, base))
        winner = ranked[0] if ranked else None
        round_info = {"residuals": residuals, "candidates": ranked, "rms": rms, "winner": "none"}
        rounds.append(round_info)
        if winner is None or winner.score < MIN_EVIDENCE or winner.explained < MIN_EXPLAINED:
            say(f"diagnose: none (best {winner.name if winner else '-'}: explains "
                f"{winner.explained if winner else 0:.0%}, ΔBIC {winner.score if winner else 0:.3g})")
            break
        if not significant(rms, noise_rms, samples.force.size):
            say(f"diagnose: the error ({rms:.3g}) is what marker noise ({noise_rms:.3g}) "
                "explains; answering none")
            break
        gap_before = gap(rms, noise_rms)
        for rank, winner in enumerate(c for c in ranked[:MAX_REFITS]
                                      if c.score >= MIN_EVIDENCE
                                      and c.explained >= MIN_EXPLAINED):
            refit = _refit(winner, current, samples, base, experiments, substeps)
            gap_after = gap(refit.rms_error_, noise_rms)
            if gap_after * MIN_SHRINK <= gap_before:
                break
            say(f"diagnose: {winner.name} (ranked {rank + 1}) shrinks the gap only "
                f"{gap_before / max(gap_after, 1e-300):.2g}x when refitted")
        else:
            say("diagnose: no candidate shrinks the gap when refitted; answering none")
            break
        round_info["winner"] = winner.name
        added = refit.model_.effects[-1]
        others = [c for c in ranked if c is not winner]
        findings.append(Finding(
            name=winner.name, confidence=confidence([winner, *others]),
            parameters=dict(zip(added.labels, added.params.tolist())),
            springs=winner.springs, nodes=winner.nodes, rms_before=rms,
            rms_after=refit.rms_error_, gap_before=gap_before, gap_after=gap_after,
            runner_up=others[0].name if others else "none", candidates=ranked))
        say(f"diagnose: found {winner.name} (explains {winner.explained:.0%}); RMS "
            f"{rms:.3g} -> {refit.rms_error_:.3g}")
        current, rms, steps = refit.model_, refit.rms_error_, refit.substeps_
    return Diagnosis(effects=findings, model_=current, rms_before=rms_start, rms_after=rms,
                     noise_rms=noise_rms, candidates=ranked, rounds=rounds)


def _refit(candidate: Candidate, model, samples, base, experiments, substeps):
    """The model with the candidate's effect (started at its least-squares parameters),
    refitted; an inclusion's sign decides stiff or soft (the candidate is renamed)."""
    effect = candidate.effect.with_params(initial_params(candidate.effect, model, samples, base))
    if effect.name in ("stiff_inclusion", "soft_inclusion"):
        kind = StiffInclusion if np.mean(effect.params) > 0 else SoftInclusion
        effect = kind(effect.params, **effect.options)
        candidate.name = effect.name
    return GradientLearner(substeps=substeps).fit(model.with_effects(effect), experiments)


def significant(rms: float, noise_rms: float, n: int) -> bool:
    """Is the squared error above the noise by more than 5 sampling standard deviations?"""
    return rms**2 - noise_rms**2 > 5.0 * np.sqrt(2.0 / max(n, 1)) * noise_rms**2


def gap(rms: float, noise_rms: float) -> float:
    """RMS error above what marker noise explains."""
    return float(np.sqrt(max(rms**2 - noise_rms**2, 0.0)))
