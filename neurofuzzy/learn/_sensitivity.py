"""Exact derivatives of the discrete simulator (semi-implicit Euler, eqs. 3.1–3.6).

Two ways through the same step ``F = F(p, v; θ) + f_ext``, ``v' = v + h W F``, ``p' = p + h v'``
(``W = 1/m``, zero at fixed nodes):

- forward (tangent-linear) sensitivities ``∂p(t)/∂θ`` for all parameters at once, giving the
  Jacobian of the residuals for Gauss–Newton / Levenberg–Marquardt and standard errors;
- the discrete adjoint (reverse mode), giving the gradient of ``½ Σ |r|²`` in one backward
  sweep whatever the number of parameters, for L-BFGS on large problems.

Both run in the compiled kernels (:mod:`neurofuzzy.kernels.sensitivity`,
:mod:`neurofuzzy.kernels.adjoint`) and are exact for the discrete model: the tests check them
against central finite differences and against the numpy reference
(``tests/numpy_reference.py``). Trajectories may be cut into windows whose first frame is reset to
the measurement (multiple shooting, the paper's teacher forcing): positions from the data and
velocities from the measured positions' backward difference at one substep a frame, their
central difference at more (:meth:`Sensitivity._window_state`).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..errors import InputError
from ..experiment import Experiment
from ..observation import remove_offsets
from ..simulation.threads import element_threads
from ._compiled import CompiledModel
from ._compiled_gradient import compiled_gradient
from ._passes import Run, cores
from ._parameters import Parameterization

__all__ = ["Sensitivity", "Run"]


class Sensitivity:
    """Simulation with derivatives for one parameterisation (arrays reused across passes).

    Parameters
    ----------
    parameters : Parameterization
        Which parameters are free.
    length_unit : float
        Residuals are divided by it (dimensionless residuals; e.g. the mean spring length).
    offsets : bool
        Fit every measured row's constant offset (the markers' rest positions as nuisance
        parameters, :func:`~neurofuzzy.observation.remove_offsets`): residuals, Jacobians and
        gradients are those of the projected residuals.
    """

    def __init__(self, parameters: Parameterization, length_unit: float, *,
                 offsets: bool = False):
        self.parameters = parameters
        self.offsets = bool(offsets)
        self.length_unit = float(length_unit)
        self.n_nodes = parameters.base.n_nodes

    def _window_state(self, experiment: Experiment, start: int, substeps: int = 1):
        """Positions and velocities at a window start, from the measurement: the velocity
        by the backward difference of the measured positions at one substep a frame (the
        paper's network, for which it is exact), by the central difference with more (the
        backward one is then the frame's mean velocity, half a frame late: it left the
        windows stage of a fit of 10,368 tetrahedra at η 30 % low)."""
        if start == 0:
            return experiment.initial_positions(), experiment.initial_velocities()
        if not experiment.complete:
            raise InputError("windows (multiple shooting) need every free node measured at "
                             "every frame",
                             source=experiment.source, key="observed")
        p = experiment.positions[start].copy()
        if substeps > 1 and start + 1 < experiment.n_frames:
            v = (experiment.positions[start + 1] - experiment.positions[start - 1]) / (
                2.0 * experiment.dt)
        else:
            v = (experiment.positions[start] - experiment.positions[start - 1]) / experiment.dt
        v[experiment.mesh.fixed] = 0.0
        return p, v

    # -- forward passes -----------------------------------------------------------------------
    def run(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
            starts=(0,), tangents: bool = False, threads: int | None = 1) -> Run:
        """Simulate ``experiment`` with parameters ``theta``; optionally forward sensitivities
        on up to ``threads`` threads (None: the cores the kernels may use): split by windows,
        by the elements of a large model, or by columns (each thread simulates the state and
        carries its share of the tangents)."""
        threads = (cores() if threads is None else threads) if tangents else 1
        model = self.parameters.model(theta)
        states = {t: self._window_state(experiment, t, substeps)
                  for t in set(int(t) for t in starts) | {0}}
        compiled = CompiledModel(self.parameters, model)
        # the ways to spread one run over threads, the best first: whole windows (when no
        # element relaxes, no internal variables go on from one window to the next; no thread
        # simulates the state of another's frames), the element passes of a large model run
        # from the main thread (every column in one run), or shares of the columns (each
        # thread simulates the state as well, so only shares of at least one column each)
        spans = (_window_spans(sorted(states), experiment.n_frames, threads)
                 if tangents and threads > 1 and not model.n_relaxation_terms else [])
        chunks = (min(threads, element_threads(compiled.n_elements))
                  if tangents and len(spans) < 2 else 1)
        bounds = np.linspace(0, compiled.n_params, min(threads, compiled.n_params) + 1)
        shares = ([(int(a), int(b)) for a, b in zip(bounds[:-1].round(), bounds[1:].round())]
                  if chunks < 2 else [])

        if len(spans) > 1 or len(shares) > 1:      # each thread writes its part of one array
            n_frames = experiment.n_frames
            jacobian = np.empty((n_frames - 1, experiment.observation.n_rows, 3,
                                 compiled.n_params))
            positions = np.empty((n_frames, model.n_nodes, 3))
            parts = ([{"frames": span} for span in spans] if len(spans) > 1
                     else [{"columns": columns} for columns in shares])

            def part(options):
                return compiled.run(experiment, states, substeps=substeps,
                                    scale=1.0 / self.length_unit, tangents=True,
                                    jacobian=jacobian, positions=positions, **options)

            with ThreadPoolExecutor(max_workers=len(parts)) as pool:
                list(pool.map(part, parts))
        else:
            positions, jacobian = compiled.run(experiment, states, substeps=substeps,
                                               scale=1.0 / self.length_unit,
                                               tangents=tangents, chunks=chunks)
        observation = experiment.observation
        with np.errstate(over="ignore", invalid="ignore"):
            residuals = self._projected(observation.residuals(positions)[1:]
                                        / self.length_unit, observation.seen[1:], jacobian)
        return Run(positions=positions, residuals=residuals,
                   n_measured=3 * int(observation.seen[1:].sum()), jacobian=jacobian)

    def _projected(self, residuals, seen, jacobian=None) -> np.ndarray:
        """``residuals`` (frames 1..) with the rows' offsets removed when they are fitted
        (and ``jacobian`` projected in place)."""
        if not self.offsets:
            return residuals
        return remove_offsets(residuals, seen, jacobian)

    # -- reverse pass -------------------------------------------------------------------------
    def gradient(self, theta: np.ndarray, experiment: Experiment, *, substeps: int = 1,
                 starts=(0,), cotangent=None) -> tuple[float, np.ndarray, Run]:
        """``(½ Σ r², ∂/∂θ, run)`` by the discrete adjoint (one forward, one backward sweep).

        ``cotangent`` (shaped as the run's residuals): pull it back
        instead of the residuals, for ``Jᵀ cotangent`` (every parameter's column against
        one vector, in one backward sweep)."""
        return compiled_gradient(self, self.parameters.model(theta), experiment, substeps,
                                 starts, cotangent)

    def _frame_residuals(self, observation, positions) -> np.ndarray:
        """(n_frames, n_rows, 3) residuals in length units, frame 0 included (zero), the
        later frames projected when offsets are fitted (the adjoint's seed)."""
        residuals = observation.residuals(positions) / self.length_unit
        residuals[1:] = self._projected(residuals[1:], observation.seen[1:])
        return residuals


def _window_spans(starts: list[int], n_frames: int, threads: int) -> list[tuple[int, int]]:
    """Frames ``(a, b)`` of up to ``threads`` runs of whole windows (``starts`` the windows'
    first frames, ascending), cut at the window starts nearest to equal shares."""
    inner = np.array(starts[1:])
    cuts = set()
    for k in range(1, threads):
        if inner.size:
            ideal = starts[0] + k * (n_frames - starts[0]) / threads
            cuts.add(int(inner[np.argmin(np.abs(inner - ideal))]))
    bounds = [starts[0], *sorted(cuts), n_frames]
    return list(zip(bounds[:-1], bounds[1:]))
