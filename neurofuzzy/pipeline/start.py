"""Where a fit starts: :func:`start_model`, the policy of ``neurofuzzy fit`` (a model or
model file, a rule base's tissue, or the data alone through the learner's equation-error
estimate, :func:`~neurofuzzy.learn.estimate_start`), with the law, relaxation and stiffening
the fit's options ask for."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..errors import InputError
from ..experiment import Experiment, check_experiments, duration
from ..forces.laws import LAWS, STIFFENING_CONSTANT
from ..forces.relaxation import relaxation_fields, start_terms
from ..learn import StartModel, estimate_start
from ..forces import Springs
from ..model import Model, tie_index
from ..progress import note

__all__ = ["start_model"]


def start_model(experiments: Experiment | Sequence[Experiment], *,
                model: Model | str | os.PathLike | None = None,
                rules=None, tissue: str | None = None, tie: str | None = None,
                elements: bool | None = None, law: str | None = None,
                relaxation=None, stiffening: float | None = None,
                progress: bool = False) -> StartModel:
    """The start of a fit of ``experiments``: the policy of ``neurofuzzy fit``.

    1. ``model`` (a :class:`Model` or a model file, e.g. written by
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
    model : Model or path, optional
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
        if value is not None and begun.model.elements is None:
            raise InputError(f"{words} is one of tetrahedral elements; this start is a spring "
                             "network (give a model or experiment with tetrahedra, or "
                             "--elements tetra)", key=key)
    if law is not None:
        changes["law"] = law
    if stiffening is not None:
        changes["stiffening"] = stiffening
    if relaxation is not None:
        changes.update(relaxation_fields(start_terms(relaxation, duration(experiments))))
    if not changes:
        return begun
    changed = begun.model.with_elements(**changes)
    own = changed.elements.stiffens
    if stiffening is not None and not own.any():
        raise InputError(f"a stiffening ({stiffening!r}) is the law's own constant (Yeoh's "
                         "C20/C10, Mooney-Rivlin's C01/C10); this start has no elements of "
                         "such a law (add --law yeoh or --law mooney-rivlin)",
                         key="--stiffening")
    if law is not None:
        note(progress, f"material law: {LAWS[int(changed.elements.law[0])]}")
    if (law is not None or stiffening is not None) and own.any():
        number = int(changed.elements.law[own][0])
        note(progress, f"{LAWS[number].capitalize()} {STIFFENING_CONSTANT[number]}: "
             f"{float(np.mean(changed.elements.stiffening[own])):.3g}")
    if relaxation is not None:
        note(progress, "relaxation: " + ", ".join(
            f"g {g:.3g}, tau {t:.3g} s" for g, t in zip(changed.elements.relaxation_moduli[0],
                                                        changed.elements.relaxation_times[0])))
    return replace(begun, model=changed)


def _start_model(experiments, *, model, rules, tissue, tie, elements, progress) -> StartModel:
    """:func:`start_model` but for the law."""
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    if not experiments:
        raise InputError("no experiments given", key="experiments")
    first = experiments[0]
    if model is not None:
        from ..io import load_model

        given = model if isinstance(model, Model) else load_model(model)
        source = "the given model" if isinstance(model, Model) else str(model)
        check_experiments(given, experiments, model_source=None if isinstance(
            model, Model) else source)
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
    guess = Model(first.mesh, 1.0 if estimate_mass else first.node_mass,
                  (Springs(stiffness=1.0, damping=1.0, tie=tie_index(first.mesh, tie)),))
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


def _topology_model(experiment: Experiment) -> Model:
    """A placeholder model with the experiment's topology (for the topology checks)."""
    return Model(experiment.mesh, 1.0, (Springs(stiffness=1.0, damping=1.0),))


def _single_tissue(model: Model) -> str | None:
    tissues = set(model.region_tissues)
    return tissues.pop() if len(tissues) == 1 else None
