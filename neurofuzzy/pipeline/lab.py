"""Experiments as labs run them, through :func:`neurofuzzy.fit`: a load-step file (scans at
equilibria, :func:`~.load_steps.fit_load_step_file`) or a recording in time whose body a stage
moved (driven sets or a tool, :func:`~.moving.fit_moving_file`) is fitted as ``neurofuzzy
fit`` fits it; :func:`lab_kind` tells them from the time series of forces on nodes.
"""

from __future__ import annotations

import os
from dataclasses import fields

import numpy as np

from ..errors import InputError
from .options import FitOptions

__all__ = ["lab_kind", "fit_lab", "refuse_options", "lab_steps", "LOAD_STEPS", "MOVING"]

#: what :func:`lab_kind` answers
LOAD_STEPS, MOVING = "load steps", "moving boundaries"


def lab_kind(experiments) -> str | None:
    """``"load steps"`` or ``"moving boundaries"`` when ``experiments`` (an object, a path,
    or a sequence of them) holds a load-step file or a recording whose body a stage moved,
    else None (forces on nodes in time: the learners' fit). A lab experiment is fitted on its
    own: one beside others is refused."""
    from ..experiment import Experiment
    from ..io.load_steps import is_load_steps_file
    from ..io.paths import is_moved_file
    from ..load_steps import LoadSteps

    def kind(item):
        if isinstance(item, LoadSteps):
            return LOAD_STEPS
        if isinstance(item, Experiment):
            return MOVING if item.driven or item.tool is not None else None
        if isinstance(item, str | os.PathLike):
            return (LOAD_STEPS if is_load_steps_file(item)
                    else MOVING if is_moved_file(item) else None)
        return None

    items = experiments if isinstance(experiments, list | tuple) else [experiments]
    kinds = [kind(item) for item in items]
    found = next((k for k in kinds if k is not None), None)
    if found is not None and len(items) > 1:
        raise InputError(f"holds {found} beside other experiments; a lab experiment (a load-step "
                         "file, a recording whose body a stage moved) is fitted on its own",
                         key="experiments")
    return found


def fit_lab(kind: str, experiment, *, start=None, rules=None, tissue: str | None = None,
            law: str | None = None, validate_on=None, options: FitOptions, refused: dict):
    """The fit of one lab experiment of ``kind`` (:func:`lab_kind`), with the start keywords
    of :func:`neurofuzzy.fit`; ``options``: its mesh check, progress and (moving
    boundaries) implicit steps per frame. ``refused``: keywords of the learners' fit given
    to it, refused by name. Returns a :class:`~.load_steps.LoadStepOutcome`."""
    from ..progress import note
    from ..rules import resolve

    default = FitOptions()
    learner_options = [f.name for f in fields(FitOptions)
                       if f.name not in ("mesh_check", "progress", "substeps")
                       and getattr(options, f.name) != getattr(default, f.name)]
    takes = ("start, rules, tissue, law and the options mesh_check, progress and substeps"
             if kind == MOVING else "start, rules, tissue, law, validate_on (load steps) "
             "and the options mesh_check and progress")
    refuse_options({**refused, **dict.fromkeys(learner_options, True)},
                   f"the learners' fit of forces on nodes in time; the fit of {kind} takes "
                   f"{takes}")
    rules = resolve(rules) if rules is not None else None
    say = (lambda text: note(True, text)) if options.progress else None
    if kind == LOAD_STEPS:
        from .load_steps import fit_load_step_file

        lab_steps(kind, options.substeps)
        steps = [] if validate_on is None else _steps(validate_on)
        return fit_load_step_file(experiment, start=start, rules=rules, tissue=tissue,
                                  law=law, validate_on=steps, mesh_check=options.mesh_check,
                                  progress=say)
    from .moving import fit_moving_file

    if validate_on is not None:
        raise InputError("holds no data out of a recording whose body a stage moved (yet); "
                         "fit it whole", key="validate_on")
    return fit_moving_file(experiment, start=start, rules=rules, tissue=tissue, law=law,
                           mesh_check=options.mesh_check,
                           substeps=lab_steps(kind, options.substeps), progress=say)


def refuse_options(given: dict, of: str) -> None:
    """Refuse, by name, every option in ``given`` (name → value) that is not None: they are
    options ``of`` another kind of experiment (an :class:`InputError` naming them all)."""
    names = [name for name, value in given.items() if value is not None]
    if names:
        raise InputError(f"{'is an option' if len(names) == 1 else 'are options'} of {of}",
                         key=", ".join(names))


def lab_steps(kind: str, substeps) -> int | None:
    """Implicit steps per frame of a lab experiment of ``kind`` from the ``substeps`` given:
    a recording in time takes a positive int (``"auto"``: one a frame); load steps are
    equilibria and take only ``"auto"`` (None)."""
    from ..simulation import check_substeps

    if kind == LOAD_STEPS:
        if substeps != "auto":
            raise InputError("load steps are equilibria: there are no steps in time to "
                             "divide", key="substeps")
        return None
    steps = check_substeps(substeps, "substeps")
    return 1 if steps == "auto" else steps


def _steps(validate_on) -> list[int]:
    """Held-out load steps: an int or a sequence of ints (step 0 is the reference)."""
    values = (list(validate_on) if isinstance(validate_on, list | tuple)
              else [validate_on])
    if not values or not all(isinstance(v, int | np.integer) and not isinstance(v, bool)
                             for v in values):
        raise InputError(f"got {validate_on!r}; a load-step fit holds out load steps by "
                         "number (an int or a list of ints)", key="validate_on")
    return [int(v) for v in values]
