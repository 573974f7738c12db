"""Fuzzy rule bases: medical words in, model parameters out, words back.

- :func:`load_rules` reads and validates a YAML rule base (format: ``rules/README.md``);
- :meth:`RuleBase.infer` / :meth:`RuleBase.tissue` turn words into material values
  (scikit-fuzzy membership functions, vectorised over many descriptions);
- :func:`initialize` makes a start model of a lattice mesh from a tissue;
- :meth:`RuleBase.describe` and :meth:`RuleBase.explain` turn numbers back into words;
- :func:`material_values` reads the material values a (fitted) model stands for.
"""

from .base import QUANTITIES, Label, RuleBase, RuleBaseError, load_rules
from .physical import initialize, lattice_geometry, material_values

__all__ = ["RuleBase", "RuleBaseError", "Label", "load_rules", "initialize",
           "lattice_geometry", "material_values", "QUANTITIES"]
