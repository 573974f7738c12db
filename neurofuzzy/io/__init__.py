"""Files in and out: experiment files (``.npz``, :mod:`.experiments`), model and fit-record
files (YAML, :mod:`.models`), YAML read with line numbers and limits (:mod:`.safe_yaml`), and
the atomic writer and JSON-ready values every output goes through (:mod:`.writing`).

Every reader validates what it reads and raises :class:`~neurofuzzy.errors.InputError` naming
the file, the key and, for YAML, the line. Every writer writes atomically (a temporary file in
the target folder, then a rename), so a failure never leaves a half-written file behind and a
user's input file is never overwritten by a partial one.

The readers and writers of experiments and models are imported on first use (PEP 562): a
module that only writes JSON or reads YAML (the rule studio, the rule parser) does not load the
simulator with them.
"""

from typing import TYPE_CHECKING

from ..lazy import lazy

_EXPORTS = {"load_experiment": "experiments", "save_experiment": "experiments",
            "load_model": "models", "save_model": "models", "load_fit_record": "models",
            "atomic_write": "writing",
            "load_load_steps": "load_steps", "save_load_steps": "load_steps"}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy(__name__, _EXPORTS)


if TYPE_CHECKING:      # for type checkers and IDEs: the same names, imported eagerly
    from .experiments import load_experiment, save_experiment  # noqa: F401
    from .models import load_fit_record, load_model, save_model  # noqa: F401
    from .writing import atomic_write  # noqa: F401
    from .load_steps import load_load_steps, save_load_steps  # noqa: F401
