"""Fuzzy rule bases: medical words in, material values out, words back. Words only: nothing
here imports the physics.

- :func:`load_rules` reads and validates a YAML rule base (format: ``rules/README.md``;
  :mod:`.parser`), :func:`resolve` also takes the name of a shipped one;
- :meth:`RuleBase.infer` / :meth:`RuleBase.tissue` turn words into material values
  (scikit-fuzzy membership functions, vectorised over many descriptions);
- :meth:`RuleBase.describe` and :meth:`RuleBase.explain` turn numbers back into words.

The start model of a mesh from a tissue (:func:`neurofuzzy.initialize`) and the values and
words a fitted model stands for (:func:`neurofuzzy.material_values`,
:func:`neurofuzzy.materials`) join the words to the physics in :mod:`neurofuzzy.tissues`.
"""

from ..errors import RuleFileDeprecationWarning
from .parser import load_rules
from .rulebase import RuleBase
from .terms import QUANTITIES, Label, RuleBaseError

__all__ = ["RuleBase", "RuleBaseError", "Label", "load_rules", "resolve", "QUANTITIES",
           "RuleFileDeprecationWarning", "shipped"]

#: names this package held before the words and the physics were parted, and where they are
MOVED = {"initialize": "neurofuzzy.initialize (neurofuzzy.tissues)",
         "material_values": "neurofuzzy.material_values (neurofuzzy.tissues)",
         "materials": "neurofuzzy.materials (neurofuzzy.tissues)",
         "element_model": "neurofuzzy.tissues.element_model",
         "lattice_geometry": "neurofuzzy.constants.lattice_geometry"}


def __getattr__(name: str):
    if name in MOVED:
        raise AttributeError(f"neurofuzzy.rules.{name} has moved to {MOVED[name]}; the rule "
                             "bases hold words only")
    raise AttributeError(f"module 'neurofuzzy.rules' has no attribute {name!r}")


def shipped(name: str):
    """Path of a rule base shipped with neurofuzzy (``shipped("brain")`` → ``rules/brain.yaml``).

    Installed packages carry the repository's ``rules/`` folder as ``neurofuzzy.shipped_rules``;
    in a source checkout the folder itself is used.
    """
    from importlib import resources
    from pathlib import Path

    from ..errors import InputError

    filename = name if name.endswith(".yaml") else f"{name}.yaml"
    candidates = [Path(__file__).resolve().parents[2] / "rules" / filename]
    try:
        candidates.insert(0, Path(str(resources.files("neurofuzzy.shipped_rules") / filename)))
    except ModuleNotFoundError:
        pass
    for path in candidates:
        if path.is_file():
            return path
    raise InputError(f"no shipped rule base {name!r}", key="rules")


def resolve(value) -> RuleBase:
    """A :class:`RuleBase` from itself, a path, or the name of a shipped one (``"liver"``)."""
    from pathlib import Path

    if isinstance(value, RuleBase):
        return value
    path = Path(value)
    if not path.exists() and path.suffix == "" and "/" not in str(value):
        path = shipped(str(value))
    return load_rules(path)

