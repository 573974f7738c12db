"""Implicit time steps: backward Euler at the step a simulator runs (issue 47, item 1).

The explicit step of :func:`~neurofuzzy.simulation.simulate` (the paper's semi-implicit Euler)
is stable only below the model's stable step, a fraction of a millisecond for an element model
of soft tissue; a surgical simulator steps at its graphics or haptics rate (16 ms, 1 ms) and
integrates implicitly, as SOFA's ``EulerImplicitSolver`` and MuJoCo's ``discrete``
integrator do. :func:`simulate_implicit` takes **backward Euler** steps,

    M (v₁ - v₀) = h (F(x₀ + h v₁, v₁) + f_ext),    x₁ = x₀ + h v₁,

solved for the new velocity by Newton's method on ``(M + h C + h² K) Δv = -R(v)`` with the
stiffness ``K = -∂F/∂x`` and damping ``C = -∂F/∂v`` of every term, generated from each item's
one definition (:mod:`~neurofuzzy.simulation.tangents`; every law, both volumetric forms, the
compiled effects). Each Newton iteration's linear solve (:mod:`.step_solve`) keeps a
factorisation of that matrix from an earlier step (SuperLU, as the static solve's) and
corrects its solve by GMRES whose products are differences of the compiled force, so the
matrix is assembled and factorised only when it has moved too far. ``iterations=1`` is the
**linearly implicit** step of real-time engines (one linear solve from the last velocity,
SOFA's and MuJoCo's); more iterations solve the step to ``tolerance``. Unconditionally
stable for a linear model, it damps motion faster than the step resolves (numerical damping
of order ``h ω²``): at 16 ms a block of soft tissue rings far less than it does, which is
what a fit for the simulator's step must account for.

``scheme="bdf2"`` takes the second-order backward differentiation formula instead,

    M (3 v₁ - 4 v₀ + v₋₁) = 2h (F(x₁, v₁) + f_ext),    3 x₁ = 4 x₀ - x₋₁ + 2h v₁,

the same Newton solve with ``h`` replaced by ``2h/3`` and the state by the history's
``(4 x₀ - x₋₁)/3``, ``(4 v₀ - v₋₁)/3``. Its first step is backward Euler's (a local error
of order ``h²`` once keeps the run second-order; a history guessed before the start is not
safe in a stiff body: extrapolated back from the start's acceleration it put a step of
16 ms metres away), so a run factorises two matrices. It is second-order accurate, A-stable
like backward Euler and damps the resolved motion far less (numerical damping of order
``h³ω⁴`` against ``hω²``), at the same cost a step.

Elements that relax (Prony terms, :mod:`neurofuzzy.kernels.relaxation`) take their internal
variables one step on at the start of each step, from the state there, ``rᵢ ← aᵢ rᵢ -
(1 - aᵢ) S_e(x₀)`` with ``aᵢ = exp(-h/τᵢ)`` (the explicit stepper's update), and the step
solves for the new state with them held: the instantaneous response is implicit, the memory
lags one step. That is stable at any step (a mode's amplification tends to ``g/(1+g)`` as
``h → ∞``), first-order in the memory whatever the scheme, and its long-time state is the
relaxed equilibrium. The derivatives carry the internal variables' own
(:mod:`.implicit_relaxation`).

The derivatives of these steps by the elements' constants are
:mod:`.implicit_derivatives`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model import Model
from .integration import Trajectory, _frame_forces, _state
from .moving import Moving
from .static import ConvergenceError
from .step_solve import BodyForce, StepSolver

__all__ = ["simulate_implicit", "integrate"]

#: The schemes of :func:`simulate_implicit`, each with the share of the step that multiplies
#: the new velocity in its position update (backward Euler 1, BDF2 2/3)
SCHEMES = {"euler": 1.0, "bdf2": 2.0 / 3.0}
#: the implicit integrators by the name :func:`integrate` and ``simulate --integrator`` take
INTEGRATORS = {"implicit": "euler", "bdf2": "bdf2"}

#: Newton iterations a step may take, each step solved, where a tool is in contact
TOOL_ITERATIONS = 30
#: m/s: a Newton update this small has converged whatever the velocity (a body at rest)
VELOCITY_FLOOR = 1e-14

def simulate_implicit(model: Model, *, dt: float, n_frames: int,
                      external_forces: np.ndarray | None = None,
                      initial_positions: np.ndarray | None = None,
                      initial_velocities: np.ndarray | None = None, substeps: int = 1,
                      iterations: int | None = None, tolerance: float = 1e-8,
                      scheme: str = "euler", driven=(), tool=None) -> Trajectory:
    """Simulate ``n_frames`` frames with backward Euler (or BDF2) steps (module docstring).

    Parameters
    ----------
    model : Model
        Springs, elements (their Prony relaxation too) and the effects the compiled kernels
        compute.
    dt : float
        Time between recorded frames.
    n_frames : int
    external_forces : (n_nodes, 3) or (n_frames, n_nodes, 3) float, optional
        As :func:`~neurofuzzy.simulation.simulate`: ``external_forces[t]`` acts from frame
        ``t`` to ``t + 1``.
    initial_positions, initial_velocities : (n_nodes, 3) float, optional
    substeps : int
        Implicit steps per frame (``h = dt / substeps``); any step is stable.
    iterations : int, optional
        Newton iterations per step: 1 (the default without a tool) is the linearly implicit
        step of real-time engines; more solve each step until the velocity changes by less
        than ``tolerance`` times its size. With a ``tool`` the default is
        :data:`TOOL_ITERATIONS`: one iteration linearises the penalty where the tool is about
        to press, and its stiff force then throws the nodes (a sphere pressed 1 mm read
        -2.2 N for the static solve's -0.031 N).
    tolerance : float
    scheme : {"euler", "bdf2"}
        Backward Euler (first order, the step of MuJoCo's ``discrete`` integrator) or the
        second-order backward differentiation formula.
    driven : sequence of DrivenPath, optional
        Node sets moved along a path, one displacement from rest per frame (:mod:`.moving`);
        their drivers' forces are :attr:`Trajectory.reactions`.
    tool : ToolPath, optional
        A rigid tool pressed along its path, one position per frame (:mod:`.moving`); its
        force on the body is :attr:`Trajectory.tool_forces`.

    Returns
    -------
    Trajectory

    Raises
    ------
    ConvergenceError
        When a step's Newton iterations do not converge (with ``iterations > 1``) or the
        state becomes NaN.
    """
    if iterations is None:
        iterations = 1 if tool is None else TOOL_ITERATIONS
    run = ImplicitRun(model, dt=dt, n_frames=n_frames, external_forces=external_forces,
                      initial_positions=initial_positions,
                      initial_velocities=initial_velocities, substeps=substeps,
                      iterations=iterations, tolerance=tolerance, scheme=scheme,
                      driven=driven, tool=tool)
    for _ in run.steps():
        pass
    return run.trajectory()


@dataclass(frozen=True)
class Step:
    """One step of an :class:`ImplicitRun`, as :meth:`ImplicitRun.steps` yields it."""

    frame: int              # the frame the step ends in (or on)
    ends_frame: bool        # the frame's last substep: its state is recorded
    scheme: str             # this step's ("euler" for BDF2's first)
    h: float                # the step's h in the position update (two thirds of it in BDF2)
    base: tuple             # (positions, velocities) it stepped from (BDF2: the history's)
    positions: np.ndarray   # (n_nodes, 3) at its end
    velocities: np.ndarray
    contact: object         # the tool's contact during the step, or None
    load: object            # the external force during it (flat, or 0.0)


class ImplicitRun:
    """The implicit time loop, one for the run of states (:func:`simulate_implicit`) and of
    their derivatives (:mod:`.implicit_derivatives`): the frames' loads, the driven sets and
    the tool along their paths, each step solved (:func:`_step`), each frame's state, driven
    sets' reactions and tool's force recorded. :meth:`steps` yields every step, so a run of
    derivatives does its own work at each between them. Arguments as
    :func:`simulate_implicit`'s."""

    def __init__(self, model: Model, *, dt, n_frames, external_forces=None,
                 initial_positions=None, initial_velocities=None, substeps=1, iterations=1,
                 tolerance=1e-8, scheme="euler", driven=(), tool=None):
        if not (np.isfinite(dt) and dt > 0):
            raise InputError(f"got {dt}; expected a positive time step", key="dt")
        if int(n_frames) < 1:
            raise InputError(f"got {n_frames}; expected at least 1", key="n_frames")
        for key, value in (("substeps", substeps), ("iterations", iterations)):
            if not (isinstance(value, (int, np.integer)) and value >= 1):
                raise InputError(f"got {value!r}; expected a positive integer", key=key)
        _check_scheme(scheme)
        n, self.n_frames = model.n_nodes, int(n_frames)
        self.model, self.dt, self.substeps = model, float(dt), int(substeps)
        self.iterations, self.tolerance, self.scheme = iterations, tolerance, scheme
        self.loads = _frame_forces(external_forces, self.n_frames, n)
        self.moving = Moving(model, self.n_frames, driven, tool)
        self.p, self.v, self.free = start(model, self.moving, initial_positions,
                                          initial_velocities)
        self.h = self.dt / self.substeps
        self.every_mass = np.repeat(np.asarray(model.node_mass, float), 3)
        self.mass = self.every_mass[self.free]
        self.positions = np.empty((self.n_frames, n, 3))
        self.velocities = np.empty_like(self.positions)
        self.positions[0], self.velocities[0] = self.p, self.v
        self.touched = None if tool is None else np.zeros((self.n_frames, 3))
        self.reactions = (None if not self.moving.driven
                          else np.zeros((self.n_frames, len(self.moving.driven), 3)))
        if self.touched is not None:
            self.touched[0] = self.moving.touch(0, 0.0).force_on_body(self.p)
        self.body = BodyForce(model, self.h)
        self.solvers = _Solvers(model, self.body, self.h, self.free, self.mass)

    def steps(self):
        """Take every step, yielding each (:class:`Step`) once solved, its frame recorded
        when it ends one."""
        p, v, before = self.p, self.v, None
        rest = self.model.mesh.rest_positions
        for frame in range(1, self.n_frames):
            load = (0.0 if self.loads is None
                    else self.loads[min(frame - 1, len(self.loads) - 1)].ravel())
            for sub in range(self.substeps):
                now, base = _base(self.scheme, (p, v), before)
                before = (p, v)
                self.body.advance(p, v)              # the relaxation's rᵢ to the step's end
                solver = self.solvers.of(now)
                fraction = (sub + 1) / self.substeps
                solver.contact = self.moving.touch(frame, fraction)
                h = SCHEMES[now] * self.h
                p, v = _step(self.body, solver, base, v, h, load, self.free, self.mass,
                             self.iterations, self.tolerance,
                             self.moving.targets(frame, fraction, rest))
                ends = sub == self.substeps - 1
                if ends:
                    self._record(frame, p, v, solver.contact, base, h, load)
                yield Step(frame, ends, now, h, base, p, v, solver.contact, load)

    def _record(self, frame, p, v, contact, base, h, load):
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
            raise ConvergenceError(f"the implicit step diverged at frame {frame} (positions "
                                   "became NaN or infinite): an element squeezed flat?",
                                   key="dt")
        self.positions[frame], self.velocities[frame] = p, v
        if self.touched is not None:
            self.touched[frame] = contact.force_on_body(p)
        if self.reactions is not None:
            self.reactions[frame] = reaction(self.moving, self.body, contact, (p, v), base[1],
                                             h, self.every_mass, load)

    def trajectory(self) -> Trajectory:
        """The run's :class:`~.integration.Trajectory` (after :meth:`steps`)."""
        return Trajectory(positions=self.positions, velocities=self.velocities, dt=self.dt,
                          substeps=self.substeps,
                          final_internal=(self.body.internal.copy() if self.body.relaxes
                                          else None),
                          reactions=self.reactions, tool_forces=self.touched)


def integrate(model: Model, integrator: str, *, dt: float, n_frames: int,
              external_forces: np.ndarray | None = None,
              substeps: int | str = 1) -> Trajectory:
    """A run from rest with the integrator named: ``"explicit"``, the paper's semi-implicit
    Euler (:func:`~neurofuzzy.simulation.simulate`), ``"implicit"``, backward Euler with
    one Newton iteration a step (:func:`simulate_implicit`: stable at any step, the step of
    MuJoCo's ``discrete`` integrator), or ``"bdf2"``, the second-order backward
    differentiation formula, the same way (``substeps="auto"``: one implicit step a
    frame)."""
    from .integration import simulate

    if integrator == "explicit":
        return simulate(model, dt=dt, n_frames=n_frames, external_forces=external_forces,
                        substeps=substeps)
    if integrator in INTEGRATORS:
        return simulate_implicit(model, dt=dt, n_frames=n_frames,
                                 external_forces=external_forces,
                                 substeps=1 if substeps == "auto" else int(substeps),
                                 scheme=INTEGRATORS[integrator])
    raise InputError(f"got {integrator!r}; expected 'explicit', 'implicit' or 'bdf2'",
                     key="integrator")


def _check_scheme(scheme: str) -> None:
    """An :class:`~neurofuzzy.errors.InputError` unless ``scheme`` is one of :data:`SCHEMES`."""
    if scheme not in SCHEMES:
        raise InputError(f"got {scheme!r}; expected one of {', '.join(map(repr, SCHEMES))}",
                         key="scheme")


class _Solvers:
    """A run's :class:`~.step_solve.StepSolver` per scheme (BDF2 takes its first step by
    backward Euler, whose matrix is another), made when first asked for."""

    def __init__(self, model, body, h, free, mass):
        self.arguments = (model, body, h, free, mass)
        self.made = {}

    def of(self, scheme: str) -> StepSolver:
        if scheme not in self.made:
            model, body, h, free, mass = self.arguments
            self.made[scheme] = StepSolver(model, body, SCHEMES[scheme] * h, free, mass)
        return self.made[scheme]


def _base(scheme: str, now: tuple, before: tuple | None) -> tuple[str, tuple]:
    """``(the step's scheme, what it starts from)`` for the state ``now`` (a pair: positions
    and velocities, or their derivatives) after ``before`` (None at the run's first step):
    backward Euler's ``now``, or BDF2's ``(4 now - before) / 3``, whose first step is
    backward Euler's."""
    if scheme == "euler" or before is None:
        return "euler", now
    return scheme, tuple((4.0 * a - b) / 3.0 for a, b in zip(now, before))


def _step(body, solver, base, guess, h, load, free, mass, iterations, tolerance,
          targets=None):
    """One step ``M (v₁ - b_v) = h (F(b_x + h v₁, v₁) + f)`` from ``base = (b_x, b_v)``
    (backward Euler: the last state; BDF2: its history, with ``h`` two thirds of the step),
    Newton from the velocity ``guess``: ``(p1, v1)``, each iteration's linear solve by
    ``solver`` (:class:`~.step_solve.StepSolver`, with its tool's contact), the force by
    ``body``; ``targets`` ``(dofs, positions)``: driven degrees of freedom, given the velocity
    that puts them there."""
    n = guess.shape[0]
    x0, w0 = base[0].ravel(), base[1].ravel()
    w = guess.ravel().copy()
    if targets is not None:
        w[targets[0]] = (targets[1] - x0[targets[0]]) / h
    for iteration in range(iterations):
        x = x0 + h * w
        force = body(x, w)
        if solver.contact is not None:
            force = force + solver.contact.forces(x.reshape(n, 3)).ravel()
        residual = mass * (w[free] - w0[free]) - h * (force + load)[free]
        delta = solver.solve(-residual, x, w, force)
        w[free] += delta
        if iterations > 1 and np.abs(delta).max() <= tolerance * max(
                np.abs(w).max(), np.abs(guess).max()) + VELOCITY_FLOOR:
            break
    else:
        if iterations > 1:
            raise ConvergenceError(f"the implicit step's Newton iterations did not converge in "
                                   f"{iterations}; allow more iterations or take smaller "
                                   "steps", key="iterations")
    return (x0 + h * w).reshape(n, 3), w.reshape(n, 3)


def reaction(moving: Moving, body: BodyForce, contact, state: tuple, base_velocity, h: float,
             every_mass: np.ndarray, load) -> np.ndarray:
    """(n_sets, 3): each driven set's share of the step's ``M (v₁ - b_v)/h - F - f`` at the
    step's end ``state = (p, v)`` (``contact`` the tool's, or None): what its driver
    exerts on it."""
    p, v = state
    force = body(p, v) + (0.0 if contact is None else contact.forces(p).ravel())
    return moving.reactions(every_mass * (v - base_velocity).ravel() / h - force - load)


def start(model: Model, moving: Moving, initial_positions, initial_velocities) -> tuple:
    """``(positions, velocities, free)`` at a run's start: the given state (rest and still
    by default) with the driven sets where their paths begin and held degrees of freedom
    still; ``free`` (3 n_nodes,) bool, the degrees of freedom neither fixed nor driven."""
    n = model.n_nodes
    rest = model.mesh.rest_positions
    p = moving.start(rest, _state(initial_positions, rest, n, "initial_positions"))
    v = _state(initial_velocities, np.zeros((n, 3)), n, "initial_velocities")
    free_nodes = np.ones(n, bool)
    free_nodes[model.mesh.fixed] = False
    free = np.repeat(free_nodes, 3) & ~moving.held
    v.reshape(-1)[~free] = 0.0
    return p, v, free
