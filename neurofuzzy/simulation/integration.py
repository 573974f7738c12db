"""Vectorised time stepping of a spring-mass model (paper eqs. 3.1–3.6).

Spring ``j`` between nodes ``a`` and ``b`` (eqs. 3.4–3.6)::

    d = p_b - p_a,   l = |d|,   u = d / l
    f_j = s_j (l - L0_j) u + c_j ((v_b - v_a) · u) u          node a gets +f_j, node b gets -f_j

Each step of length ``h`` (the paper's time constant ``t_c``) is semi-implicit (symplectic)
Euler, eqs. 3.3, 3.2 and 3.1::

    a(t) = (Σ spring forces + effect forces + f_ext) / m
    v(t) = v(t-1) + h a(t)
    p(t) = p(t-1) + h v(t)

with the forces evaluated at ``p(t-1), v(t-1)``. The paper adds ``ext_f`` after the weight
``w_m = 1/m`` (an external *acceleration*); we treat external input as a force, which is the
same up to the scaling by the node mass. Fixed nodes keep their positions and zero velocity.

Stability: :mod:`neurofuzzy.simulation.stability` bounds the stable step; :func:`simulate`
refuses (or, with ``substeps="auto"``, subdivides) a step that breaks the bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, UnstableTimeStepError
from ..model import Model
from .stability import check_time_step, required_substeps
from .steppers import NumbaStepper, euler_update

__all__ = ["State", "Trajectory", "internal_forces", "step", "simulate", "check_substeps"]


@dataclass(frozen=True, eq=False)
class State:
    """The state of a model at one instant: what a simulation continues from.

    Attributes
    ----------
    positions, velocities : (n_nodes, 3) float
    internal : (n_tetrahedra, K, 6) float
        The internal variables of the elements' Prony relaxation (K terms,
        :mod:`neurofuzzy.forces.relaxation`): per element and term the ``rᵢ`` of
        ``S = S_rest + Σᵢ gᵢ (S_e + rᵢ)``, six entries of a symmetric stress (Pa), zero for a
        model at rest; (0, 0, 6) or (n_tetrahedra, 0, 6) for a model that does not relax. A
        relaxing model's positions and velocities alone do not say where it is: the same
        shape recently loaded pushes back harder than after it has relaxed.
    """

    positions: np.ndarray
    velocities: np.ndarray
    internal: np.ndarray

    @classmethod
    def at_rest(cls, model: Model) -> State:
        """The model at its rest positions, not moving, nothing relaxed."""
        return cls(np.array(model.mesh.rest_positions, dtype=float),
                   np.zeros((model.n_nodes, 3)), _no_internal(model))


def _no_internal(model: Model) -> np.ndarray:
    n_elements = model.mesh.n_tetrahedra if model.elements is not None else 0
    return np.zeros((n_elements, model.n_relaxation_terms, 6))


@dataclass(frozen=True)
class Trajectory:
    """Recorded frames of a simulation.

    Attributes
    ----------
    positions : (n_frames, n_nodes, 3) float
    velocities : (n_frames, n_nodes, 3) float
    dt : float
        Time between recorded frames.
    substeps : int
        Integration steps per recorded frame.
    final_internal : (n_tetrahedra, K, 6) float or None
        The relaxation's internal variables after the last frame (:class:`State`); None
        when the trajectory does not know them (a trajectory from another solver).
    reactions : (n_frames, n_sets, 3) float or None
        What each driven set's driver exerts on the body at each frame (N), inertia
        included (:mod:`.moving`); None without driven sets.
    tool_forces : (n_frames, 3) float or None
        What a tool exerts on the body at each frame (N); None without one.
    """

    positions: np.ndarray
    velocities: np.ndarray
    dt: float
    substeps: int = 1
    final_internal: np.ndarray | None = None
    reactions: np.ndarray | None = None
    tool_forces: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    @property
    def final_state(self) -> State:
        """The :class:`State` after the last frame, to continue the simulation from
        (``simulate(..., initial_state=trajectory.final_state)``)."""
        if self.final_internal is None:
            raise InputError("this trajectory does not carry the internal variables of its "
                             "last frame (it was not made by simulate)", key="final_state")
        return State(self.positions[-1].copy(), self.velocities[-1].copy(),
                     self.final_internal.copy())


def internal_forces(model: Model, positions: np.ndarray,
                    velocities: np.ndarray) -> np.ndarray:
    """(n_nodes, 3) the sum of every force term of the model (springs and effects)."""
    force = np.zeros_like(positions, dtype=float)
    for term in model.force_terms:
        force += term.force(model, positions, velocities)
    return force


def step(model: Model, positions: np.ndarray, velocities: np.ndarray, h: float,
         external_force: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One semi-implicit Euler step of length ``h`` (eqs. 3.1–3.3); returns ``(p, v)``.

    Positions and velocities are the whole state of models that do not relax; a relaxing
    model (Prony terms) also carries internal variables: step it with :func:`simulate` and a
    :class:`State` (``initial_state=...``, continued from ``Trajectory.final_state``)."""
    if model.n_relaxation_terms:
        raise InputError("this model's elements relax (Prony terms), whose internal variables "
                         "positions and velocities do not hold; step it with simulate(model, "
                         "..., initial_state=state), continuing from trajectory.final_state",
                         key="model")
    force = internal_forces(model, positions, velocities)
    if external_force is not None:
        force = force + external_force
    p, v = np.array(positions, dtype=float), np.array(velocities, dtype=float)
    v[model.mesh.fixed] = 0.0
    euler_update(p, v, force, model.node_inverse_mass, h)
    return p, v


def simulate(model: Model, *, dt: float, n_frames: int,
             external_forces: np.ndarray | None = None,
             initial_positions: np.ndarray | None = None,
             initial_velocities: np.ndarray | None = None,
             initial_state: State | None = None,
             substeps: int | str = 1, check_stability: bool = True,
             dtype=np.float64) -> Trajectory:
    """Simulate ``n_frames`` recorded frames, frame 0 being the initial state.

    Parameters
    ----------
    model : Model
    dt : float
        Time between recorded frames.
    n_frames : int
        Number of frames to return (>= 1).
    external_forces : (n_nodes, 3) or (n_frames, n_nodes, 3) float, optional
        Applied load; constant, or per frame, where ``external_forces[t]`` acts from frame
        ``t`` to ``t + 1`` (the last frame's row is unused).
    initial_positions, initial_velocities : (n_nodes, 3) float, optional
        Start state (default: rest positions, at rest), with nothing relaxed.
    initial_state : State, optional
        Start state with the relaxation's internal variables, e.g. the
        :attr:`Trajectory.final_state` of a previous run: a run continued from it equals one
        run through (instead of ``initial_positions``, ``initial_velocities``).
    substeps : int or "auto"
        Integration steps per frame (``h = dt / substeps``); ``"auto"`` picks the fewest that
        are stable.
    check_stability : bool
        Raise :class:`UnstableTimeStepError` when ``h`` exceeds the stability bound.
    dtype : numpy dtype
        float64 (default) or float32 for the inner loop.

    Returns
    -------
    Trajectory
    """
    n_nodes = model.n_nodes
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"got {dt}; expected a positive time step", key="dt")
    if int(n_frames) < 1:
        raise InputError(f"got {n_frames}; expected at least 1", key="n_frames")
    n_frames = int(n_frames)
    if check_substeps(substeps) == "auto":
        substeps = required_substeps(model, dt)
    elif check_stability:
        check_time_step(model, dt, int(substeps))
    substeps = int(substeps)

    forces = _frame_forces(external_forces, n_frames, n_nodes)
    if initial_state is not None:
        if initial_positions is not None or initial_velocities is not None:
            raise InputError("give initial_state or initial_positions/initial_velocities, "
                             "not both", key="initial_state")
        p, v, internal = _start_state(model, initial_state)
    else:
        p = _state(initial_positions, model.mesh.rest_positions, n_nodes, "initial_positions")
        v = _state(initial_velocities, np.zeros((n_nodes, 3)), n_nodes, "initial_velocities")
        internal = _no_internal(model)
    v[model.mesh.fixed] = 0.0
    stepper = NumbaStepper(model, dt / substeps, dtype)

    with np.errstate(over="ignore", invalid="ignore"):
        positions, velocities, internal = stepper.trajectory(p, v, forces, n_frames, substeps,
                                                             internal)
    bad = ~np.isfinite(positions).all(axis=(1, 2))
    if bad.any():
        raise UnstableTimeStepError(
            f"the simulation diverged at frame {int(np.argmax(bad))} (positions became NaN or "
            "infinite); reduce the time step or the stiffness, or raise substeps")
    return Trajectory(positions=positions, velocities=velocities, dt=float(dt),
                      substeps=substeps, final_internal=internal)


#: most integration steps per frame a caller may ask for
MAX_SUBSTEPS = 10_000


def check_substeps(value, key: str = "substeps") -> int | str:
    """``value`` as a positive int or ``"auto"``; :class:`InputError` naming ``key`` otherwise.

    Strings of digits are accepted (command-line options).
    """
    if isinstance(value, str) and value != "auto":
        value = int(value) if value.strip().isdigit() else value
    if value == "auto":
        return "auto"
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= 1:
        if value > MAX_SUBSTEPS:
            raise InputError(f"got {value}; at most {MAX_SUBSTEPS} steps per frame (more would "
                             "run for hours: check dt and the model's units, or use 'auto')",
                             key=key)
        return int(value)
    raise InputError(f"got {value!r}; expected a positive integer or 'auto'", key=key)


def _frame_forces(external_forces, n_frames: int, n_nodes: int) -> np.ndarray | None:
    if external_forces is None:
        return None
    forces = np.asarray(external_forces, dtype=float)
    if forces.shape == (n_nodes, 3):
        forces = forces[None]                      # one row, held for every frame
    elif forces.shape != (n_frames, n_nodes, 3):
        raise InputError(f"got shape {forces.shape}; expected (n_nodes, 3) = ({n_nodes}, 3) or "
                         f"(n_frames, n_nodes, 3) = ({n_frames}, {n_nodes}, 3)",
                         key="external_forces")
    if not np.all(np.isfinite(forces)):
        raise InputError("contains NaN or infinite values", key="external_forces")
    return forces


def _state(value, default: np.ndarray, n_nodes: int, key: str) -> np.ndarray:
    if value is None:
        return np.array(default, dtype=float)
    state = np.array(value, dtype=float)
    if state.shape != (n_nodes, 3):
        raise InputError(f"got shape {state.shape}; expected (n_nodes, 3) = ({n_nodes}, 3)",
                         key=key)
    if not np.all(np.isfinite(state)):
        raise InputError("contains NaN or infinite values", key=key)
    return state


def _start_state(model: Model, state) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``initial_state`` checked against ``model``: copies of its arrays."""
    if not isinstance(state, State):
        raise InputError(f"got {type(state).__name__}; expected a State (e.g. "
                         "trajectory.final_state)", key="initial_state")
    n_nodes = model.n_nodes
    p = _state(state.positions, None, n_nodes, "initial_state.positions")
    v = _state(state.velocities, None, n_nodes, "initial_state.velocities")
    expected = _no_internal(model).shape
    internal = np.array(state.internal, dtype=float)
    if internal.shape != expected and not (internal.size == 0 and expected[1] == 0):
        raise InputError(f"got internal variables of shape {internal.shape}; this model "
                         f"needs {expected} (n_tetrahedra, Prony terms, 6): a state of "
                         "another model?", key="initial_state.internal")
    if not np.all(np.isfinite(internal)):
        raise InputError("contains NaN or infinite values", key="initial_state.internal")
    return p, v, internal.reshape(expected)
