"""Find the missing effect: where simulation and measurement disagree, name it, add it, refit.

Each round (DESIGN.md, "Diagnosis"):

1. fit the model as it is (:class:`~neurofuzzy.learn.GradientLearner`);
2. residuals: the trajectory error of the free run and the one-step residual force
   ``r_i(t) = m_i a_i(t) - F_model,i(p(t), v(t)) - f_ext,i(t)`` with the measured state (positions
   smoothed by a Savitzky–Golay filter when the markers are noisy). One-step residuals do not
   accumulate, the insight behind the paper's teacher forcing;
3. localise ``r`` per node, per spring (a ridge regression of ``r`` on every spring's own force
   template gives each spring's stiffness mismatch) and per frame, and estimate the noise floor;
4. score every candidate of the effect catalogue by regressing ``r`` on its force templates
   together with the model's own parameter templates (sparse identification of dynamics, as in
   SINDy): the Bayesian information criterion with the noise floor as variance, ``ΔBIC =
   (RSS_model - RSS_model+candidate) / σ² - k ln n``, favours the simpler explanation;
   ``none`` when no candidate explains at least ``MIN_EXPLAINED`` of the residual with strong
   evidence (``ΔBIC > MIN_EVIDENCE``);
5. add the winner, refit everything, and keep it only if the gap (RMS above the noise floor)
   shrinks at least ``MIN_SHRINK`` times; repeat until ``none``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import savgol_filter

from .effects import EFFECTS, SoftInclusion, StiffInclusion
from .errors import InputError
from .experiment import Experiment
from .forces import SPRINGS, incidence
from .learn import GradientLearner
from .learn._base import check_experiments, simulate_like
from .model import SpringMassModel
from .simulate import internal_forces

__all__ = ["diagnose", "Diagnosis", "Finding", "Candidate", "Residuals", "residual_analysis"]

#: A candidate must explain at least this fraction of the residual force above the noise…
MIN_EXPLAINED = 0.3
#: …with at least this much evidence (ΔBIC; 10 is "very strong" on Kass & Raftery's scale).
MIN_EVIDENCE = 10.0
#: …and refitting with it must shrink the gap above the noise floor at least this many times.
MIN_SHRINK = 1.5
#: Residual forces below this fraction of the inertial forces count as numerical noise.
RELATIVE_FLOOR = 1e-3
#: A spring joins (or leaves) an inclusion region when that explains this much more residual.
REGION_GAIN = 0.005


@dataclass
class Residuals:
    """Where and when the model disagrees with the measurement.

    Attributes
    ----------
    force : (n_samples, 3) float
        One-step residual force at every (experiment, frame, free observed node).
    per_node : (n_nodes,) float
        RMS residual force of every node over time (0 for fixed or unobserved nodes).
    per_node_error : (n_nodes,) float
        RMS trajectory error of every node (free run).
    per_spring : (n_springs,) float
        Relative stiffness mismatch of every spring (ridge regression of the residual force).
    per_frame : (n_frames - 2,) float
        RMS residual force per frame (first experiment).
    noise_floor : float
        Standard deviation of the residual force that noise alone explains.
    marker_noise : float
        Estimated standard deviation of the marker positions.
    """

    force: np.ndarray
    per_node: np.ndarray
    per_node_error: np.ndarray
    per_spring: np.ndarray
    per_frame: np.ndarray
    noise_floor: float
    marker_noise: float


@dataclass
class Candidate:
    """One effect scored against the residuals."""

    name: str
    score: float              # ΔBIC against the model alone (higher is better)
    explained: float          # fraction of the residual above the noise floor it removes
    effect: object = None     # the Effect to add (None for "none")
    springs: list = field(default_factory=list)
    nodes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"name": self.name, "score": _finite(self.score),
                "explained": _finite(self.explained), "springs": self.springs,
                "nodes": self.nodes}


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
        return {"effects": [f.to_dict() for f in self.effects],
                "answer": self.names,
                "rms_before": self.rms_before, "rms_after": self.rms_after,
                "noise_rms": self.noise_rms,
                "candidates": [c.to_dict() for c in self.candidates],
                "rounds": [{"candidates": [c.to_dict() for c in r["candidates"]],
                            "rms": r["rms"], "winner": r["winner"]} for r in self.rounds]}


def _finite(value):
    return float(value) if np.isfinite(value) else None


# -- residuals ------------------------------------------------------------------------------
def _states(positions: np.ndarray, experiment: Experiment, discrete: bool, smooth: bool):
    """Positions, velocities, accelerations at frames 1..T-2 from measured ``positions``."""
    if smooth and experiment.n_frames >= 9:
        fixed = positions[:, experiment.mesh.fixed]
        positions = savgol_filter(positions, 9, 3, axis=0, mode="interp")
        positions[:, experiment.mesh.fixed] = fixed
    h = experiment.dt
    p = positions[1:-1]
    if discrete:   # semi-implicit Euler: v(t) = (p(t) - p(t-1)) / h
        v = (positions[1:-1] - positions[:-2]) / h
    else:          # continuous physics: central differences
        v = (positions[2:] - positions[:-2]) / (2 * h)
    a = (positions[2:] - 2 * positions[1:-1] + positions[:-2]) / (h * h)
    return p, v, a


def _marker_noise(error: np.ndarray, motion: np.ndarray) -> float:
    """Standard deviation of white marker noise in a trajectory error ``measured - model``.

    Model errors are smooth in time, noise is not: the first difference of the error is
    dominated by noise (variance 2σ²). Robust (median-based); 0 when it is negligible next to
    the motion (noise-free data).
    """
    if error.shape[0] < 3 or error.size == 0:
        return 0.0
    first = np.diff(error, axis=0)
    sigma = float(np.sqrt(np.median(first**2) / 0.455 / 2.0))
    scale = float(np.abs(motion).max()) or 1.0
    return sigma if sigma > 1e-7 * scale else 0.0


@dataclass
class _Samples:
    """Measured states and residual forces of all experiments, flattened."""

    experiment: list         # per experiment: dict(p, v, a, rows, residual)
    force: np.ndarray        # (n_samples, 3)
    noise_floor: float
    marker_noise: float


def _sample(model: SpringMassModel, experiments, substeps: int) -> _Samples:
    per_experiment, forces, floors, noises = [], [], [], []
    rng = np.random.default_rng(0)
    for experiment in experiments:
        free_run = simulate_like(model, experiment, substeps)
        # One-step residuals need a node's measured positions in consecutive frames: nodes
        # with gaps count like unobserved ones here (their positions come from the model's
        # free run and they contribute no samples); the fit itself still uses every frame.
        seen = experiment.measured()
        measured = np.where(seen[:, :, None], experiment.positions, free_run)
        rows = experiment.tracked() & seen.all(axis=0)
        if not rows.any():
            raise InputError("the diagnosis needs at least one free node measured at every "
                             "frame; every observed node has gaps", source=experiment.source,
                             key="positions")
        noise = _marker_noise(measured[:, rows] - free_run[:, rows],
                              measured[:, rows] - measured[:1, rows])
        loads = experiment.forces_per_frame()[1:-1]

        def residual_of(positions):
            p, v, a = _states(positions, experiment, substeps == 1, smooth=noise > 0)
            out = np.empty_like(p)
            for t in range(p.shape[0]):
                out[t] = (model.node_mass[:, None] * a[t] - internal_forces(model, p[t], v[t])
                          - loads[t])
            return out, (p, v, a)

        residual, (p, v, a) = residual_of(measured)
        inertial = model.node_mass[None, rows, None] * a[:, rows]
        floor = RELATIVE_FLOOR * float(np.sqrt(np.mean(inertial**2)))
        if noise > 0:
            # the residual force that noise alone causes: push one more noise realisation of
            # the estimated size through the same pipeline (it is linear in small noise)
            extra = rng.normal(0.0, noise, measured.shape)
            extra[:, ~rows] = 0.0
            perturbed, _ = residual_of(measured + extra)
            floor = max(floor, float(np.sqrt(np.mean((perturbed - residual)[:, rows] ** 2))))
        floors.append(floor)
        noises.append(noise)
        per_experiment.append({"p": p, "v": v, "a": a, "rows": rows, "residual": residual})
        forces.append(residual[:, rows].reshape(-1, 3))
    return _Samples(per_experiment, np.concatenate(forces),
                    float(np.sqrt(np.mean(np.square(floors)))), float(np.mean(noises)))


def _templates(model, samples: _Samples, force_of) -> np.ndarray:
    """Stack a force template ``force_of(p, v) -> (n_nodes, k, 3)`` over all samples → (n, k)."""
    blocks = []
    for data in samples.experiment:
        rows = data["rows"]
        per_frame = [force_of(data["p"][t], data["v"][t])[rows] for t in range(len(data["p"]))]
        stacked = np.stack(per_frame).transpose(2, 0, 1, 3)        # (k, T', F, 3)
        blocks.append(stacked.reshape(stacked.shape[0], -1))
    return np.concatenate(blocks, axis=1).T


def _model_templates(model, samples) -> np.ndarray:
    """Templates of the model's own tied stiffness and viscosity (their log-derivatives)."""
    maps = incidence(model.mesh)

    def force_of(p, v):
        templates = SPRINGS.parameter_templates(SPRINGS.state(model, p, v))
        return np.concatenate([
            maps.group_sums(values[:, None] * templates[name], model.spring_tie, model.n_ties)
            for name, values in (("stiffness", model.spring_stiffness),
                                 ("damping", model.spring_damping))], axis=1)

    return _templates(model, samples, force_of)


def _spring_templates(model, samples) -> np.ndarray:
    """(n, n_springs): every spring's own stiffness template ``s_j (l - L0) u``."""
    maps = incidence(model.mesh)

    def force_of(p, v):
        force = model.spring_stiffness[:, None] * SPRINGS.parameter_templates(
            SPRINGS.state(model, p, v))["stiffness"]
        return maps.group_sums(force, np.arange(model.n_springs), model.n_springs)

    return _templates(model, samples, force_of)


def residual_analysis(model: SpringMassModel, experiments: Sequence[Experiment], *,
                      substeps: int = 1) -> tuple[Residuals, _Samples]:
    """Residual forces, trajectory errors, localisation and noise floor of a fitted model.

    ``substeps`` is the integration the model was fitted with: 1 means the paper's discrete
    network (residuals with its backward-difference velocity), more means continuous physics
    (central differences).
    """
    samples = _sample(model, experiments, substeps)
    n_nodes = model.n_nodes
    per_node = np.zeros(n_nodes)
    counts = np.zeros(n_nodes)
    per_node_error = np.zeros(n_nodes)
    for experiment, data in zip(experiments, samples.experiment):
        rows = data["rows"]
        per_node[rows] += np.sum(data["residual"][:, rows] ** 2, axis=(0, 2))
        counts[rows] += data["residual"].shape[0]
        simulated = simulate_like(model, experiment, substeps)
        error = np.where(experiment.measured()[:, :, None],
                         simulated - np.nan_to_num(experiment.positions), 0.0)
        per_node_error += np.mean(np.sum(error**2, axis=2), axis=0)
    per_node = np.sqrt(per_node / np.maximum(counts, 1))
    per_node_error = np.sqrt(per_node_error / len(experiments))
    first = samples.experiment[0]
    per_frame = np.sqrt(np.mean(np.sum(first["residual"][:, first["rows"]] ** 2, axis=2), axis=1))
    per_spring = _spring_mismatch(model, samples)
    residuals = Residuals(force=samples.force, per_node=per_node, per_node_error=per_node_error,
                          per_spring=per_spring, per_frame=per_frame,
                          noise_floor=samples.noise_floor, marker_noise=samples.marker_noise)
    return residuals, samples


def _spring_mismatch(model, samples) -> np.ndarray:
    """Relative stiffness correction of every spring that best explains the residual (what the
    model's own tied parameters cannot explain)."""
    basis = _orthonormal(_model_templates(model, samples))
    columns = _spring_templates(model, samples)
    columns = columns - basis @ (basis.T @ columns)
    target = samples.force.ravel()
    target = target - basis @ (basis.T @ target)
    norms = np.linalg.norm(columns, axis=0)
    usable = norms > 1e-12 * (norms.max() or 1.0)
    scaled = columns[:, usable] / norms[usable]
    gram = scaled.T @ scaled
    ridge = 1e-3 * np.trace(gram) / max(len(gram), 1)
    solution = np.linalg.solve(gram + ridge * np.eye(len(gram)), scaled.T @ target)
    out = np.zeros(model.n_springs)
    out[usable] = solution / norms[usable]
    return out


# -- candidates ------------------------------------------------------------------------------
@dataclass
class Evidence:
    """What the residuals say, for :meth:`~neurofuzzy.effects.Effect.propose`: the effects the
    model has, the mean residual force per node, what located effects already use, and the
    inclusion region search."""

    model: SpringMassModel
    samples: _Samples
    base: np.ndarray

    @property
    def present(self) -> set[str]:
        return {e.name for e in self.model.effects}

    @property
    def mean_force(self) -> np.ndarray:
        """(n_nodes, 3) mean residual force of every node over the frames and experiments."""
        mean_force = np.zeros((self.model.n_nodes, 3))
        for data in self.samples.experiment:
            rows = data["rows"]
            mean_force[rows] += data["residual"][:, rows].mean(axis=0) / len(
                self.samples.experiment)
        return mean_force

    @property
    def taken_nodes(self) -> set[int]:
        return {int(n) for e in self.model.effects for n in e.nodes}

    @property
    def taken_springs(self) -> set[int]:
        return {int(j) for e in self.model.effects for j in e.springs}

    def inclusion_region(self, taken: set[int]) -> list[int]:
        return _inclusion_region(self.model, self.samples, taken, self.base)


def _candidates(model, samples: _Samples, base: np.ndarray) -> list:
    """Every effect of the registry, instantiated where the residuals point."""
    evidence = Evidence(model, samples, base)
    return [effect for cls in EFFECTS.values() for effect in cls.propose(model, evidence)]


def _inclusion_region(model, samples, taken: set[int], base: np.ndarray) -> list[int]:
    """Grow a region of springs, from the best star of springs around one node, while each
    added (or removed) neighbouring spring explains at least ``REGION_GAIN`` more of the
    residual; the region shares one stiffness change ``δ``. Everything is projected off the
    model's own templates first: the fit without the inclusion has already shifted the global
    stiffness to make up for it, and only what that cannot explain points at the region."""
    basis = _orthonormal(base)
    templates = _spring_templates(model, samples)                  # (n, S)
    templates = templates - basis @ (basis.T @ templates)
    target = samples.force.ravel()
    target = target - basis @ (basis.T @ target)
    total = float(target @ target)
    if total == 0:
        return []
    springs = model.mesh.springs
    allowed = np.ones(model.n_springs, bool)
    allowed[list(taken)] = False
    allowed &= np.linalg.norm(templates, axis=0) > 0

    def explained(region):
        column = templates[:, region].sum(axis=1)
        norm2 = float(column @ column)
        return (column @ target) ** 2 / norm2 / total if norm2 > 0 else 0.0

    stars = [np.flatnonzero(allowed & ((springs[:, 0] == k) | (springs[:, 1] == k)))
             for k in range(model.n_nodes)]
    stars = [star for star in stars if star.size]
    if not stars:
        return []
    region = set(max(stars, key=lambda star: explained(list(star))).tolist())
    best = explained(sorted(region))
    while True:
        nodes = np.unique(springs[sorted(region)])
        border = [j for j in np.flatnonzero(allowed & np.isin(springs, nodes).any(axis=1))
                  if j not in region]
        trials = [(explained(sorted(region | {j})), j) for j in border]
        trials += [(explained(sorted(region - {j})), -j - 1) for j in region if len(region) > 1]
        gain, move = max(trials, default=(best, None))
        if move is None or gain < best + REGION_GAIN:
            break
        region = region | {move} if move >= 0 else region - {-move - 1}
        best = gain
    return sorted(region)


def _orthonormal(columns: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the span of ``columns`` (zero columns dropped)."""
    norms = np.linalg.norm(columns, axis=0)
    usable = columns[:, norms > 0] / norms[norms > 0]
    if usable.shape[1] == 0:
        return np.zeros((columns.shape[0], 0))
    q, r = np.linalg.qr(usable)
    keep = np.abs(np.diag(r)) > 1e-10
    return q[:, keep]


def _score(model, samples: _Samples, base: np.ndarray, candidates) -> list[Candidate]:
    target = samples.force.ravel()
    sigma2 = samples.noise_floor**2
    n = target.size
    rss_base = _rss(base, target)
    excess = rss_base - n * sigma2        # what noise does not explain
    scored = []
    for effect in candidates:
        columns = _templates(model, samples,
                             lambda p, v, e=effect: e.parameter_jacobian(model, p, v))
        rss = _rss(np.concatenate([base, columns], axis=1), target)
        k = columns.shape[1]
        score = (rss_base - rss) / sigma2 - k * np.log(n)
        gain = rss_base - rss
        explained = gain / max(excess, gain) if gain > 0 else 0.0
        scored.append(Candidate(name=effect.name, score=float(score), explained=float(explained),
                                effect=effect, springs=[int(j) for j in effect.springs],
                                nodes=[int(i) for i in effect.nodes]))
    scored.sort(key=lambda c: -c.score)
    return scored


def _rss(columns: np.ndarray, target: np.ndarray) -> float:
    norms = np.linalg.norm(columns, axis=0)
    usable = norms > 0
    if not usable.any():
        return float(target @ target)
    scaled = columns[:, usable] / norms[usable]
    solution, *_ = np.linalg.lstsq(scaled, target, rcond=None)
    residual = target - scaled @ solution
    return float(residual @ residual)


def _confidence(ranked: list[Candidate]) -> float:
    """Posterior weight of the winner among the candidates and "none" (BIC weights)."""
    scores = np.array([c.score for c in ranked] + [0.0]) / 2.0
    scores -= scores.max()
    weights = np.exp(scores)
    return float(weights[0] / weights.sum())


def _initial_params(effect, model, samples, base) -> np.ndarray:
    """Least-squares estimate of the effect's parameters together with the model templates."""
    columns = _templates(model, samples, lambda p, v: effect.parameter_jacobian(model, p, v))
    both = np.concatenate([base, columns], axis=1)
    norms = np.linalg.norm(both, axis=0)
    norms[norms == 0] = 1.0
    solution, *_ = np.linalg.lstsq(both / norms, samples.force.ravel(), rcond=None)
    return (solution / norms)[base.shape[1]:]


# -- the loop --------------------------------------------------------------------------------
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
    say = (lambda message: print(message, file=sys.stderr, flush=True)) if progress else \
        (lambda message: None)
    fitted = GradientLearner(substeps=substeps).fit(model, experiments)
    current, rms, steps = fitted.model_, fitted.rms_error_, fitted.substeps_
    rms_start = rms
    say(f"diagnose: fitted the model as it is, RMS {rms:.3g}")
    findings, rounds = [], []
    ranked: list[Candidate] = []
    noise_rms = 0.0
    for _ in range(max_effects):
        residuals, samples = residual_analysis(current, experiments, substeps=steps)
        noise_rms = samples.marker_noise * np.sqrt(3.0)
        base = _model_templates(current, samples)
        ranked = _score(current, samples, base, _candidates(current, samples, base))
        winner = ranked[0] if ranked else None
        round_info = {"residuals": residuals, "candidates": ranked, "rms": rms, "winner": "none"}
        rounds.append(round_info)
        if winner is None or winner.score < MIN_EVIDENCE or winner.explained < MIN_EXPLAINED:
            say(f"diagnose: none (best {winner.name if winner else '-'}: explains "
                f"{winner.explained if winner else 0:.0%}, ΔBIC {winner.score if winner else 0:.3g})")
            break
        effect = winner.effect.with_params(_initial_params(winner.effect, current, samples, base))
        if effect.name in ("stiff_inclusion", "soft_inclusion"):
            kind = StiffInclusion if np.mean(effect.params) > 0 else SoftInclusion
            effect = kind(effect.params, **effect.options)
            winner.name = effect.name
        refit = GradientLearner(substeps=substeps).fit(current.with_effects(effect), experiments)
        gap_before, gap_after = _gap(rms, noise_rms), _gap(refit.rms_error_, noise_rms)
        if not _significant(rms, noise_rms, samples.force.size):
            say(f"diagnose: the error ({rms:.3g}) is what marker noise ({noise_rms:.3g}) "
                "explains; answering none")
            break
        if not gap_after * MIN_SHRINK <= gap_before:
            say(f"diagnose: {winner.name} scored best but refitting with it shrinks the gap only "
                f"{gap_before / max(gap_after, 1e-300):.2g}x; answering none")
            break
        round_info["winner"] = winner.name
        added = refit.model_.effects[-1]
        findings.append(Finding(
            name=winner.name, confidence=_confidence(ranked),
            parameters=dict(zip(added.labels, added.params.tolist())),
            springs=winner.springs, nodes=winner.nodes, rms_before=rms,
            rms_after=refit.rms_error_, gap_before=gap_before, gap_after=gap_after,
            runner_up=ranked[1].name if len(ranked) > 1 else "none", candidates=ranked))
        say(f"diagnose: found {winner.name} (explains {winner.explained:.0%}); RMS "
            f"{rms:.3g} -> {refit.rms_error_:.3g}")
        current, rms, steps = refit.model_, refit.rms_error_, refit.substeps_
    return Diagnosis(effects=findings, model_=current, rms_before=rms_start, rms_after=rms,
                     noise_rms=noise_rms, candidates=ranked, rounds=rounds)


def _significant(rms: float, noise_rms: float, n: int) -> bool:
    """Is the squared error above the noise by more than 5 sampling standard deviations?"""
    return rms**2 - noise_rms**2 > 5.0 * np.sqrt(2.0 / max(n, 1)) * noise_rms**2


def _gap(rms: float, noise_rms: float) -> float:
    """RMS error above what marker noise explains."""
    return float(np.sqrt(max(rms**2 - noise_rms**2, 0.0)))
