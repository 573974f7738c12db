"""Residuals of a fitted model: one-step residual forces from the measured states, trajectory
errors, per-node and per-spring localisation, the noise floor, and force templates."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import savgol_filter

from ..errors import InputError
from ..experiment import Experiment, simulate_like
from ..forces import incidence
from ..forces.springs import parameter_templates, spring_constants, spring_state
from ..learn import element_directions
from ..model import Model
from ..noise import marker_noise
from ..simulation import internal_forces

__all__ = ["Residuals", "Samples", "residual_analysis", "templates", "model_templates",
           "spring_templates", "orthonormal"]

#: Residual forces below this fraction of the inertial forces count as numerical noise.
RELATIVE_FLOOR = 1e-3


def measured_states(positions: np.ndarray, experiment: Experiment, discrete: bool, smooth: bool):
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
    samples : Samples
        The measured states and residual forces behind these numbers.
    kind : {"force", "position"}
        One-step residual forces (N; ``per_node``, ``per_frame`` and ``noise_floor`` are
        forces), or marker errors of the free run (m; the diagnosis in trajectory space,
        :mod:`.trajectory`).
    """

    force: np.ndarray
    per_node: np.ndarray
    per_node_error: np.ndarray
    per_spring: np.ndarray
    per_frame: np.ndarray
    noise_floor: float
    marker_noise: float
    samples: Samples = field(repr=False, default=None)
    kind: str = "force"


@dataclass
class Samples:
    """Measured states and residual forces of all experiments, flattened."""

    experiment: list         # per experiment: dict(p, v, a, rows, residual)
    force: np.ndarray        # (n_samples, 3)
    noise_floor: float
    marker_noise: float


def sample(model: Model, experiments, substeps: int) -> Samples:
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
        noise = marker_noise(measured[:, rows] - free_run[:, rows],
                              measured[:, rows] - measured[:1, rows])
        loads = experiment.forces_per_frame()[1:-1]

        def residual_of(positions):
            p, v, a = measured_states(positions, experiment, substeps == 1, smooth=noise > 0)
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
    return Samples(per_experiment, np.concatenate(forces),
                    float(np.sqrt(np.mean(np.square(floors)))), float(np.mean(noises)))


def templates(model, samples: Samples, force_of) -> np.ndarray:
    """Stack a force template ``force_of(p, v) -> (n_nodes, k, 3)`` over all samples → (n, k)."""
    blocks = []
    for data in samples.experiment:
        rows = data["rows"]
        per_frame = [force_of(data["p"][t], data["v"][t])[rows] for t in range(len(data["p"]))]
        stacked = np.stack(per_frame).transpose(2, 0, 1, 3)        # (k, T', F, 3)
        blocks.append(stacked.reshape(stacked.shape[0], -1))
    return np.concatenate(blocks, axis=1).T


def model_templates(model, samples) -> np.ndarray:
    """Templates of the model's own tied parameters (their log-derivatives): spring stiffness
    and viscosity, and for element models every element tie group's E, ν and η."""
    maps = incidence(model.mesh)
    springs, elements = model.springs, model.elements
    directions = None if elements is None else element_directions(model)

    def force_of(p, v):
        columns = []
        if springs is not None:
            per_unit = springs.parameter_templates(springs.state(model, p, v))
            columns += [maps.group_sums(getattr(springs, name)[:, None] * per_unit[name],
                                        springs.tie, springs.n_ties)
                        for name in ("stiffness", "damping")]
        if elements is not None:
            columns.append(elements.parameter_jvp(model, p, v, directions))
        return np.concatenate(columns, axis=1)

    return templates(model, samples, force_of)


def spring_templates(model, samples) -> np.ndarray:
    """(n, n_springs): every spring's own stiffness template ``s_j (l - L0) u`` (node a +,
    node b -), in the rows of :func:`templates`; all frames at once, each spring written at
    its two nodes only (a spring's column is zero elsewhere)."""
    a, b = model.mesh.springs[:, 0], model.mesh.springs[:, 1]
    spring = np.arange(model.n_springs)
    stiffness = spring_constants(model)[0]
    blocks = []
    for data in samples.experiment:
        force = np.stack([stiffness[:, None] * parameter_templates(
            spring_state(model, p, v))["stiffness"] for p, v in zip(data["p"], data["v"])])
        # force: (frames, springs, 3)
        n_rows = int(np.count_nonzero(data["rows"]))
        row = np.full(model.n_nodes, -1)
        row[data["rows"]] = np.arange(n_rows)
        out = np.zeros((len(force), n_rows, 3, model.n_springs))
        for node, sign in ((a, 1.0), (b, -1.0)):
            seen = row[node] >= 0
            out[:, row[node][seen], :, spring[seen]] += sign * force[:, seen].transpose(1, 0, 2)
        blocks.append(out.reshape(-1, model.n_springs))
    return np.concatenate(blocks, axis=0)


def residual_analysis(model: Model, experiments: Sequence[Experiment], *,
                      substeps: int = 1) -> Residuals:
    """Residual forces, trajectory errors, localisation and noise floor of a fitted model.

    ``substeps`` is the integration the model was fitted with: 1 means the paper's discrete
    network (residuals with its backward-difference velocity), more means continuous physics
    (central differences).
    """
    samples = sample(model, experiments, substeps)
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
    per_spring = spring_mismatch(model, samples)
    residuals = Residuals(force=samples.force, per_node=per_node, per_node_error=per_node_error,
                          per_spring=per_spring, per_frame=per_frame,
                          noise_floor=samples.noise_floor, marker_noise=samples.marker_noise,
                          samples=samples)
    return residuals


def spring_mismatch(model, samples) -> np.ndarray:
    """Relative stiffness correction of every spring that best explains the residual (what the
    model's own tied parameters cannot explain)."""
    basis = orthonormal(model_templates(model, samples))
    columns = spring_templates(model, samples)
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


def orthonormal(columns: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the span of ``columns`` (zero columns dropped)."""
    norms = np.linalg.norm(columns, axis=0)
    usable = columns[:, norms > 0] / norms[norms > 0]
    if usable.shape[1] == 0:
        return np.zeros((columns.shape[0], 0))
    q, r = np.linalg.qr(usable)
    keep = np.abs(np.diag(r)) > 1e-10
    return q[:, keep]
