"""Where a fit starts: :func:`start_model` (a model file, a rule base's tissue, or the data
alone) and :func:`estimate_start`, the equation-error estimate from the data.

Start values from the data alone: equation-error least squares.

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

import os
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import lsq_linear

from ..errors import InputError
from ..experiment import Experiment, check_experiments, duration
from ..forces import SPRINGS, incidence
from ..forces.laws import LAWS, YEOH
from ..forces.relaxation import relaxation_fields, start_terms
from ..model import SpringMassModel, tie_index
from ..progress import note
from ._base import TiedSprings

__all__ = ["StartModel", "start_model", "estimate_start"]

#: Largest dense equation-error system (entries per force component) we build.
MAX_ENTRIES = 3e7
#: Per-group estimates further than this factor from the shared one are not trusted.
MAX_SPREAD = 10.0


@dataclass(frozen=True)
class StartModel:
    """A start model and where it came from.

    Attributes
    ----------
    model : SpringMassModel
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

    model: SpringMassModel
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


def start_model(experiments: Experiment | Sequence[Experiment], *,
                model: SpringMassModel | str | os.PathLike | None = None,
                rules=None, tissue: str | None = None, tie: str | None = None,
                elements: bool | None = None, law: str | None = None,
                relaxation=None, stiffening: float | None = None,
                progress: bool = False) -> StartModel:
    """The start of a fit of ``experiments``: the policy of ``neurofuzzy fit``.

    1. ``model`` (a :class:`SpringMassModel` or a model file, e.g. written by
       ``neurofuzzy mesh`` or a previous fit): used as it is, with its regions, tissues, masses
       and tie groups (``tie`` re-ties it within its regions); ``rules`` then only lends the
       words for the report (each region's tissue, or ``tissue`` for regions without one);
    2. ``rules`` and ``tissue``: the rule base's start values for the experiments' mesh (known
       masses of the experiments replace the rule base's): tetrahedral elements when the mesh
       has tetrahedra, else the spring network (``elements`` decides otherwise);
    3. otherwise the equation-error estimate from the data (:func:`estimate_start`), with one
       mass per node estimated when the experiments give none.

    Parameters
    ----------
    experiments : Experiment or sequence of Experiment
        Load cases of one object (one topology).
    model : SpringMassModel or path, optional
    rules : RuleBase, path or name of a shipped rule base (``"liver"``), optional
    tissue : str, optional
        With ``rules``: the tissue of the whole object.
    tie : {"global", "groups", "none"}, optional
        Parameter tying (default: the model's own, else ``"groups"``).
    elements : bool, optional
        With ``rules``: tetrahedral elements (True) or springs (False); default elements
        when the experiments' mesh has tetrahedra.
    law : str, optional
        The elements' material law for every element (:mod:`neurofuzzy.forces.laws`:
        ``"st-venant-kirchhoff"``, ``"neo-hookean"`` or ``"yeoh"``); default the model's own,
        else St. Venant–Kirchhoff.
    relaxation : int, sequence of (g, τ) or str, optional
        Prony relaxation of every element (:mod:`neurofuzzy.forces.relaxation`): a number
        of terms (1–3) started from g = 0.5 and times below the recording's length, or the
        terms' start values (:func:`~neurofuzzy.forces.relaxation.start_terms`); default the
        model's own, else none.
    stiffening : float, optional
        Yeoh's ``C₂₀/C₁₀`` to start the Yeoh elements from (``element_stiffening``;
        default the model's own, else :data:`~neurofuzzy.forces.laws.DEFAULT_STIFFENING`
        for elements that become Yeoh's).
    progress : bool
        Say on stderr where the start came from.

    Raises
    ------
    InputError
        Experiments of different objects; a model of another object; rules without a tissue;
        no masses given and none estimable; a law for a spring network; a stiffening without
        Yeoh elements.
    """
    begun = _start_model(experiments, model=model, rules=rules, tissue=tissue, tie=tie,
                         elements=elements, progress=progress)
    changes = {}
    for value, key, words in ((law, "--law", f"a material law ({law!r})"),
                              (relaxation, "--relaxation", "relaxation (Prony terms)"),
                              (stiffening, "--stiffening", "a stiffening (Yeoh's C20/C10)")):
        if value is not None and not begun.model.has_elements:
            raise InputError(f"{words} is one of tetrahedral elements; this start is a spring "
                             "network (give a model or experiment with tetrahedra, or "
                             "--elements tetra)", key=key)
    if law is not None:
        changes["element_law"] = law
    if stiffening is not None:
        changes["element_stiffening"] = stiffening
    if relaxation is not None:
        changes.update(relaxation_fields(start_terms(relaxation, duration(experiments))))
    if not changes:
        return begun
    changed = begun.model.replace(**changes)
    yeoh = changed.element_law == YEOH
    if stiffening is not None and not yeoh.any():
        raise InputError(f"a stiffening ({stiffening!r}) is Yeoh's C20/C10; this start has no "
                         "Yeoh elements (add --law yeoh)", key="--stiffening")
    if law is not None:
        note(progress, f"material law: {LAWS[int(changed.element_law[0])]}")
    if (law is not None or stiffening is not None) and yeoh.any():
        note(progress, "Yeoh stiffening C20/C10: "
             f"{float(np.mean(changed.element_stiffening[yeoh])):.3g}")
    if relaxation is not None:
        note(progress, "relaxation: " + ", ".join(
            f"g {g:.3g}, tau {t:.3g} s" for g, t in zip(changed.element_relaxation_moduli[0],
                                                        changed.element_relaxation_times[0])))
    return replace(begun, model=changed)


def _start_model(experiments, *, model, rules, tissue, tie, elements, progress) -> StartModel:
    """:func:`start_model` but for the law."""
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    if not experiments:
        raise InputError("no experiments given", key="experiments")
    first = experiments[0]
    if model is not None:
        from ..io import load_model

        given = model if isinstance(model, SpringMassModel) else load_model(model)
        source = "the given model" if isinstance(model, SpringMassModel) else str(model)
        check_experiments(given, experiments, model_source=None if isinstance(
            model, SpringMassModel) else source)
        given = given if tie is None else given.tied(tie)
        rule_base = None if rules is None else _rules(rules)
        if tissue is not None:
            _check_tissue(rule_base, tissue)
        note(progress, f"start values: {source}")
        return StartModel(given, "model", f"model {source}", rules=rule_base,
                          tissue=tissue or _single_tissue(given))
    check_experiments(_topology_model(first), experiments)
    tie = tie or "groups"
    if rules is not None:
        from ..tissues import initialize

        if not tissue:
            raise InputError("a rule base needs a tissue (--tissue NAME)", key="tissue")
        rule_base = _rules(rules)
        if elements is None:
            elements = first.mesh.tetrahedra is not None
        start = initialize(rule_base, first.mesh, tissue, elements=elements).tied(tie)
        if first.node_mass is not None:
            start = start.replace(node_mass=first.node_mass)
        note(progress, f"start values: rules {rule_base.source}, tissue {tissue}")
        return StartModel(start, "rules", f"rules {rule_base.source}, tissue {tissue}",
                          rules=rule_base, tissue=tissue)
    estimate_mass = first.node_mass is None
    if estimate_mass:
        note(progress, f"neurofuzzy: note: {first.source} gives no 'masses'; estimating one "
                       "mass per node from the data")
    guess = SpringMassModel(first.mesh, node_mass=1.0 if estimate_mass else first.node_mass,
                            spring_stiffness=1.0, spring_damping=1.0,
                            spring_tie=tie_index(first.mesh, tie))
    start = estimate_start(guess, experiments, estimate_mass=estimate_mass)
    if estimate_mass and not start.used:
        raise InputError(f"gives no 'masses', and they cannot be estimated here ({start.reason}"
                         "); give known masses (import with --topology MODEL.yaml), a start "
                         "model (--start MODEL.yaml) or a rule base (--rules R.yaml --tissue "
                         "NAME)", source=first.source, key="masses")
    note(progress, f"start values: {start.reason}" if start.used else
         f"start values: defaults ({start.reason})")
    return start


def _rules(value):
    from ..rules import resolve

    return resolve(value)


def _check_tissue(rule_base, tissue: str) -> None:
    """A tissue named beside a start model lends its words: it must be one of the rules'."""
    if rule_base is None:
        raise InputError(f"names tissue {tissue!r} but no rule base to take it from; give "
                         "the rule base too (--rules R)", key="tissue")
    if tissue not in rule_base.tissues:
        from ..rules.limits import unknown_tissue

        raise unknown_tissue(rule_base, tissue)


def _topology_model(experiment: Experiment) -> SpringMassModel:
    """A placeholder model with the experiment's topology (for the topology checks)."""
    return SpringMassModel(experiment.mesh, node_mass=1.0, spring_stiffness=1.0,
                           spring_damping=1.0)


def _single_tissue(model: SpringMassModel) -> str | None:
    tissues = set(model.region_tissues)
    return tissues.pop() if len(tissues) == 1 else None


def estimate_start(model: SpringMassModel, experiments: Experiment | Sequence[Experiment], *,
                   estimate_mass: bool = False) -> StartModel:
    """Start model whose tied spring constants (and, optionally, uniform mass) fit the data.

    The constants are first estimated with all springs tied together (two numbers, robust to
    noise), then per tie group of ``model``; a group whose estimate never moves in the data,
    hits zero or lies more than ``MAX_SPREAD`` times away from the shared estimate keeps the
    shared one (per-spring estimates from noisy second differences can be wild).

    Parameters
    ----------
    model : SpringMassModel
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
    tied = TiedSprings.of(model)
    s_ratio = tied.split(model.spring_stiffness)[1] if np.all(model.spring_stiffness > 0) \
        else np.ones(model.n_springs)
    c_ratio = tied.split(model.spring_damping)[1] if np.all(model.spring_damping > 0) \
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
    changes = {"spring_stiffness": stiffness[tied.tie] * s_ratio,
               "spring_damping": damping[tied.tie] * c_ratio}
    if estimate_mass:
        if not (mass is not None and mass > 0):
            return StartModel(model, "defaults", "the mass estimate was not positive")
        node_mass = model.node_mass.copy()
        node_mass[model.mesh.free] = mass
        changes["node_mass"] = node_mass
    return StartModel(model.replace(**changes), "equation error", reason)


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
            templates = SPRINGS.parameter_templates(SPRINGS.state(model, p[t], v[t]))
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
