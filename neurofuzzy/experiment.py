"""Measured (or simulated) node trajectories of one load case: the :class:`Experiment`.

This is the in-memory form of the experiment file contract (docs/formats.md); :mod:`neurofuzzy.io`
reads and writes it as ``.npz``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .errors import InputError, UnstableTimeStepError
from .mesh import Mesh
from .mesh.core import check_coordinates
from .model import Model, term_values
from .observation import EmbeddedMarkers, Observation, remove_offsets, require_motion
from .simulation import simulate

__all__ = ["Experiment", "simulate_experiment", "check_experiments", "simulate_like",
           "require_node_observations", "duration",
           "rms_error"]


@dataclass(frozen=True, eq=False)
class Experiment:
    """Node trajectories of an object under a known load.

    Parameters
    ----------
    mesh : Mesh
        Rest positions, springs, spring groups and fixed nodes.
    dt : float
        Time between recorded frames.
    positions : (n_frames, n_nodes, 3) float
        Measured positions; ``positions[0]`` is the initial state. Unobserved nodes may hold NaN,
        and so may an observed node at a frame where its marker was not seen (a gap: occluded
        marker, dropped frame). Learners and the diagnosis treat a gap as "not measured at that
        frame", never interpolate it. Frame 0 must be complete for observed nodes.
    external_forces : (n_nodes, 3) or (n_frames, n_nodes, 3) float, optional
        Applied load (constant, or ``external_forces[t]`` acting from frame t to t + 1).
    observed : (n_nodes,) bool, optional
        Nodes that have measurements (default: all).
    node_mass : (n_nodes,) float, optional
        Known node masses (the paper's "predefined masses"; the file key is ``masses``).
    truth : dict of str to array, optional
        Ground truth of synthetic data (``true_stiffness`` …): reported, never read by a fitter.
    source : str
        Where the data came from (a file name), used in messages.
    markers : EmbeddedMarkers, optional
        Markers anywhere in the object, observed through the tetrahedra containing them
        (:mod:`neurofuzzy.observation`). When given, the markers are what is measured: nodes
        need not be observed (``positions`` may be all NaN), and the learners compare the
        markers' interpolated positions with their measurements.
    driven : tuple of DrivenPath, optional
        Node sets a stage moved, one displacement from rest per frame (a plate ramped).
    reaction : (n_frames, 3) float, optional
        A load cell's reading per frame (N): the first driven set's reaction, or the tool's.
    tool : ToolPath, optional
        A rigid tool pressed along a path, one position per frame. Recordings with these
        are fitted through implicit steps (:func:`~neurofuzzy.learn.implicit_fit.fit_implicit`).
    """

    mesh: Mesh
    dt: float
    positions: np.ndarray
    external_forces: np.ndarray | None = None
    observed: np.ndarray | None = None
    node_mass: np.ndarray | None = None
    truth: dict = field(default_factory=dict)
    source: str = "<experiment>"
    markers: EmbeddedMarkers | None = None
    driven: tuple = ()
    reaction: np.ndarray | None = None
    tool: object = None

    def __post_init__(self):
        src = self.source
        n_nodes = self.mesh.n_nodes
        dt = np.asarray(self.dt)
        if dt.shape != () or not np.issubdtype(dt.dtype, np.number) or not np.isfinite(dt) \
                or float(dt) <= 0:
            shown = float(dt) if dt.shape == () and np.issubdtype(dt.dtype, np.number) \
                else self.dt
            raise InputError(f"got {shown!r}; expected a positive number (seconds between "
                             "frames)", source=src, key="dt")
        positions = _float_array(self.positions, src, "positions")
        if positions.ndim != 3 or positions.shape[1:] != (n_nodes, 3):
            raise InputError(f"got shape {positions.shape}; expected (n_frames, n_nodes, 3) "
                             f"with n_nodes = {n_nodes} (the length of rest_positions)",
                             source=src, key="positions")
        if positions.shape[0] < 2:
            raise InputError("needs at least 2 frames", source=src, key="positions")
        if self.observed is None:
            observed = np.ones(n_nodes, dtype=bool)
        else:
            observed = np.asarray(self.observed)
            if observed.dtype != bool or observed.shape != (n_nodes,):
                raise InputError(f"got {observed.dtype} of shape {observed.shape}; expected bool "
                                 f"of shape (n_nodes,) = ({n_nodes},)", source=src,
                                 key="observed")
            if not observed.any() and self.markers is None:
                raise InputError("no node is observed", source=src, key="observed")
        if self.markers is not None:
            if not isinstance(self.markers, EmbeddedMarkers):
                raise InputError("expected EmbeddedMarkers", source=src, key="markers")
            if self.markers.positions.shape[0] != positions.shape[0]:
                raise InputError(f"has {self.markers.positions.shape[0]} frames; the node "
                                 f"positions have {positions.shape[0]}", source=src,
                                 key="marker_positions")
            try:
                self.markers.operator(n_nodes)
            except InputError as error:
                raise InputError(error.detail, source=src, key=error.key) from None
            if not np.isfinite(self.markers.positions[0]).all():
                raise InputError("every marker needs a position at frame 0 (the initial "
                                 "state)", source=src, key="marker_positions")
        require_motion(self.mesh, observed, self.markers, src)
        try:
            check_coordinates(positions, "positions")
            if self.markers is not None:
                check_coordinates(self.markers.positions, "marker_positions")
        except InputError as error:
            raise InputError(error.detail, source=src, key=error.key) from None
        if np.isinf(positions[:, observed]).any():
            frame, node = np.argwhere(np.isinf(positions[:, observed]).any(axis=-1))[0]
            node = np.flatnonzero(observed)[node]
            raise InputError(f"infinite value at frame {frame}, node {node}; use NaN for a "
                             "position that was not measured", source=src, key="positions")
        missing_at_start = observed & ~np.isfinite(positions[0]).all(axis=-1)
        if missing_at_start.any():
            node = int(np.flatnonzero(missing_at_start)[0])
            raise InputError(f"node {node} is marked observed but has no position at frame 0 "
                             "(the initial state); start the recording where every observed "
                             "node is seen, or mark the node unobserved", source=src,
                             key="positions")
        # a marker is seen or not: a partly NaN position counts as not measured
        gaps = ~np.isfinite(positions).all(axis=-1, keepdims=True)
        positions = np.where(gaps, np.nan, positions)
        forces = None
        if self.external_forces is not None:
            forces = _float_array(self.external_forces, src, "external_forces")
            if forces.shape not in ((n_nodes, 3), (positions.shape[0], n_nodes, 3)):
                raise InputError(f"got shape {forces.shape}; expected (n_nodes, 3) = "
                                 f"({n_nodes}, 3) or (n_frames, n_nodes, 3) = "
                                 f"({positions.shape[0]}, {n_nodes}, 3)", source=src,
                                 key="external_forces")
            if not np.all(np.isfinite(forces)):
                raise InputError("contains NaN or infinite values", source=src,
                                 key="external_forces")
        masses = None
        if self.node_mass is not None:
            masses = _float_array(self.node_mass, src, "masses")
            if masses.shape != (n_nodes,):
                raise InputError(f"got shape {masses.shape}; expected (n_nodes,) = ({n_nodes},)",
                                 source=src, key="masses")
            if not np.all(np.isfinite(masses)) or np.any(masses <= 0):
                raise InputError("must be positive and finite", source=src, key="masses")
        if self.driven or self.tool is not None or self.reaction is not None:
            from .paths import check_moving

            driven, reaction = check_moving(self.mesh, self.driven, self.tool, self.reaction,
                                            positions.shape[0], src)
            object.__setattr__(self, "driven", driven)
            object.__setattr__(self, "reaction", reaction)
        object.__setattr__(self, "dt", float(dt))
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "observed", observed)
        object.__setattr__(self, "external_forces", forces)
        object.__setattr__(self, "node_mass", masses)
        object.__setattr__(self, "truth", dict(self.truth))

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.mesh.n_nodes

    def forces_per_frame(self) -> np.ndarray:
        """(n_frames, n_nodes, 3) external force, zero where none is given."""
        if self.external_forces is None:
            return np.zeros((self.n_frames, self.n_nodes, 3))
        return np.broadcast_to(self.external_forces, (self.n_frames, self.n_nodes, 3))

    @property
    def load_onset(self) -> int:
        """The first frame whose external load is not zero (0 without a load): the frames
        before it are at rest."""
        if self.external_forces is None or np.ndim(self.external_forces) < 3:
            return 0
        loaded = np.flatnonzero(np.abs(self.external_forces).max(axis=(1, 2)) > 0)
        return int(loaded[0]) if loaded.size else 0

    def initial_positions(self) -> np.ndarray:
        """(n_nodes, 3) start state: frame 0, with rest positions for unobserved nodes."""
        start = np.array(self.mesh.rest_positions, dtype=float)
        start[self.observed] = self.positions[0, self.observed]
        return start

    def initial_velocities(self) -> np.ndarray:
        """(n_nodes, 3) start velocity: zero (the contract's objects start at rest)."""
        return np.zeros((self.n_nodes, 3))

    def replace(self, **changes) -> Experiment:
        return replace(self, **changes)

    def first_frames(self, n_frames: int) -> Experiment:
        """The experiment cut to its first ``n_frames`` frames (loads and markers too)."""
        forces = self.external_forces
        if forces is not None and forces.ndim == 3:
            forces = forces[:n_frames]
        markers = self.markers
        if markers is not None:
            markers = replace(markers, positions=markers.positions[:n_frames])
        cut = {"driven": tuple(replace(d, displacement=d.displacement[:n_frames])
                               for d in self.driven),
               "reaction": None if self.reaction is None else self.reaction[:n_frames],
               "tool": self.tool and self.tool.first_rows(n_frames)}
        return self.replace(positions=self.positions[:n_frames], external_forces=forces,
                            markers=markers, **cut)

    def tracked(self) -> np.ndarray:
        """(n_nodes,) bool: nodes whose error counts (observed and not fixed)."""
        return self.observed & self.mesh.free

    def measured(self) -> np.ndarray:
        """(n_frames, n_nodes) bool: node i has a measured position at frame t.

        False for unobserved nodes and for the gaps of observed ones.
        """
        return self.observed[None, :] & np.isfinite(self.positions).all(axis=-1)

    def tracked_frames(self) -> np.ndarray:
        """(n_frames, n_nodes) bool: the (frame, node) pairs whose error counts: measured and
        not fixed."""
        return self.measured() & self.mesh.free[None, :]

    @property
    def complete(self) -> bool:
        """Every free node is measured at every frame (no unobserved nodes, no gaps)."""
        return bool(np.all(self.measured() | ~self.mesh.free[None, :]))

    @cached_property
    def observation(self) -> Observation:
        """What is measured, as one linear operator on the node positions: the tracked
        nodes (observed, not fixed), or the embedded markers."""
        if self.markers is not None:
            operator = self.markers.operator(self.n_nodes)
            # a marker that moves only with fixed nodes never moves: it does not count
            moves = np.asarray(operator[:, self.mesh.free].sum(axis=1)).ravel() > 1e-12
            return Observation(operator, self.markers.positions,
                               np.isfinite(self.markers.positions).all(axis=-1) & moves)
        rows = np.flatnonzero(self.tracked())
        operator = sp.csr_matrix((np.ones(len(rows)), (np.arange(len(rows)), rows)),
                                 shape=(len(rows), self.n_nodes))
        return Observation(operator, self.positions[:, rows], self.tracked_frames()[:, rows])


def model_truth(model) -> dict[str, np.ndarray]:
    """The ground truth a synthetic experiment records of the model that made it: every
    term's own parameters (:func:`~neurofuzzy.model.term_values`) as ``true_<name>`` and
    ``true_masses``."""
    return {**{f"true_{name}": value for name, value in term_values(model).items()},
            "true_masses": model.node_mass}


def simulate_experiment(model: Model, *, dt: float, n_frames: int,
                        external_forces: np.ndarray | None = None, substeps: int | str = 1,
                        noise: float = 0.0, seed: int | None = 0,
                        observed: np.ndarray | None = None,
                        with_masses: bool = True, source: str = "<simulated>",
                        integrator: str = "explicit") -> Experiment:
    """Synthetic data: simulate ``model`` from rest and record it as an :class:`Experiment`.

    Parameters
    ----------
    model : Model
        The "true" model; its parameters are stored as ``truth``.
    dt, n_frames, external_forces, substeps
        As in :func:`neurofuzzy.simulation.simulate`.
    noise : float
        Standard deviation of Gaussian marker noise added to every recorded coordinate
        (frames 1 onwards), in length units.
    seed : int, optional
        Seed of the noise generator.
    observed : (n_nodes,) bool, optional
        Nodes to record; the others are stored as NaN.
    with_masses : bool
        Store the true masses as known ``masses``.
    integrator : {"explicit", "implicit", "bdf2"}
        As :func:`~neurofuzzy.simulation.implicit.integrate`.
    """
    from .simulation.implicit import integrate

    trajectory = integrate(model, integrator, dt=dt, n_frames=n_frames,
                           external_forces=external_forces, substeps=substeps)
    positions = trajectory.positions.copy()
    if noise > 0:
        rng = np.random.default_rng(seed)
        positions[1:] += rng.normal(0.0, noise, positions[1:].shape)
        positions[:, model.mesh.fixed] = trajectory.positions[:, model.mesh.fixed]
    if observed is not None:
        positions[:, ~np.asarray(observed, bool)] = np.nan
    return Experiment(mesh=model.mesh, dt=dt, positions=positions,
                      external_forces=external_forces, observed=observed,
                      node_mass=model.node_mass if with_masses else None,
                      truth=model_truth(model), source=source)


def duration(experiments) -> float:
    """The longest recording's length (s) of an experiment or a sequence of them."""
    experiments = [experiments] if isinstance(experiments, Experiment) else experiments
    return max(e.dt * (e.n_frames - 1) for e in experiments)


def check_experiments(model: Model,
                      experiments: Experiment | Sequence[Experiment], *,
                      model_source: str | None = None) -> list[Experiment]:
    """Return ``experiments`` as a list after checking they describe ``model``'s object
    (``model_source``: the model's file, named in the messages)."""
    if isinstance(experiments, Experiment):
        experiments = [experiments]
    experiments = list(experiments)
    if not experiments:
        raise InputError("no experiments given", key="experiments")
    the_model = f"the model {model_source}" if model_source else "the model"
    for experiment in experiments:
        if experiment.driven or experiment.tool is not None:
            raise InputError("is moved by driven sets or a tool, which implicit steps follow: "
                             "fit it with learn.implicit_fit.fit_implicit", key="driven",
                             source=experiment.source)
        mesh = experiment.mesh
        if mesh.n_nodes != model.n_nodes:
            raise InputError(f"has {mesh.n_nodes} nodes; {the_model} has {model.n_nodes}",
                             source=experiment.source, key="rest_positions")
        if mesh.n_springs != model.n_springs or not np.array_equal(mesh.springs,
                                                                   model.mesh.springs):
            raise InputError(f"its {mesh.n_springs} springs differ from the "
                             f"{model.n_springs} of {the_model}; all experiments must share "
                             "one topology", source=experiment.source, key="springs")
        if not np.array_equal(mesh.fixed, model.mesh.fixed):
            raise InputError(f"its fixed nodes differ from those of {the_model}",
                             source=experiment.source, key="fixed")
        if model.elements is not None and mesh.tetrahedra is not None and not np.array_equal(
                mesh.tetrahedra, model.mesh.tetrahedra):
            raise InputError(f"its tetrahedra differ from the elements of {the_model}",
                             source=experiment.source, key="tetrahedra")
    return experiments


def require_node_observations(experiments: Sequence[Experiment], why: str) -> None:
    """Refuse experiments that observe embedded markers, for a method that needs measured
    node positions; ``why`` says what it does with them."""
    embedded = next((e for e in experiments if e.markers is not None), None)
    if embedded is not None:
        raise InputError(f"observes markers embedded in the mesh; {why}, so import the "
                         "recording with --attach node (each marker following a node) for it",
                         source=embedded.source, key="markers")


def simulate_like(model: Model, experiment: Experiment,
                  substeps: int = 1) -> np.ndarray:
    """(n_frames, n_nodes, 3): ``model`` run freely under ``experiment``'s load and start."""
    return simulate(model, dt=experiment.dt, n_frames=experiment.n_frames,
                    external_forces=experiment.external_forces,
                    initial_positions=experiment.initial_positions(),
                    substeps=substeps, check_stability=False).positions


def rms_error(model: Model, experiments: Experiment | Sequence[Experiment], *,
              substeps: int = 1, offsets: bool = False) -> float:
    """Root-mean-square distance between free simulation and measurement, per marker.

    Over all experiments, frames 1 onwards, and what is measured (observed nodes that are not
    fixed, or embedded markers; not in a gap): ``sqrt(mean |p_sim - p_measured|²)`` (metres;
    the mean is over measured marker positions, each a 3-D distance, so it is √3 times the
    RMS per coordinate), simulating with ``substeps`` steps per frame. With ``offsets`` every
    marker's constant offset is fitted first (:func:`~neurofuzzy.observation.remove_offsets`).
    Infinite when the simulation diverges.
    """
    experiments = check_experiments(model, experiments)
    errors = model_errors(model, experiments, substeps=substeps, offsets=offsets)
    if errors is None:
        return float("inf")
    total = sum(float(np.sum(diff * diff)) for diff in errors)
    count = sum(int(e.observation.seen[1:].sum()) for e in experiments)
    value = np.sqrt(total / max(count, 1))
    return float(value) if np.isfinite(value) else float("inf")


def model_errors(model: Model, experiments: Sequence[Experiment], *,
                 substeps: int = 1, offsets: bool = False) -> list[np.ndarray] | None:
    """Per experiment, (n_frames - 1, n_rows, 3) simulated minus measured (m) at frames 1
    onwards for every measured row (zero where not measured), as :func:`rms_error` counts
    them; None when a simulation is unstable."""
    errors = []
    for experiment in experiments:
        try:
            with np.errstate(all="ignore"):
                simulated = simulate_like(model, experiment, substeps)
        except UnstableTimeStepError:
            return None
        observation = experiment.observation
        diff = observation.residuals(simulated)[1:]
        if offsets:
            diff = remove_offsets(diff, observation.seen[1:])
        errors.append(diff)
    return errors


def _float_array(value, source: str, key: str) -> np.ndarray:
    array = np.asarray(value)
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise InputError(f"expected numbers, got dtype {array.dtype}", source=source, key=key)
    return np.array(array, dtype=float)
