"""What every learner shares: input checks, the tied parameterisation, error measures, progress."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, UnstableTimeStepError
from ..experiment import Experiment
from ..model import SpringMassModel
from ..simulate import simulate

__all__ = ["Learner", "rms_error", "simulate_like", "check_experiments", "TiedSprings",
           "Progress"]


def check_experiments(model: SpringMassModel,
                      experiments: Experiment | Sequence[Experiment]) -> list[Experiment]:
    """Return ``experiments`` as a list after checking they describe ``model``'s object."""
    if isinstance(experiments, Experiment):
        experiments = [experiments]
    experiments = list(experiments)
    if not experiments:
        raise InputError("no experiments given", key="experiments")
    for experiment in experiments:
        mesh = experiment.mesh
        if mesh.n_nodes != model.n_nodes:
            raise InputError(f"has {mesh.n_nodes} nodes; the model has {model.n_nodes}",
                             source=experiment.source, key="rest_positions")
        if mesh.n_springs != model.n_springs or not np.array_equal(mesh.springs,
                                                                   model.mesh.springs):
            raise InputError(f"its {mesh.n_springs} springs differ from the model's "
                             f"{model.n_springs}; all experiments must share one topology",
                             source=experiment.source, key="springs")
        if not np.array_equal(mesh.fixed, model.mesh.fixed):
            raise InputError("its fixed nodes differ from the model's", source=experiment.source,
                             key="fixed")
    return experiments


def simulate_like(model: SpringMassModel, experiment: Experiment,
                  substeps: int = 1) -> np.ndarray:
    """(n_frames, n_nodes, 3): ``model`` run freely under ``experiment``'s load and start."""
    return simulate(model, dt=experiment.dt, n_frames=experiment.n_frames,
                    external_forces=experiment.external_forces,
                    initial_positions=experiment.initial_positions(),
                    substeps=substeps, check_stability=False).positions


def rms_error(model: SpringMassModel, experiments: Experiment | Sequence[Experiment], *,
              substeps: int = 1) -> float:
    """Root-mean-square node distance between free simulation and measurement.

    Over all experiments, frames 1 onwards, and the nodes that are measured (observed, not in a
    gap) and not fixed: ``sqrt(mean |p_sim - p_measured|²)``, simulating with ``substeps``
    steps per frame. Infinite when the simulation diverges.
    """
    experiments = check_experiments(model, experiments)
    total, count = 0.0, 0
    for experiment in experiments:
        try:
            with np.errstate(all="ignore"):
                simulated = simulate_like(model, experiment, substeps)
        except UnstableTimeStepError:
            return float("inf")
        tracked = experiment.tracked_frames()[1:]
        diff = simulated[1:][tracked] - experiment.positions[1:][tracked]
        total += float(np.sum(diff * diff))
        count += diff.shape[0]
    value = np.sqrt(total / max(count, 1))
    return float(value) if np.isfinite(value) else float("inf")


@dataclass(frozen=True)
class TiedSprings:
    """Map between per-spring values and the shared values of tie groups.

    A tied group shares one value ``shared[k]``; spring ``j`` gets ``shared[tie[j]] * ratio[j]``
    where ``ratio`` keeps the proportions the springs started with (1 for equal starts).
    """

    tie: np.ndarray
    n_ties: int

    @classmethod
    def of(cls, model: SpringMassModel) -> TiedSprings:
        return cls(model.spring_tie, model.n_ties)

    def split(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(shared, ratio)`` with ``shared`` the group means of ``values``."""
        count = np.bincount(self.tie, minlength=self.n_ties)
        shared = np.bincount(self.tie, values, self.n_ties) / np.maximum(count, 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(shared[self.tie] > 0, values / shared[self.tie], 1.0)
        return shared, ratio

    def reduce(self, per_spring: np.ndarray, ratio: np.ndarray) -> np.ndarray:
        """Chain rule: derivative by ``shared`` from derivatives by per-spring values."""
        return np.bincount(self.tie, per_spring * ratio, self.n_ties)


class Progress:
    """Progress of long work on stderr (``paper learner: 12/100 E=0.0312 (1.2 s)``).

    On a terminal one line is rewritten in place; otherwise a line is printed at most every
    ``interval`` seconds and at the end. Quiet when ``enabled`` is False.
    """

    def __init__(self, label: str, total: int, enabled: bool = True, interval: float = 2.0):
        self.label, self.total, self.enabled = label, total, enabled
        self.start = time.perf_counter()
        self.last = -np.inf
        self.done = False
        self.tty = enabled and sys.stderr.isatty()
        self.interval = 0.2 if self.tty else interval

    def update(self, done: int, message: str = "") -> None:
        if not self.enabled or self.done:
            return
        now = time.perf_counter()
        final = done >= self.total
        if now - self.last < self.interval and not final:
            return
        self.last = now
        self.done = final
        text = f"{self.label}: {done}/{self.total} {message} ({now - self.start:.1f} s)"
        if self.tty:
            print("\r" + text, end="\n" if final else "", file=sys.stderr, flush=True)
        else:
            print(text, file=sys.stderr, flush=True)


class Learner:
    """Base of the learners: ``fit(model, experiments)`` returns ``self`` with results in ``*_``.

    Attributes set by ``fit``
    -------------------------
    model_ : SpringMassModel
        The fitted model.
    history_ : (n_cycles,) float
        Error after (or during) every cycle, as each learner defines it.
    rms_error_initial_, rms_error_ : float
        :func:`rms_error` of the start model and of the fitted model.
    n_cycles_ : int
        Complete simulations of the training data the fit used.
    seconds_ : float
        Wall time of ``fit``.
    """

    def to_dict(self) -> dict:
        """JSON-ready summary of the fitted model and the fit."""
        model = self.model_
        return {
            "stiffness": model.spring_stiffness.tolist(),
            "damping": model.spring_damping.tolist(),
            "masses": model.node_mass.tolist(),
            "effects": [{"name": e.name, "parameters": e.params.tolist()} for e in model.effects],
            "rms_error": self.rms_error_,
            "rms_error_initial": self.rms_error_initial_,
            "cycles": self.n_cycles_,
            "seconds": self.seconds_,
            "history": np.asarray(self.history_).tolist(),
        }
