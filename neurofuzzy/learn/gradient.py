"""Exact-gradient learner: Levenberg–Marquardt (Gauss–Newton) or L-BFGS on the discrete
simulator, with multiple shooting.

The objective is the paper's error ``E`` (eq. 2.2) over all experiments, with lengths in units
of the mean spring length. Derivatives are exact for the discrete model (forward sensitivities
for the Jacobian, the adjoint for large problems; :mod:`._sensitivity`). Optimisation runs in
stages: first on short windows whose first frame is reset to the measurement (multiple
shooting, the same idea as the paper's teacher forcing; it keeps far-off starts from being
trapped by the long free-running trajectory), then on the whole trajectory, so the result
minimises the free-running error that :func:`rms_error` reports.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..experiment import Experiment, check_experiments, rms_error
from ..model import Model
from ..simulation import check_substeps
from ..progress import Progress, Stopwatch
from ._base import Learner
from . import _passes as passes
from ._parameters import Parameterization
from ._prior_weight import set_prior
from ._sensitivity import Sensitivity
from ._solvers import solve_lbfgs, solve_lm
from .identifiability import structurally_unidentifiable
from ..formatting import length_text
from .steps import (auto_substeps, fits_offsets, parameter_bounds, stable_at_one_step,
                    stable_start)
from .region_test import homogeneous_fit
from .regions import supported_regions_found
from .uncertainty import assess, intervals_dict

__all__ = ["GradientLearner", "auto_substeps", "fits_offsets"]

#: Jacobians with more entries than this switch ``method="auto"`` to L-BFGS with the adjoint.
MAX_JACOBIAN_ENTRIES = 3e7
#: Default multiple-shooting window (frames) before the whole-trajectory stage.
DEFAULT_WINDOW = 25
#: Relative tolerance on the cost of the stages before the last (windows, beginnings).
STAGE_TOLERANCE = 1e-3
#: Times a fit with ``stable_steps`` moves on to finer steps.
MAX_MOVES = 4


class GradientLearner(Learner):
    """Fit a model to experiments with exact gradients of the discrete simulator.

    Parameters
    ----------
    learn_masses : bool
        Learn the free nodes' masses too (otherwise they stay as given).
    learn_effects : bool
        Learn the parameters of the model's effects.
    substeps : int or "auto"
        Integration steps per recorded frame. 1 is the paper's network (one propagation step
        per frame; exact for data made by our simulator at one step per frame). ``"auto"`` also
        fits continuous physics: with ``k`` (:func:`auto_substeps`) and ``2k`` substeps,
        extrapolating the first-order bias of the integrator away (Richardson), and keeps
        whichever of the two explains the data better.
    windows : sequence of int or None
        Window lengths (frames) of the multiple-shooting stages that come before the final
        stage on the whole trajectory; ``None`` means ``(25,)``, ``()`` none. Windows need every
        free node observed; otherwise the stages fit growing beginnings of the recording.
        Stages before the last stop at a relative cost change of ``STAGE_TOLERANCE`` (0.1 %).
    method : {"auto", "lm", "lbfgs"}
        Levenberg–Marquardt on the normal equations of the full Jacobian (``"lm"``,
        :mod:`._lm`), L-BFGS-B with the adjoint gradient (``"lbfgs"``), or the first when
        the Jacobian fits in memory.
    max_iterations : int
        Function evaluations (``"lm"``) or iterations (``"lbfgs"``) per stage.
    tolerance : float
        Relative tolerance on the cost and the step.
    bounds : float
        Stiffness, viscosity and mass stay within this factor of their start.
    prior : FuzzyPrior, optional
        The rule base's description of every region as a penalty on the material parameters
        (:mod:`.prior`); its weight fixed or chosen by the discrepancy principle.
    mesh_check : "auto", "step", "refit" or False
        After the fit, estimate how far the values move on the mesh refined once and widen
        the intervals by it (:mod:`.mesh_check`; element models). ``"auto"`` (the default):
        one Gauss–Newton step on the refined mesh from the fitted values
        (:func:`~.mesh_check.linearised_mesh_check`; about one Jacobian of the refined model,
        half a fit's time on the 7.5 mm probed block) for an element model of at most
        ``STEP_COLUMNS`` (64) parameters, none for a fit of every element or a spring
        network. ``"step"``: the step for any element model, and the whole refit where the
        step cannot be trusted. ``"refit"`` (or True): the whole refit (about 16 times the
        work of the fit). False: none. ``intervals_hold_`` says what the intervals hold: the
        noise and the mesh, or the noise alone and why.
    offsets : bool or "auto"
        Fit every marker's rest position along with the parameters (a constant offset per
        marker and coordinate, eliminated exactly: :func:`~neurofuzzy.observation.remove_offsets`),
        so that the noise of the frames a rest position was taken from, or a marker a little
        off the mesh, is not read as model error. ``"auto"``: for markers embedded in
        elements (an imported recording); tracked nodes start from their measured frame 0.
    abandon_above : float, optional
        An RMS error per marker (metres) the fit has to be able to beat, or it stops: once,
        at two such Jacobians in a row, Gauss–Newton's prediction of the least error reachable
        from there (:func:`._lm.floor`; asked only near a minimum, where it predicts that at
        most half the cost can go, or where it agrees with the last one) is above it, the fit
        ends where it is and ``abandoned_`` is True (Levenberg–Marquardt on the whole
        recording only). The diagnosis gives it the best refit so far.
    fitted_at : int, optional
        The substeps per frame at which the start model is already fitted (the diagnosis's
        winning refit, made at one step): with ``substeps="auto"`` they are the fit's first
        step when the start is stable there, and it is not fitted there again, only at twice
        as many steps (Richardson).
    extrapolate : bool
        With ``substeps="auto"``: fit at ``k`` and ``2k`` substeps and extrapolate (the
        default), or at ``k`` only (False: one step, as the diagnosis's refits are made).
    stable_steps : bool
        With ``substeps="auto"``: once the values leave the stable range of the steps they
        are fitted at (a growing viscosity shortens the stable step), fit on at the steps
        they need (:func:`auto_substeps`): beyond its stable step a simulation amplifies
        rounding, and the fit creeps on that noise (docs/benchmarks.md); and stop at steps
        below the cluster-robust standard errors too. Off by default until its cost is
        settled: two slow validation tests took 25 times as long with it.
    progress : bool
        Report progress on stderr.

    Attributes
    ----------
    history_ : (n_cycles_,) float
        The paper's error ``E`` (eq. 2.2, lengths in mean spring lengths) after every
        simulation of the data, best so far (trial steps the solver rejects do not raise it):
        one value per cycle, Jacobian passes included.
    n_cycles_ : int
        Complete simulations of all experiments (a Jacobian or gradient pass counts as one);
        ``len(history_)``.
    substeps_ : int
        Substeps per frame with which the returned model reproduces the data best.
    extrapolated_ : bool
        True when the returned parameters are the continuous-physics extrapolation.
    parameter_names_ : list of str
    std_errors_ : (n_params,) float
        Standard errors of the parameters; relative for stiffness, viscosity and mass: the
        larger of the Gauss–Newton and the cluster-robust estimate (:mod:`.identifiability`).
    lack_of_fit_ : LackOfFit
        The RMS error against the marker noise and the verdict (:mod:`.lack_of_fit`).
    intervals_ : dict
        ``{name: (low, high)}`` 95 % intervals in the parameters' own units
        (:mod:`.uncertainty`), widened by the mesh check when it ran.
    mesh_check_ : MeshCheck or None
        With ``mesh_check``: how far the values move on the mesh refined once.
    intervals_hold_ : str
        What ``intervals_`` hold: the noise and the mesh (the move on the refined mesh), or
        the noise alone and why no mesh check ran.
    offsets_ : bool
        Whether the markers' rest positions were fitted.
    abandoned_ : bool
        Whether the fit stopped because it could not beat ``abandon_above``.
    identifiability_ : Identifiability
        Standard errors and the parameter combinations the data do not determine.
    homogeneous_ : GradientLearner or None
        With a prior: the homogeneous model (one value per region) fitted first, against
        which every region found is tested (:mod:`.region_test`).
    regions_ : dict or None
        With a prior: the regions found that the data support (:mod:`.region_test`;
        ``"regions"``, ``"rejected"``, ``"rest"``) and the test's power on these data
        (``"power"``, :func:`.power.detection_limit`: how small a lump five times stiffer it
        would keep, and at how many places), and all that in words (``"words"``,
        :func:`.regions.describe_regions`).
    prior_ : dict or None
        With a prior: its weight ``alpha`` (``w = α σ²``), the noise level ``noise`` (metres)
        it was measured against, how it was chosen, the fits the choice took and the sets.
    """

    cycle_name = "simulation of the data"
    #: the last simulation of the data during a fit (:class:`._passes.Last`), else None
    _last = None

    def __init__(self, *, learn_masses: bool = False, learn_effects: bool = True,
                 substeps: int | str = 1, windows: Sequence[int] | None = None,
                 method: str = "auto", max_iterations: int = 100, tolerance: float = 1e-10,
                 bounds: float = 1e3, prior=None, offsets: bool | str = "auto",
                 mesh_check: bool | str = "auto", abandon_above: float | None = None,
                 fitted_at: int | None = None, extrapolate: bool = True,
                 stable_steps: bool = False, progress: bool = False):
        self.learn_masses = learn_masses
        self.learn_effects = learn_effects
        self.substeps = substeps
        self.windows = windows
        self.method = method
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.bounds = bounds
        self.prior = prior
        self.offsets = offsets
        self.mesh_check = mesh_check
        self.abandon_above = abandon_above
        self.fitted_at = fitted_at
        self.extrapolate = extrapolate
        self.stable_steps = stable_steps
        self.progress = progress

    def fit(self, model: Model,
            experiments: Experiment | Sequence[Experiment]) -> GradientLearner:
        """Learn ``model``'s parameters from ``experiments``; returns ``self``."""
        experiments = check_experiments(model, experiments)
        if self.method not in ("auto", "lm", "lbfgs"):
            raise InputError(f"got {self.method!r}; expected 'auto', 'lm' or 'lbfgs'",
                             key="method")
        auto = check_substeps(self.substeps) == "auto"
        offsets = self.offsets_ = fits_offsets(self.offsets, experiments)
        if self.mesh_check not in (False, True, "auto", "step", "refit", None):
            raise InputError(f"got {self.mesh_check!r}; expected 'auto', 'step', 'refit' or "
                             "False", key="mesh_check")
        if self.mesh_check and self.mesh_check != "auto" and model.elements is None:
            raise InputError("the mesh check refines tetrahedral elements; a spring network's "
                             "constants belong to its mesh", key="mesh_check")
        watch = Stopwatch()       # the kernels' compilation left out
        # the start's error as the fit would simulate it (one step per frame can be unstable
        # for a start that continuous physics fits with substeps)
        initial_steps = (max(auto_substeps(model, e.dt) for e in experiments) if auto
                         else int(self.substeps))
        if auto and self.fitted_at and stable_at_one_step(model, experiments,
                                                          substeps=self.fitted_at):
            initial_steps = int(self.fitted_at)
        self.rms_error_initial_ = rms_error(model, experiments, substeps=initial_steps,
                                            offsets=offsets)
        # one step per frame (the paper's network) is tried only where it is stable
        discrete = not auto or (self.extrapolate and stable_at_one_step(model, experiments))
        self.n_cycles_ = 0
        self.abandoned_ = self._left = False
        self._trace = []        # (E, RMS) of every simulation of the data
        self._last = None       # the last simulation of the data (passes.Last)
        model = stable_start(model, min(e.dt for e in experiments)
                              / (1 if auto and discrete else initial_steps))
        parameters = Parameterization(model, learn_masses=self.learn_masses,
                                      learn_effects=self.learn_effects)
        sensitivity = Sensitivity(parameters, model.length_unit,
                                  offsets=offsets)
        method = self._method(parameters, experiments)
        theta = parameters.initial()
        lower, upper = parameter_bounds(parameters, theta, self.bounds)
        # Parameters that cannot influence any observed node (springs between fixed nodes)
        # keep their start values; the solvers see only the others.
        active = np.setdiff1d(np.arange(parameters.size),
                              structurally_unidentifiable(parameters))

        # a start fitted already (the prior's search's fit at its chosen weight, or the
        # caller's ``fitted_at``) and its substeps
        searched = (theta, self.fitted_at) if auto and self.fitted_at else (None, 0)

        def fit(start, substeps, windows, guard=False):
            """``start`` fitted at ``substeps`` (with ``guard``, at as many more as the values
            need to stay stable; ``self._at``: the substeps it ended at)."""
            self._at = substeps
            if (start is searched[0] and substeps == searched[1]) or self.abandoned_:
                return start    # fitted there already: not twice
            theta = self._fit_stages(sensitivity, experiments, start, substeps, windows,
                                     method, lower, upper, active, guard=guard)
            for _ in range(MAX_MOVES):
                if not self._left:
                    break
                # the values left the step's stable range: on at the steps they need
                self._left, self._at = False, max(
                    auto_substeps(parameters.model(theta), e.dt) for e in experiments)
                theta = self._fit_stages(sensitivity, experiments, theta, self._at, (),
                                         method, lower, upper, active, guard=True)
            return theta

        self._prior_terms, self._prior_scale, self.prior_ = None, 0.0, None
        self.homogeneous_ = self.regions_ = None
        if self.prior is not None:
            steps = initial_steps if auto and not discrete else (1 if auto
                                                                 else int(self.substeps))
            self.homogeneous_ = homogeneous_fit(self, model, experiments)
            theta, fitted = set_prior(self, parameters, sensitivity, experiments, theta, steps,
                                      fit, method, active)
            searched = (theta, steps) if fitted else searched

        self.extrapolated_ = False
        best = (np.inf, theta, initial_steps)
        if discrete:
            substeps = 1 if auto else int(self.substeps)
            theta = fit(theta, substeps, self.windows)     # the network's own step
            best = (passes.rms(sensitivity, experiments, theta, substeps, self._last), theta,
                    substeps)
        exact = best[0] <= 1e-9 * sensitivity.length_unit     # the discrete model fits exactly
        if auto and not exact:
            # Continuous physics: fit with k and 2k substeps and extrapolate the O(h) bias of
            # semi-implicit Euler away (Richardson): θ∞ ≈ 2 θ(2k) - θ(k).
            guard = bool(self.stable_steps)
            theta_k = fit(theta, initial_steps, () if discrete else self.windows, guard=guard)
            k = self._at
            theta_2k = fit(theta_k, 2 * k, (), guard=guard) if self.extrapolate else theta_k
            if not discrete:      # nothing fitted at one step per frame to fall back on
                best = (passes.rms(sensitivity, experiments, theta_2k, self._at, self._last),
                        theta_2k, self._at)
            if self.extrapolate and self._at == 2 * k:
                theta_inf = np.clip(2 * theta_2k - theta_k, lower, upper)
                rms_inf = passes.rms(sensitivity, experiments, theta_inf, 2 * k)
                if rms_inf < best[0]:
                    best = (rms_inf, theta_inf, 2 * k)
                    self.extrapolated_ = True
            if (not discrete and self.extrapolate
                    and stable_at_one_step(parameters.model(best[1]), experiments)):
                # a start unstable at one step per frame may end stable there: data of the
                # paper's network (one step per frame) are fitted exactly only at that step
                theta_1 = fit(best[1], 1, self.windows)
                rms_1 = passes.rms(sensitivity, experiments, theta_1, 1, self._last)
                if rms_1 < best[0]:
                    best = (rms_1, theta_1, 1)
                    self.extrapolated_ = False
        self.rms_error_, theta, self.substeps_ = best
        self.model_ = parameters.model(theta)
        self.parameter_names_ = parameters.names()

        assess(self, sensitivity, parameters, experiments, theta, method)
        self._last = None       # its runs and Jacobian: not kept (nor pickled) with the result
        if self.prior is not None:
            self.regions_ = supported_regions_found(self.model_, self.prior, self.homogeneous_,
                                                    experiments, progress=self.progress)
        self.history_ = np.minimum.accumulate([energy for energy, _ in self._trace])  # best so far
        self.seconds_ = watch.seconds
        return self

    def to_dict(self) -> dict:
        """JSON-ready summary: the common one plus the parameter names, whether the result
        is the continuous-physics extrapolation, standard errors and what the data cannot
        determine."""
        return {**super().to_dict(), "offsets": self.offsets_,
                "extrapolated": self.extrapolated_, "parameters": self.parameter_names_,
                **self.identifiability_.to_dict(), **intervals_dict(self), "prior": self.prior_}

    # -- stages and solvers -----------------------------------------------------------------
    def _method(self, parameters, experiments) -> str:
        if self.method != "auto":
            return self.method
        n_residuals = sum(3 * int(e.observation.seen[1:].sum()) for e in experiments)
        return "lm" if n_residuals * parameters.size <= MAX_JACOBIAN_ENTRIES else "lbfgs"

    def _fit_stages(self, sensitivity, experiments, theta, substeps, windows, method, lower,
                    upper, active, guard=False) -> np.ndarray:
        """Stages of growing difficulty, then the whole trajectory.

        With every free node measured throughout: multiple shooting, windows restarted from
        the measured states. Otherwise (unobserved nodes, gaps) there is no measured state to
        restart from: the stages fit growing beginnings of the recording instead (``window``
        frames after the load starts, doubled until the whole), so a far-off start locks on
        to the early motion before the later oscillations can trap it in a local minimum
        (frames at rest before the load say nothing about the parameters).
        """
        windows = [DEFAULT_WINDOW] if windows is None else list(windows)
        longest = max(e.n_frames for e in experiments)
        shooting = all(e.complete for e in experiments)
        if not shooting and windows:
            moving = max(e.n_frames - e.load_onset for e in experiments)
            lengths = [min(windows)]
            while 2 * lengths[-1] < moving:
                lengths.append(2 * lengths[-1])
            windows = [w for w in lengths if w < moving]
        stages = [w for w in windows if w < longest] + [longest]
        solver = solve_lm if method == "lm" else solve_lbfgs
        progress = Progress(f"gradient fit, {substeps} substep(s)", len(stages), self.progress)
        for stage, window in enumerate(stages):
            if shooting or window == longest:
                data = experiments
                starts = [tuple(range(0, e.n_frames, int(window))) for e in experiments]
                what = f"window {window} frames"
            else:
                data = [e.first_frames(e.load_onset + int(window)) for e in experiments]
                starts = [(0,)] * len(experiments)
                what = f"first {window} frames of motion"
            # a stage before the last only has to bring the next into its basin
            tolerance = (self.tolerance if window == longest
                         else max(self.tolerance, STAGE_TOLERANCE))
            begun = len(self._trace)
            theta = solver(self, sensitivity, data, theta, starts, substeps, lower, upper,
                           active, tolerance,
                           abandon=self.abandon_above if window == longest else None,
                           guard=guard, last=window == longest)
            best = min(self._trace[begun:] or self._trace[-1:])   # this stage's, not earlier
            progress.update(stage + 1, f"{what}, RMS {length_text(best[1])} per marker")
            if self._left:
                break
        return theta

    def _record(self, runs, length_unit: float) -> None:
        """One more simulation of the data: count it and keep its ``E`` and RMS error (per
        marker, over the measured values; gaps hold zero residuals and do not count)."""
        with np.errstate(over="ignore", invalid="ignore"):
            total = sum(float(np.sum(run.residuals**2)) for run in runs)
            rms = passes.per_marker(total, runs, length_unit)
        entry = (0.5 * total, rms) if np.isfinite(total) else (float("inf"), float("inf"))
        self._trace.append(entry)
        self.n_cycles_ += 1

    def _residuals(self, sensitivity, experiments, theta, starts, substeps) -> np.ndarray:
        runs = passes.side_by_side(lambda e, s: sensitivity.run(
            theta, e, substeps=substeps, starts=s), experiments, starts)
        self._record(runs, sensitivity.length_unit)
        self._last = passes.Last(theta.copy(), substeps, starts, runs)
        return passes.stacked(runs)

    def _jacobian(self, sensitivity, experiments, theta, starts, substeps, *,
                  with_runs: bool = False, columns=None, near: bool = False):
        """:func:`._passes.jacobian`, counted as one simulation of the data (and one point
        of ``history_``: its runs carry the residuals at ``theta``); that of the last
        simulation when it computed it at ``theta`` (not counted again) or, with ``near``
        (for the standard errors), a step behind it that the solver found statistically
        nothing (:meth:`._passes.Last.behind`)."""
        last = self._last
        jacobian = (last.jacobian_of(columns, near) if last is not None
                    and last.at(theta, substeps, starts) else None)
        if jacobian is not None:
            runs = last.runs
        else:
            jacobian, runs = passes.jacobian(sensitivity, experiments, theta, starts,
                                             substeps, columns=columns)
            self._record(runs, sensitivity.length_unit)
            self._last = passes.Last(theta.copy(), substeps, starts, runs, jacobian, columns)
        return (jacobian, runs) if with_runs else jacobian
