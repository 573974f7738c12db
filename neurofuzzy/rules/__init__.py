"""Fuzzy rule bases: medical words in, model parameters out, words back.

- :func:`load_rules` reads and validates a YAML rule base (format: ``rules/README.md``;
  :mod:`.parser`), :func:`resolve` also takes the name of a shipped one;
- :meth:`RuleBase.infer` / :meth:`RuleBase.tissue` turn words into material values
  (scikit-fuzzy membership functions, vectorised over many descriptions);
- :func:`initialize` makes a start model of a lattice mesh from a tissue;
- :meth:`RuleBase.describe` and :meth:`RuleBase.explain` turn numbers back into words;
- :func:`material_values` reads the material values a (fitted) model stands for.
"""

from ..errors import RuleFileDeprecationWarning
from .parser import load_rules
from .materials import materials
from .physical import element_model, initialize, lattice_geometry, material_values
from .rulebase import RuleBase
from .terms import QUANTITIES, Label, RuleBaseError

__all__ = ["RuleBase", "RuleBaseError", "Label", "load_rules", "resolve", "initialize",
           "lattice_geometry", "material_values", "materials", "element_model", "QUANTITIES",
           "RuleFileDeprecationWarning", "shipped"]


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

