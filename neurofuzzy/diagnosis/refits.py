"""Refits of the diagnosis's candidates: which are worth one, the model each starts from, and
the winner's fit confirmed."""

from __future__ import annotations

import numpy as np

from ..effects import SoftInclusion, StiffInclusion
from ..experiment import duration
from ..learn import auto_substeps
from ..learn.steps import stable_at_one_step
from ..pipeline import FitOptions, fit
from .scoring import INCLUSIONS, Candidate, gap, nothing_left

__all__ = ["fitted", "to_refit", "refit_candidate", "refit_with_starts", "confirm",
           "switches", "MIN_EVIDENCE", "MIN_SHRINK", "MAX_REFITS", "FIT_TOLERANCE",
           "CONFIRM_EVALUATIONS", "tolerance"]

#: Refitting with a candidate must shrink the gap above the noise floor at least this many
#: times (and the candidate have :data:`MIN_EVIDENCE`).
MIN_SHRINK = 1.5

#: A candidate must explain at least a fraction of the residual above the noise (the
#: evidence's ``min_explained``: 0.3 of the one-step residual force, 0.1 of the linearised
#: marker error) with at least this much evidence (ΔBIC; 10 is "very strong" on Kass &
#: Raftery's scale)…
MIN_EVIDENCE = 10.0
#: Candidates refitted per round, best-scored first, until one passes the refit test: with
#: noisy accelerations the one-step scores can rank a wrong local effect above the global one.
MAX_REFITS = 5
#: Relative tolerance of the diagnosis's fit of the model as it is and of its refits, on
#: the cost and the step (:class:`~neurofuzzy.pipeline.FitOptions`' ``tolerance``; 1e-10 by
#: default), in trajectory space, where every pass is a simulation: the diagnosis compares
#: RMS errors by factors (a winner shrinks the gap 1.5×), which a cost 10⁻⁴ short of its
#: minimum moves by 5·10⁻⁵, and the winner's fit is confirmed at the default
#: (:func:`confirm`). On sfepy's block at 27 % strain (4 mm voxels) the fit of the SVK
#: model crept from 746.4 to 746.2 µm over 30 Jacobians, 95 s of its 142. Fits of one-step
#: residuals keep the default: they are cheap, and on exact data reach the rounding (the
#: cube's hidden gravity: 1e-16 m).
FIT_TOLERANCE = 1e-4
#: Solver evaluations of the winner's confirmation at twice its refit's step (the start's,
#: with its Jacobian, and one step's): :func:`confirm`.
CONFIRM_EVALUATIONS = 2


def fitted(model, experiments, *, prior=None, **options):
    """``model`` fitted to ``experiments`` as the diagnosis fits, through the one fit path
    (:func:`neurofuzzy.fit`): from the model as it is, no mesh check, unchecked (the
    diagnosis checked the data once, and ranks its refits by their error), with ``prior``
    (a :class:`~neurofuzzy.learn.prior.FuzzyPrior`) or none; ``options`` more
    :class:`~neurofuzzy.pipeline.FitOptions`. Returns the fitted learner."""
    options = FitOptions(mesh_check=False, checked=False, **options)
    return fit(experiments, start=model, prior="off" if prior is None else prior,
               options=options).learner


def to_refit(ranked, evidence, verdict, rms, say) -> list:
    """The candidates worth a refit, in the order to refit them: while the model explains
    the data to the noise, only those that explain a good share of the residual,
    significantly, best scored first; while it does not, the best of every kind with strong
    evidence, however little it explains linearly (a linearised step from a model far off
    underestimates what a refit does), the material switches first (:func:`switches`).

    Why the switches first: far from the noise every kind is refitted until one reaches it,
    and a refit is given up once it cannot beat the best so far, so the round is quickest
    when a good leader comes early. A switch changes every element, which a linearised step
    underestimates most (sfepy's block at 27 % strain, 4 mm voxels: the law switch explained
    26 % linearly, an inclusion 40 %; refitted, the switch shrank the gap 6.9×, the inclusion
    1.8×), and its refit has no region to find. Refitted after the law switch, the inclusion
    was given up in 22 s; refitted first, with no leader, it ran 174 s. Within each group
    the order is the score's."""
    strong = [c for c in ranked if c.score >= MIN_EVIDENCE]
    if verdict.explained:
        strong = [c for c in strong if c.explained >= evidence.min_explained]
        if nothing_left(verdict, rms, evidence.size):
            say(f"diagnose: none ({verdict.short}; nothing left to explain)")
            return []
        if not strong:
            best = ranked[0] if ranked else None
            say(f"diagnose: none ({verdict.short}; no candidate has strong evidence: best "
                f"{best.name if best else '-'}, explaining {best.explained if best else 0:.0%}"
                " linearly)")
            return []
        return strong[:MAX_REFITS]
    kinds, tried = set(), []
    for candidate in strong:
        if candidate.name not in kinds:
            kinds.add(candidate.name)
            tried.append(candidate)
    return sorted(tried[:MAX_REFITS], key=lambda candidate: not switches(candidate))


def refit_candidate(candidate: Candidate, model, evidence, experiments, substeps,
                    staged=True, abandon_above=None):
    """The model with the candidate's effect (started at its least-squares parameters),
    refitted; an inclusion's sign decides stiff or soft (the candidate is renamed). From
    markers (``staged=False``) the refit starts from the fitted model and the linearised
    step, so it fits the whole recording at once rather than growing beginnings of it, and
    with ``substeps="auto"`` at one step only, the candidate model's own
    (:func:`~neurofuzzy.learn.auto_substeps`): enough to compare candidates, and at most a
    third of the work of Richardson's two steps (the second, twice as fine, costs twice the
    first per iteration; the relaxation switch on the 4 mm block took 72 s at one step, 486 s
    at both); the winner's fit is confirmed at both (:func:`confirm`). With
    ``abandon_above`` (the best refit's RMS so far) the refit stops once it cannot come
    below it (:class:`~neurofuzzy.pipeline.FitOptions`' ``abandon_above``)."""
    start = _with_candidate(candidate, model, evidence, experiments)
    if not staged and substeps == "auto":
        substeps = max(auto_substeps(start, e.dt) for e in experiments)
    refit = fitted(start, experiments, substeps=substeps, windows=None if staged else (),
                   abandon_above=abandon_above, **tolerance(not staged))
    extra = np.mean(refit.model_.effects[-1].params) if candidate.name in INCLUSIONS else 0
    if extra:                             # the sign the refit ended with names an inclusion
        candidate.name = INCLUSIONS[0 if extra > 0 else 1]
    return refit


def refit_with_starts(candidate: Candidate, fitted, start, evidence, experiments, substeps,
                      in_trajectory_space: bool, clock, *, leader: float, noise_rms: float,
                      gap_before: float):
    """The candidate refitted from the ``fitted`` model, and once more from the ``start``
    model's values (with the effects found so far) when that stays above the noise, the
    better of the two; given up against ``leader`` (the best refit's RMS so far; the gap
    above ``noise_rms`` was ``gap_before`` without the candidate).

    The fitted model may have bent its own values to make up for what it lacks (softened the
    whole block for hidden gravity), far from where the effect's fit starts well. A law's
    switch starts from the start model's values instead, the fitted ones its second start:
    they are the old law's (on sfepy's block at 27 % strain the SVK fit's viscosity rose
    11x, and the neo-Hookean refit took 122 s from them; from the start's, with the fitted
    ones given up as the second start, 32 s). A law switch that shrinks the gap
    :data:`MIN_SHRINK` times from there has no second start: the old law's values are not a
    better start for the new one (on the 401-frame block that start, at 3x the substeps its
    viscosity needs, ran 28 s and was given up)."""
    staged = not in_trajectory_space
    starts = [fitted, start]
    law = switches(candidate) and not candidate.effect.switches_partly
    if law:
        starts.reverse()
    refit = clock.timed(lambda: refit_candidate(
        candidate, starts[0], evidence, experiments, substeps, staged=staged,
        abandon_above=leader))
    placed = (law and not refit.abandoned_
              and gap(refit.rms_error_, noise_rms) * MIN_SHRINK <= gap_before)
    if not refit.lack_of_fit_.explained and clock.out():
        clock.left_out(f"{candidate.name} not refitted from a second start")
    elif not refit.lack_of_fit_.explained and not placed:
        again = clock.timed(lambda: refit_candidate(
            candidate, starts[1], evidence, experiments, substeps, staged=staged,
            abandon_above=min(leader, refit.rms_error_)))
        refit = min(refit, again, key=lambda fitted: fitted.rms_error_)
    return refit


def _with_candidate(candidate: Candidate, model, evidence, experiments):
    """``model`` with the candidate's effect at its linearised parameters, or switched."""
    if switches(candidate):
        # not a patch: the elements take the law or relax (as much as the linearised fit of
        # the probe asks for), and everything is refitted
        own, share = evidence.linearised_step(candidate.effect)
        if candidate.effect.switches_partly and model is evidence.model:
            # from the fitted model, its own parameters take the step the linearised fit
            # takes with the probe (relaxation's g shifts the stiffness E must make up for)
            model = evidence.stepped(own)
        return candidate.effect.switch(model, duration(experiments), share=float(share[0]))
    params = evidence.initial_params(candidate.effect)
    effect = candidate.effect.with_params(params)
    if effect.name in INCLUSIONS and candidate.seeded:
        # the map's sign: the linearised step starts the refit when it agrees, else none
        agrees = np.mean(params) * (1.0 if effect.name == INCLUSIONS[0] else -1.0) > 0
        effect = candidate.effect.with_params(params if agrees else np.zeros_like(params))
    elif effect.name in INCLUSIONS:
        kind = StiffInclusion if np.mean(effect.params) > 0 else SoftInclusion
        effect = kind(effect.params, **effect.options)
        candidate.name = effect.name
    return model.with_effects(effect)


def tolerance(in_trajectory_space: bool) -> dict:
    """The diagnosis's fits' tolerance as their options (:func:`fitted`): :data:`FIT_TOLERANCE` in
    trajectory space, the learner's default otherwise."""
    return {"tolerance": FIT_TOLERANCE} if in_trajectory_space else {}


def switches(candidate: Candidate) -> bool:
    """Does the catalogue entry switch the elements' material
    (:attr:`~neurofuzzy.effects.Effect.switches_material`: neo-Hookean or Yeoh elements, a
    Prony term) rather than add a force term?"""
    return candidate.effect.switches_material


def confirm(refit, experiments):
    """The winner's refit, made at one step (:func:`refit_candidate`), fitted as every fit
    is: at two steps and extrapolated (Richardson), from where the refit ended, which is its
    fit at the first of them when that is the refit's step. At twice its step the minimum
    moves by the integrator's error, which one Levenberg–Marquardt step takes
    (:data:`CONFIRM_EVALUATIONS`): on sfepy's relaxing block on 4 mm voxels, 39 s against
    75 s for the fit run to its end, the values equal within 0.2 % and the RMS within 1e-6.
    A refit whose values ended outside its step's stable range has no fit at that step to
    start from: it is confirmed by a whole fit from its values."""
    if not stable_at_one_step(refit.model_, experiments, substeps=refit.substeps_):
        # two evaluations at steps of their own had made sfepy's 7.5 mm block at 27 % strain
        # 15.3x the noise from the refit's 9.6x
        return fitted(refit.model_, experiments, windows=())
    return fitted(refit.model_, experiments, windows=(), fitted_at=refit.substeps_,
                  cycles=CONFIRM_EVALUATIONS)
