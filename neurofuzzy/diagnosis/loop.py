"""The diagnosis loop: fit, analyse the residuals, score the candidates, add the winner, refit."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np

from ..experiment import Experiment, check_experiments
from ..formatting import length_text
from ..model import Model
from ..progress import note
from .candidates import Evidence, propose_candidates
from .clock import Clock
from .localise import INCLUSIONS, localise, seeded
from .refits import (MIN_SHRINK, confirm, fitted, refit_with_starts, switches, to_refit,
                     tolerance)
from .result import Diagnosis, Finding, mesh_share, where
from .scoring import Candidate, confidence, gap, nothing_left
from .trajectory import TrajectoryEvidence
from .window import first_frames, on_all_frames, span, window_frames

__all__ = ["diagnose", "Diagnosis", "Finding"]

def diagnose(model: Model, experiments: Experiment | Sequence[Experiment], *,
             max_effects: int = 3, substeps: int | str = "auto", prior=None,
             mesh_check: bool = True, max_time: float | None = None,
             window: int | str | None = "auto", progress: bool = False) -> Diagnosis:
    """Find, name and add the effects the model lacks (see the module docstring).

    Parameters
    ----------
    model : Model
        Start model (topology, tying, masses, start values); it is fitted first.
    experiments : Experiment or sequence of Experiment
    max_effects : int
        Stop after this many effects.
    substeps : int or "auto"
        As in :class:`~neurofuzzy.pipeline.FitOptions`; ``"auto"`` decides afresh at every
        fit whether the data follow our discrete network or continuous physics (a model that
        lacks an effect fits neither exactly).
    prior : FuzzyPrior, optional
        The rule base as a prior (:class:`~neurofuzzy.learn.prior.FuzzyPrior` of ``model``):
        once an inclusion is a candidate to refit, every element (or spring) of ``model``
        (with the effects found so far) is fitted with it, and the region found under the
        inclusion gives it its sign and is refitted beside it, or drops it when the regions
        hold none of other stiffness
        (:func:`~neurofuzzy.diagnosis.localise.seeded`); they locate an inclusion found item
        by item (``localisation``). Costs one per-item fit with the prior's weight search.
    mesh_check : bool
        When the final element model still misses the data, refit it on its mesh refined
        once to say how much of the misfit is the mesh's (``mesh``; a fit of about 16 times
        the work).
    max_time : float, optional
        Seconds of wall time: once they are spent, no further fit starts and the best answer
        so far is returned, marked :attr:`Diagnosis.provisional` (checked between fits, so
        the answer comes at most one fit late; the first fit always runs).
    window : "auto", "all", None or int
        Frames of motion (after the load's onset) to diagnose a long recording on, its
        answer then fitted on all frames (:mod:`.window`): ``"auto"`` the first
        :data:`~.window.WINDOW` of recordings in trajectory space with more than
        :data:`~.window.LONG` times as many; ``"all"`` or None: every frame.
    progress : bool
        Report each round on stderr, each refit with an estimate of the round's time left.
    """
    experiments = check_experiments(model, experiments)
    # one-step residual forces need measured nodes; element models and embedded markers are
    # diagnosed from the free-run marker error (trajectory space)
    in_trajectory_space = model.elements is not None or any(e.markers is not None
                                                     for e in experiments)
    clock = Clock(max_time)
    frames = window_frames(experiments, window)
    options = {"max_effects": max_effects, "substeps": substeps, "prior": prior,
               "mesh_check": mesh_check, "progress": progress}
    if frames is None or not in_trajectory_space:
        return _rounds(model, experiments, clock, in_trajectory_space, **options)
    shown, total = span(experiments, frames)
    note(progress, f"diagnose: {total} frames; diagnosing the first {shown} ({frames} of "
         "motion), then fitting the answer on all")
    found = _rounds(model, first_frames(experiments, frames), clock, True, **options,
                    confirm_winner=False)
    return on_all_frames(found, experiments, frames, substeps, clock,
                         lambda line: note(progress, line),
                         lambda: _rounds(model, experiments, clock, True, **options))


def _rounds(model, experiments, clock, in_trajectory_space, *, max_effects, substeps, prior,
            mesh_check, progress, confirm_winner=True) -> Diagnosis:
    """The diagnosis's rounds on ``experiments`` (checked), timed by ``clock``; a winner's
    fit confirmed at two steps unless ``confirm_winner`` is False (a window's answer, which
    is fitted and confirmed on all frames after)."""

    def say(message):
        note(progress, message)

    as_it_is = clock.timed(lambda: fitted(model, experiments, substeps=substeps,
                                          **tolerance(in_trajectory_space)))
    current, rms, steps = as_it_is.model_, as_it_is.rms_error_, as_it_is.substeps_
    rms_start, verdict = rms, as_it_is.lack_of_fit_
    say(f"diagnose: fitted the model as it is, {verdict.short}")
    findings, rounds = [], []
    ranked: list[Candidate] = []
    located = None        # the per-item map with the prior, made once an inclusion is a candidate
    mapped_with = 0       # ... with this many of the effects found
    for _ in range(max_effects):
        noise_rms = verdict.noise
        evidence = (TrajectoryEvidence.of(current, experiments, steps,
                                          verdict.noise_per_coordinate, verdict.explained)
                    if in_trajectory_space else Evidence.of(current, experiments, steps))
        if in_trajectory_space and nothing_left(verdict, rms, evidence.size):
            # the answer is none whatever the candidates score: their evidence (a scan of
            # inclusion balls, the material switches) is most of a diagnosis's time
            say(f"diagnose: none ({verdict.short}; nothing left to explain, so no candidate "
                "scored)")
            rounds.append({"residuals": evidence.residuals(), "candidates": [], "rms": rms,
                           "winner": "none"})
            break
        candidates = propose_candidates(current, evidence)
        kinds = Counter(c.name for c in candidates)       # an inclusion: several regions
        say(f"diagnose: scoring {len(candidates)} candidates of {len(kinds)} effects (" +
            ", ".join(f"{name}{f' x{n}' if n > 1 else ''}" for name, n in sorted(kinds.items()))
            + ")")
        ranked = evidence.score(candidates)
        round_info = {"residuals": evidence.residuals(), "candidates": ranked, "rms": rms,
                      "winner": "none"}
        rounds.append(round_info)
        tried = to_refit(ranked, evidence, verdict, rms, say)
        if prior is not None and any(c.name in INCLUSIONS for c in tried):
            if located is None or mapped_with != len(current.effects):
                # made again once an effect was found: the map fitted what it now explains
                say("diagnose: an inclusion is a candidate; fitting every "
                    f"{'spring' if model.elements is None else 'element'} with the rule base "
                    "as a prior, to give it the region and sign of the map")
                # from the start model's values (with the effects found so far), as the
                # localisation always started: from the homogeneous fit's, the 5x inclusion
                # of tests/test_lack_of_fit_continuum.py came out as 9 elements 5.2 mm off
                located = localise(model.with_effects(*current.effects), experiments, prior,
                                   substeps=substeps, progress=progress)
                mapped_with = len(current.effects)
                say(f"diagnose: {located.words}")
            tried, words = seeded(tried, located, current, evidence)
            for line in words:
                say(f"diagnose: {line}")
            ranked = sorted([c for c in ranked if c.name not in INCLUSIONS]
                            + [c for c in tried if c.seeded], key=lambda c: -c.score)
            round_info["candidates"] = ranked
        if not tried:
            break
        gap_before = gap(rms, noise_rms)
        refits, leader = [], np.inf     # leader: the best refit's RMS so far
        for order, candidate in enumerate(tried):
            # its place by score (the refits go material switches first: to_refit)
            rank = next((i for i, c in enumerate(ranked) if c is candidate), order)
            if clock.out():
                clock.left_out(f"{len(tried) - order} of {len(tried)} candidates of round "
                               f"{len(rounds)} not refitted")
                break
            say(f"diagnose: refitting {candidate.name} ({order + 1} of {len(tried)}; "
                f"{clock.estimate(len(tried) - order)})")
            refit = refit_with_starts(candidate, current, model.with_effects(*current.effects),
                                      evidence, experiments, substeps, in_trajectory_space,
                                      clock, leader=leader, noise_rms=noise_rms,
                                      gap_before=gap_before)
            gap_after = gap(refit.rms_error_, noise_rms)
            say(f"diagnose: {candidate.name} (ranked {rank + 1}), refitted: " +
                (f"shrinks the gap {gap_before / gap_after:.2g}x" if gap_after > 0 else
                 "down to the noise") +
                (f" (given up: it cannot come below {length_text(leader)}, the best refit "
                 "so far)" if refit.abandoned_ else ""))
            leader = min(leader, refit.rms_error_)
            refits.append((gap_after, rank, candidate, refit))
            if (nothing_left(refit.lack_of_fit_, refit.rms_error_, evidence.size)
                    and order + 1 < len(tried)):
                # at the noise, nothing significant left: a candidate refitted later could
                # only tie within the noise (merely "explained" is not enough: a model at
                # the noise with a significant excess refits its candidates to compare them)
                say(f"diagnose: {candidate.name} explains the data to the noise; the "
                    f"{len(tried) - order - 1} candidate(s) after it are not refitted")
                break
        if not refits:
            break
        gap_after, _, winner, refit = min(refits, key=lambda entry: entry[:2])
        if gap_after * MIN_SHRINK > gap_before:
            say("diagnose: no candidate shrinks the gap enough when refitted")
            break
        if in_trajectory_space and substeps == "auto" and confirm_winner and not clock.out():
            # the refits compared at one step; the winner's fit confirmed as every fit is
            # (Richardson's two steps), from where its refit ended
            say(f"diagnose: confirming {winner.name} (the fit at two steps, extrapolated)")
            refit = clock.timed(lambda: confirm(refit, experiments))
            gap_after = gap(refit.rms_error_, noise_rms)
        round_info["winner"] = winner.name
        # a switch of the material adds no effect: the refitted model's elements are
        # neo-Hookean, or relax
        added = (winner.effect.with_params([1.0]) if switches(winner)
                 else refit.model_.effects[-1])
        others = [c for c in ranked if c is not winner]
        nodes, centroid = where(current, added)
        findings.append(Finding(
            name=winner.name, confidence=confidence([winner, *others]),
            parameters=(winner.effect.switched_values(refit.model_) if switches(winner)
                        else dict(zip(added.labels, added.params.tolist()))),
            springs=winner.springs, nodes=nodes, rms_before=rms,
            rms_after=refit.rms_error_, gap_before=gap_before, gap_after=gap_after,
            runner_up=others[0].name if others else "none", candidates=ranked,
            elements=winner.elements, centroid=centroid))
        say(f"diagnose: found {winner.name}; RMS per marker {length_text(rms)} -> "
            f"{length_text(refit.rms_error_)}")
        current, rms, steps = refit.model_, refit.rms_error_, refit.substeps_
        verdict = refit.lack_of_fit_
        if clock.stopped:
            break
    mesh = None
    if not verdict.explained and model.elements is not None and mesh_check and clock.out():
        clock.left_out("the mesh check not run")
    elif not verdict.explained and model.elements is not None and mesh_check:
        say("diagnose: the misfit is above the noise; a step of the fit on the mesh refined "
            "once, to see how much of it is the mesh's")
        mesh = mesh_share(current, experiments, verdict)
    localisation = None
    inclusions = [f for f in findings if f.name in INCLUSIONS]
    if prior is not None and inclusions and clock.out():
        clock.left_out("the inclusion not located item by item")
    elif prior is not None and inclusions and located is not None:
        localisation = located.covering(inclusions)
    elif prior is not None and inclusions:
        say("diagnose: locating the inclusion item by item (a fit of every "
            f"{'spring' if model.elements is None else 'element'} with the rule base as a prior)")
        localisation = localise(model, experiments, prior, findings=inclusions,
                                substeps=substeps, progress=progress)
        say(f"diagnose: {localisation.words}")
    if clock.stopped:
        say(f"diagnose: out of time ({clock.provisional}); the answer is provisional")
    return Diagnosis(effects=findings, model_=current, rms_before=rms_start, rms_after=rms,
                     noise_rms=verdict.noise, candidates=ranked, rounds=rounds,
                     localisation=localisation, lack_of_fit=verdict, mesh=mesh,
                     provisional=clock.provisional)
