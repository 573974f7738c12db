"""Where the words meet the physics: a rule base's tissues → a start model
(:func:`initialize`), and a (fitted) model → the material values it stands for
(:func:`material_values`) and their words (:func:`materials`).

The rule bases (:mod:`neurofuzzy.rules`) hold words only (YAML, inference, description); the
physics of the values (spring homogenisation, element models) is :mod:`neurofuzzy.constants`.
This package joins the two and uses a rule base through its methods (``tissue``, ``outputs``,
``describe``), so that neither of them imports the other."""

from .initialize import element_model, initialize
from .values import material_values, materials

__all__ = ["initialize", "element_model", "material_values", "materials"]
