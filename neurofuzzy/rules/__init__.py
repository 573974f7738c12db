"""Fuzzy rule bases: medical words in, material values out, words back. Words only: nothing
here imports the physics.

- :func:`load_rules` reads and validates a YAML rule base (format: ``rules/README.md``;
  :mod:`.parser`), :func:`resolve` also takes a bare name (``"liver"``), which
  :func:`locate` finds as ``./rules/liver.yaml``, ``./liver.yaml``, then the shipped copy;
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

__all__ = ["RuleBase", "RuleBaseError", "Label", "load_rules", "resolve", "locate", "QUANTITIES",
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


def locate(value, *, folder=None):
    """The rule file that ``value`` names.

    A path that exists is itself. A bare name (no suffix, no folder: ``"liver"``) is the
    user's copy first, the shipped one last: ``FOLDER/rules/liver.yaml``, then
    ``FOLDER/liver.yaml``, then :func:`shipped` (so the file a user copied and edited is
    the one used). Anything else is returned as it is, for :func:`load_rules` to refuse.

    Parameters
    ----------
    value : str or path
    folder : path, optional
        Where the user's copies are looked for (default the current folder; a manifest's
        folder for ``fit-many``).
    """
    from pathlib import Path

    path = Path(value)
    if path.exists() or path.suffix or "/" in str(value) or "\\" in str(value):
        return path if folder is None or path.is_absolute() else Path(folder) / path
    name = f"{value}.yaml"
    base = Path(folder) if folder is not None else Path()
    for candidate in (base / "rules" / name, base / name):
        if candidate.is_file():
            return candidate
    return shipped(str(value))


def resolve(value) -> RuleBase:
    """A :class:`RuleBase` from itself, a path, or a bare name (``"liver"``: ``./rules/
    liver.yaml``, ``./liver.yaml``, else the shipped one; :func:`locate`). Which file was
    read is its ``source``, ``sha256`` and :meth:`~RuleBase.provenance`."""
    if isinstance(value, RuleBase):
        return value
    return load_rules(locate(value))
