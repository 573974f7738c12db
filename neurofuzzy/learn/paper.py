"""The paper's learning algorithm (Figure 2): online one-step backpropagation with teacher forcing.

For every time step ``t`` of every cycle:

1. propagate the network one step from ``(p(t-1), v(t-1))`` (eqs. 3.1–3.6);
2. derive the error ``E(t) = ½ Σ_k |p_k(t) - o_k(t)|²`` over observed nodes (eqs. 2.2, 2.3);
3. derive the error rates: ``δ_p = p - o_p`` (3.7), ``δ_v = δ_p t_c`` (3.8),
   ``δ_a = δ_p t_c²`` (3.9), ``δ_f = Σ_a w_a δ_a`` (3.14); for free nodes without a measurement
   at that step (unobserved, or in a gap of their marker) the position error rate is propagated back from their springs, ``δ_p* = Σ_s δ_s + Σ_c δ_c``
   (3.17, 3.18, 3.22);
4. modify the weights at once: ``Δw_m = η_m δ_p · o_f`` (3.11), ``Δc = η δ_f · o_c`` (3.15),
   ``Δs = η δ_f · o_s`` (3.16) (tied springs add their changes, paper §"jointly learned");
5. every ``teacher_forcing_limit`` steps, set the positions of the nodes measured at that
   step to the measured ones (teacher forcing).

Units. The paper's learning rates act in the network's own units, where one propagation step
takes ``t_c = 1``. We keep the model in physical units and scale every update so that it equals
the paper's update in network units: time in frames, length in the mean rest spring length,
mass in the mean free-node mass. ``η = 0.01`` therefore means the same for a 2-cm specimen in
SI units as for the paper's unit cube. Two readings where the printed equations are loose:
``w_a`` in eq. 3.14 includes the weight ``w_m = 1/m`` of eq. 3.3 (exact chain rule; identical to
the printed form for unit masses), and the mass update uses the total force on the node, since
we apply external input as a force (see :mod:`neurofuzzy.simulation`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError, NeurofuzzyError
from ..experiment import Experiment, check_experiments, require_node_observations, rms_error
from ..forces import incidence
from ..forces.blocks import TieGroups
from ..model import Model
from ..progress import Progress, Stopwatch
from ..simulation import euler_update
from ._base import Learner
from .lack_of_fit import model_lack_of_fit

__all__ = ["PaperLearner"]


class PaperLearner(Learner):
    """Online learner of Figure 2 (one-step backpropagation, immediate updates, teacher forcing).

    Parameters
    ----------
    learning_rate : float
        ``η`` for spring constants and viscosities (paper: 0.01 or 0.1).
    mass_learning_rate : float
        ``η_m`` for the inverse masses ``w_m`` (paper: 0.1); used when ``learn_masses``.
    effect_learning_rate : float
        Rate for the parameters of the model's effects (our extension; default 1e-4: an
        effect such as gravity acts on every node at once, so its summed update is large).
    teacher_forcing_limit : int
        Steps between two teacher-forcing resets (paper: 10).
    cycles : int
        Maximum number of learning cycles (complete passes over the data; paper: 100).
    tolerance : float
        Stop early when the cycle error ``E`` falls below this (default 0: run all cycles).
    learn_masses : bool
        Learn node masses too (paper experiment 1); otherwise they stay as given.
    learn_effects : bool
        Learn the parameters of the model's effects.
    progress : bool
        Report progress on stderr.

    Attributes
    ----------
    history_ : (n_cycles,) float
        The paper's error ``E`` of eq. 2.2 accumulated over each cycle (with teacher forcing),
        in network units (lengths in mean spring lengths), summed over experiments.
    substeps_ : int
        Always 1: the paper's network takes one step per frame.
    """

    def __init__(self, *, learning_rate: float = 0.01, mass_learning_rate: float = 0.1,
                 effect_learning_rate: float = 1e-4, teacher_forcing_limit: int = 10,
                 cycles: int = 100, tolerance: float = 0.0, learn_masses: bool = False,
                 learn_effects: bool = True, progress: bool = False):
        self.learning_rate = learning_rate
        self.mass_learning_rate = mass_learning_rate
        self.effect_learning_rate = effect_learning_rate
        self.teacher_forcing_limit = teacher_forcing_limit
        self.cycles = cycles
        self.tolerance = tolerance
        self.learn_masses = learn_masses
        self.learn_effects = learn_effects
        self.progress = progress

    def fit(self, model: Model,
            experiments: Experiment | Sequence[Experiment]) -> PaperLearner:
        """Learn ``model``'s parameters from ``experiments``; returns ``self``."""
        for name in ("learning_rate", "mass_learning_rate"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"got {value}; expected a non-negative number", key=name)
        if int(self.teacher_forcing_limit) < 1:
            raise InputError(f"got {self.teacher_forcing_limit}; expected >= 1",
                             key="teacher_forcing_limit")
        if int(self.cycles) < 1:
            raise InputError(f"got {self.cycles}; expected >= 1", key="cycles")
        experiments = check_experiments(model, experiments)
        if model.elements is not None or model.springs is None:
            raise InputError("the paper's learner learns spring networks (eqs. 3.7-3.22); fit "
                             "a model with tetrahedral elements with the gradient learner",
                             key="method")
        require_node_observations(experiments, "the paper's learner teacher-forces measured "
                                  "node positions (Figure 2; the gradient learner takes markers)")
        watch = Stopwatch()       # the kernels' compilation left out
        self.rms_error_initial_ = rms_error(model, experiments)

        state = _LearningState(model)
        progress = Progress("paper learner", int(self.cycles), self.progress)
        history = []
        for cycle in range(int(self.cycles)):
            with np.errstate(all="ignore"):
                error = sum(self._cycle(state, experiment) for experiment in experiments)
            if not np.isfinite(error):
                raise NeurofuzzyError(
                    f"learning diverged in cycle {cycle + 1} (the error became infinite); "
                    "lower the learning rates or start closer to plausible parameters")
            history.append(error)
            progress.update(cycle + 1, f"E={error:.4g} (eq. 2.2, mean spring lengths²)")
            if error < self.tolerance:
                break
        progress.update(int(self.cycles))

        self.model_ = state.model()
        self.history_ = np.array(history)
        self.substeps_ = 1
        self.n_cycles_ = len(history)
        self.lack_of_fit_ = model_lack_of_fit(self.model_, experiments)
        self.rms_error_ = self.lack_of_fit_.rms
        self.seconds_ = watch.seconds
        return self

    def _cycle(self, state: _LearningState, experiment: Experiment) -> float:
        """One complete propagation through ``experiment`` with immediate updates; returns E."""
        model = state.base
        maps = incidence(model.mesh)
        rest_length = model.springs.rest_length
        h = experiment.dt
        length_unit, mass_unit = state.length_unit, state.mass_unit
        # Update scale U_θ² h² / L² of every parameter class (module docstring).
        scale_s = self.learning_rate * mass_unit**2 / (h * length_unit) ** 2
        scale_c = self.learning_rate * mass_unit**2 / length_unit**2
        scale_w = self.mass_learning_rate * h * h / (mass_unit * length_unit) ** 2
        effect_rate = self.effect_learning_rate

        # per frame: nodes with a measurement (observed, not in a gap) and free nodes without
        # one, which take the back-propagated error of eq. 3.22 at that frame
        measured = experiment.measured()
        tracked = measured & model.mesh.free
        unobserved = ~measured & model.mesh.free
        targets = np.where(tracked[:, :, None], experiment.positions, 0.0)
        loads = experiment.forces_per_frame()
        p = experiment.initial_positions()
        v = experiment.initial_velocities()
        counter, error = 0, 0.0
        springs = model.springs
        for t in range(1, experiment.n_frames):
            s, c, w = state.stiffness(), state.damping(), state.inverse_mass
            # 1. propagate one step (eqs. 3.1–3.6)
            geometry = springs.state(model, p, v)
            templates = springs.parameter_templates(geometry)
            o_s, o_c = templates["stiffness"], templates["damping"]
            force = springs.force_of_state(model, geometry, s, c)
            for effect in state.effects:
                force += effect.force(model, p, v)
            force += loads[t - 1]
            p_new, v = p.copy(), v.copy()
            euler_update(p_new, v, force, w, h)
            # 2. error E(t) (eqs. 2.2, 2.3) and 3. error rates (3.7–3.9, 3.14)
            e = np.where(tracked[t][:, None], targets[t] - p_new, 0.0)
            error += 0.5 * float(np.sum(e * e)) / length_unit**2
            if unobserved[t].any():   # eq. 3.22: δ_p* = Σ_s δ_s + Σ_c δ_c
                u = geometry.direction
                delta_f = -maps.difference(w[:, None] * e)          # w_a e_a - w_b e_b
                along = np.einsum("ij,ij->i", u, delta_f)
                ratio = rest_length / geometry.length
                delta_s = (1 - ratio)[:, None] * delta_f + (ratio * along)[:, None] * u
                delta_c = along[:, None] * u
                back = h * h * s[:, None] * delta_s + h * c[:, None] * delta_c
                e = e - np.where(unobserved[t][:, None], maps.accumulate(back), 0.0)
            we = w[:, None] * e
            delta_f = -maps.difference(we)
            # 4. modify the weights immediately (3.11, 3.15, 3.16)
            state.update_springs(scale_s * np.einsum("ij,ij->i", delta_f, o_s),
                                 scale_c * np.einsum("ij,ij->i", delta_f, o_c))
            if self.learn_masses:
                state.update_inverse_mass(scale_w * np.einsum("ij,ij->i", e, force))
            if self.learn_effects and state.effects:
                state.update_effects(model, p, v, we, effect_rate * h * h / length_unit**2, h)
            # 5. teacher forcing
            counter += 1
            if counter >= self.teacher_forcing_limit:
                p_new[measured[t]] = experiment.positions[t, measured[t]]
                counter = 0
            p = p_new
        return error


class _LearningState:
    """The weights while they are being learned: tied spring values, inverse masses, effects."""

    def __init__(self, model: Model):
        self.base = model
        self.tied = TieGroups.of(model.springs.tie)
        self.stiffness_shared, self.stiffness_ratio = self.tied.split(model.springs.stiffness)
        self.damping_shared, self.damping_ratio = self.tied.split(model.springs.damping)
        free = model.mesh.free
        self.inverse_mass = np.where(free, 1.0 / model.node_mass, 0.0)
        self.length_unit = model.length_unit
        self.mass_unit = float(np.mean(model.node_mass[free])) if free.any() else 1.0
        # Parameters stay positive: never below a small fraction of where they started.
        self.stiffness_floor = 1e-4 * np.maximum(self.stiffness_shared, 1e-12)
        self.damping_floor = 1e-4 * np.maximum(self.damping_shared, 1e-12)
        self.inverse_mass_floor = 1e-4 * self.inverse_mass
        self.effects = list(model.effects)

    def stiffness(self) -> np.ndarray:
        return self.stiffness_shared[self.tied.tie] * self.stiffness_ratio

    def damping(self) -> np.ndarray:
        return self.damping_shared[self.tied.tie] * self.damping_ratio

    def update_springs(self, stiffness_step: np.ndarray, damping_step: np.ndarray) -> None:
        self.stiffness_shared = np.maximum(
            self.stiffness_shared + self.tied.reduce(stiffness_step, self.stiffness_ratio),
            self.stiffness_floor)
        self.damping_shared = np.maximum(
            self.damping_shared + self.tied.reduce(damping_step, self.damping_ratio),
            self.damping_floor)

    def update_inverse_mass(self, step: np.ndarray) -> None:
        self.inverse_mass = np.maximum(self.inverse_mass + step, self.inverse_mass_floor)

    def update_effects(self, model, p, v, weighted_error, rate, h) -> None:
        length_unit, mass_unit = self.length_unit, self.mass_unit
        for index, effect in enumerate(self.effects):
            jacobian = effect.parameter_jacobian(model, p, v)          # (N, P, 3)
            gradient = np.einsum("ipj,ij->p", jacobian, weighted_error)
            unit = effect.parameter_units(length_unit, h, mass_unit)
            self.effects[index] = effect.with_params(effect.params + rate * unit**2 * gradient)

    def model(self) -> Model:
        free = self.base.mesh.free
        mass = self.base.node_mass.copy()
        mass[free] = 1.0 / self.inverse_mass[free]
        springs = self.base.springs.replace(stiffness=self.stiffness(), damping=self.damping())
        return self.base.replace(terms=(springs, *self.effects), node_mass=mass)
