"""Start values from the data alone: :func:`estimate_start`, equation-error least squares,
and :class:`StartModel`, a start and where it came from. (Where a fit starts, from a model
file, a rule base's tissue or the data, is the pipeline's choice:
:func:`neurofuzzy.pipeline.start_model`.)

With every node observed, the measured positions give each node's velocity and acceleration by
finite differences (for our integrator exactly: ``v(t) = (p(t) - p(t-1)) / h`` and
``a(t) = (p(t+1) - p(t)) / h² - v(t) / h``), and Newton's law at every free node and frame,

    m_i a_i(t) - f_ext,i(t) = Σ_k s_k G_k,i(t) + Σ_k c_k H_k,i(t),

is *linear* in the shared stiffness ``s_k`` and viscosity ``c_k`` of the tie groups
(``G``, ``H``: the spring forces per unit constant). Solving it with non-negativity bounds gives
start values close to the answer without any simulation; the learners then refine them on the
free-running error, which is robust to the noise that finite differences amplify.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

from ..experiment import Experiment, check_experiments
from ..forces import incidence
from ..forces.blocks import TieGroups
from ..forces.springs import parameter_templates, spring_state
from ..model import Model

__all__ = ["StartModel", "estimate_start"]

#: Largest dense equation-error system (entries per force component) we build.
MAX_ENTRIES = 3e7
#: Per-group estimates further than this factor from the shared one are not trusted.
MAX_SPREAD = 10.0


@dataclass(frozen=True)
class StartModel:
    """A start model and where it came from.

    Attributes
    ----------
    model : Model
    how : {"model", "rules", "equation error", "defaults"}
        A model given (file or object), a rule base's tissue, the equation-error estimate from
        the data, or the given model unchanged because the data could not say.
    reason : str
        In words, for reports and progress messages.
    rules : RuleBase or None
        The rule base, when the start came from one (for words in the report).
    tissue : str or None
        Its tissue (one-tissue starts).
    """

    model: Model
    how: str
    reason: str
    rules: object = None
    tissue: str | None = None

    @property
    def used(self) -> bool:
        """False when the data could not give a start and defaults were kept."""
        return self.how != "defaults"

    def to_dict(self) -> dict:
        return {"used": self.used, "how": self.how, "reason": self.reason,
                "tissue": self.tissue}


def estimate_start(model: Model, experiments: Experiment | Sequence[Experiment], *,
                   estimate_mass: bool = False) -> StartModel:
    """Start model whose tied spring constants (and, optionally, uniform mass) fit the data.

    The constants are first estimated with all springs tied together (two numbers, robust to
    noise), then per tie group of ``model``; a group whose estimate never moves in the data,
    hits zero or lies more than ``MAX_SPREAD`` times away from the shared estimate keeps the
    shared one (per-spring estimates from noisy second differences can be wild).

    Parameters
    ----------
    model : Model
        Topology, tying and masses; its spring values are the fallback.
    experiments : Experiment or sequence of Experiment
    estimate_mass : bool
        Also estimate one mass shared by all free nodes (when the data give none).

    Returns
    -------
    StartModel
        ``how="equation error"`` with the estimated model, or ``how="defaults"`` with the
        input unchanged and the reason the data could not say.
    """
    experiments = check_experiments(model, experiments)
    if not all(e.complete for e in experiments):
        return StartModel(model, "defaults", "some free nodes are unobserved or have gaps")
    springs = model.springs
    if springs is None:
        return StartModel(model, "defaults", "the model has no springs (the equation-error "
                                             "estimate is of spring constants)")
    tied = TieGroups.of(springs.tie)
    s_ratio = tied.split(springs.stiffness)[1] if np.all(springs.stiffness > 0) \
        else np.ones(model.n_springs)
    c_ratio = tied.split(springs.damping)[1] if np.all(springs.damping > 0) \
        else np.ones(model.n_springs)
    shared = _solve(model, experiments, np.zeros(model.n_springs, dtype=np.intp), s_ratio,
                    c_ratio, estimate_mass)
    if shared is None or not (shared[0][0] > 0 and shared[1][0] > 0):
        return StartModel(model, "defaults",
                          "the equation-error estimate was not positive (noisy data?)")
    stiffness = np.full(tied.n_ties, shared[0][0])
    damping = np.full(tied.n_ties, shared[1][0])
    mass = shared[2]
    reason = "equation-error least squares"
    if tied.n_ties > 1:
        grouped = _solve(model, experiments, tied.tie, s_ratio, c_ratio, estimate_mass)
        if grouped is None:
            reason += " (one shared value: the per-group system is too large)"
        else:
            for values, estimate in ((stiffness, grouped[0]), (damping, grouped[1])):
                plausible = (estimate > values / MAX_SPREAD) & (estimate < values * MAX_SPREAD)
                values[plausible] = estimate[plausible]
            if estimate_mass and grouped[2] is not None and grouped[2] > 0:
                mass = grouped[2]
    model = model.with_term(springs.replace(stiffness=stiffness[tied.tie] * s_ratio,
                                            damping=damping[tied.tie] * c_ratio))
    changes = {}
    if estimate_mass:
        if not (mass is not None and mass > 0):
            return StartModel(model, "defaults", "the mass estimate was not positive")
        node_mass = model.node_mass.copy()
        node_mass[model.mesh.free] = mass
        changes["node_mass"] = node_mass
    return StartModel(model.replace(**changes) if changes else model, "equation error", reason)


def _solve(model, experiments, tie, s_ratio, c_ratio, estimate_mass):
    """Non-negative least squares of Newton's law for the tied constants; ``(stiffness,
    damping, mass or None)`` per tie group (NaN for groups that never move), or None when the
    system would be too large."""
    n_ties = int(tie.max()) + 1
    free = model.mesh.free
    size = sum(e.n_frames for e in experiments) * model.n_nodes * n_ties * 3
    if size > MAX_ENTRIES:
        return None
    maps = incidence(model.mesh)
    columns, targets = [], []
    for experiment in experiments:
        p = experiment.positions
        h = experiment.dt
        loads = experiment.forces_per_frame()[:-1]
        v = np.zeros_like(p)
        v[1:] = (p[1:] - p[:-1]) / h
        accel = (p[1:] - p[:-1]) / (h * h) - v[:-1] / h          # (T-1, N, 3)
        per_frame = []                 # (F, 2K, 3) per frame: node force of every tie group
        for t in range(len(accel)):
            templates = parameter_templates(spring_state(model, p[t], v[t]))
            per_frame.append(np.concatenate([
                maps.group_sums(templates[name] * ratio[:, None], tie, n_ties)[free]
                for name, ratio in (("stiffness", s_ratio), ("damping", c_ratio))], axis=1))
        blocks = [np.stack(per_frame).transpose(0, 1, 3, 2).reshape(-1, 2 * n_ties)]
        if estimate_mass:
            blocks.append(-accel[:, free].reshape(-1, 1))
            targets.append(-loads[:, free].ravel())
        else:
            targets.append((model.node_mass[free, None] * accel[:, free]
                            - loads[:, free]).ravel())
        columns.append(np.concatenate(blocks, axis=1))
    matrix = np.concatenate(columns)
    target = np.concatenate(targets)
    norms = np.linalg.norm(matrix, axis=0)
    usable = (norms > 0) & np.isfinite(norms)
    solution = np.full(matrix.shape[1], np.nan)
    solution[usable] = lsq_linear(matrix[:, usable] / norms[usable], target,
                                  bounds=(0, np.inf)).x / norms[usable]
    mass = solution[-1] if estimate_mass else None
    return solution[:n_ties], solution[n_ties:2 * n_ties], mass
