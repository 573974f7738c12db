"""Passes of the gradient learner over all its experiments: residuals, RMS error and the
Jacobian, one experiment per thread when the compiled kernels do the work (they release the
GIL), and with fewer experiments than cores one experiment's Jacobian columns split over the
cores (:meth:`~neurofuzzy.learn.Sensitivity.run` with ``threads``)."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np


@dataclass
class Run:
    """Result of one pass over an experiment.

    Attributes
    ----------
    positions : (n_frames, n_nodes, 3) float
        Simulated positions (with resets at the window starts).
    residuals : (n_frames - 1, n_rows, 3) float
        ``(simulated - measured) / length_unit`` at frames 1.., per measured row (tracked
        node or embedded marker, :class:`~neurofuzzy.observation.Observation`); 0 in the gaps.
    n_measured : int
        Number of residual values that come from a measurement (not from a gap).
    jacobian : (n_frames - 1, n_rows, 3, n_params) float or None
        ``∂ residuals / ∂ θ`` (forward mode only).
    """

    positions: np.ndarray
    residuals: np.ndarray
    n_measured: int
    jacobian: np.ndarray | None = None

    @property
    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.residuals)))


#: Residuals (in spring lengths) beyond this mean the simulation diverged.
DIVERGED = 1e6


def cores() -> int:
    """Threads the compiled kernels may use: the machine's cores, or fewer when
    ``NUMBA_NUM_THREADS`` says so (fit-many's local workers set it to 1, so that ``n``
    workers use ``n`` cores and no more)."""
    available = os.cpu_count() or 1
    try:
        limit = int(os.environ.get("NUMBA_NUM_THREADS", available))
    except ValueError:
        return available
    return max(1, min(available, limit))


def side_by_side(run, experiments, starts) -> list:
    """``run(experiment, starts)`` for every experiment: in threads, one per core
    (:func:`cores`; the compiled kernels release the GIL)."""
    workers = min(len(experiments), cores())
    if workers < 2:
        return [run(e, s) for e, s in zip(experiments, starts)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(run, experiments, starts))


@dataclass
class Last:
    """The last simulation of the data a learner ran: where (``theta``, ``substeps``, window
    ``starts``), its runs and, for a Jacobian pass, the Jacobian of ``columns`` (None: all).
    A pass asked for at the same place again is read from here instead of run twice.
    ``jacobian_from``: the point the Jacobian was taken at when that is not ``theta`` but
    one statistically indistinguishable from it (:meth:`behind`)."""

    theta: np.ndarray
    substeps: int
    starts: list
    runs: list
    jacobian: np.ndarray | None = None
    columns: np.ndarray | None = None
    jacobian_from: np.ndarray | None = None

    def at(self, theta, substeps, starts) -> bool:
        return (self.substeps == substeps and list(self.starts) == list(starts)
                and np.array_equal(self.theta, theta))

    def behind(self, taken: Last) -> Last:
        """This pass with the Jacobian of ``taken``, a Jacobian pass at the point the solver
        stepped here from by a step that is statistically nothing (below a tenth of that
        Jacobian's standard errors, or onto the rounding floor:
        :attr:`._lm.Solution.jacobian_behind`): for the standard errors here, not for
        another step (:meth:`jacobian_of` gives it only when asked for ``near``)."""
        if (self.jacobian is not None or taken.jacobian is None
                or taken.substeps != self.substeps or list(taken.starts) != list(self.starts)):
            return self
        return Last(self.theta, self.substeps, self.starts, self.runs, taken.jacobian,
                    taken.columns, taken.theta.copy())

    def jacobian_of(self, columns, near: bool = False) -> np.ndarray | None:
        """The Jacobian's ``columns`` (all for None; sorted), or None when not computed
        (nor when it was taken a step behind, unless ``near``: :meth:`behind`)."""
        if self.jacobian is None or (self.jacobian_from is not None and not near):
            return None
        size = self.theta.size
        stored = np.arange(size) if self.columns is None else np.asarray(self.columns)
        if len(stored) == size:
            return self.jacobian if columns is None else self.jacobian[:, columns]
        wanted = np.arange(size) if columns is None else np.asarray(columns)
        return self.jacobian if np.array_equal(stored, wanted) else None


def stacked(runs) -> np.ndarray:
    """The residuals of ``runs`` as one vector; all :data:`DIVERGED` when a simulation diverged
    (a huge cost the solver rejects)."""
    residuals = np.concatenate([run.residuals.ravel() for run in runs])
    if not np.all(np.abs(residuals) < DIVERGED):
        return np.full_like(residuals, DIVERGED)
    return residuals


def rms(sensitivity, experiments, theta, substeps, last: Last | None = None) -> float:
    """:func:`~neurofuzzy.experiment.rms_error` of ``theta`` by the compiled forward pass
    (read from ``last`` when that simulated the data there)."""
    starts = [(0,)] * len(experiments)
    if last is not None and last.at(theta, substeps, starts):
        runs = last.runs
    else:
        runs = side_by_side(lambda e, s: sensitivity.run(
            theta, e, substeps=substeps, starts=s), experiments, starts)
    with np.errstate(over="ignore", invalid="ignore"):
        total = sum(float(np.sum(run.residuals**2)) for run in runs)
        value = per_marker(total, runs, sensitivity.length_unit)
    return float(value) if np.isfinite(value) else float("inf")


def per_marker(total: float, runs, length_unit: float) -> float:
    """The RMS error per marker (metres) of a sum of squared residuals ``total`` (in length
    units) over the values ``runs`` measured (gaps hold zero residuals and do not count)."""
    count = sum(run.n_measured for run in runs)
    return float(np.sqrt(3.0 * total / count)) * length_unit if count else 0.0


def jacobian(sensitivity, experiments, theta, starts, substeps, *, columns=None):
    """``(J, runs)``: the Jacobian of the residuals of all experiments (only ``columns``
    when given; entries of a diverged simulation set to 0) and the runs that made it (their
    residuals are those at ``theta``)."""
    # fewer experiments than cores: each splits its columns over its share of the cores
    threads = max(1, cores() // len(experiments))
    runs = side_by_side(lambda e, s: sensitivity.run(
        theta, e, substeps=substeps, starts=s, tangents=True, threads=threads),
        experiments, starts)
    blocks = [run.jacobian.reshape(-1, theta.size) for run in runs]
    if columns is not None and len(columns) < theta.size:
        blocks = [block[:, columns] for block in blocks]
    J = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
    # (min and max: two passes over a large array, no temporary copies)
    if J.size and not -DIVERGED**2 < J.min() <= J.max() < DIVERGED**2:
        J = np.where(np.abs(J) < DIVERGED**2, J, 0.0)
    return J, runs
