"""The model: a :class:`~neurofuzzy.mesh.Mesh`, node masses and a tuple of force terms
(:class:`Model`), and the tying of its springs (:func:`tie_index`).

``SpringMassModel`` is the model's name before a model was made of terms (the same class,
deprecated)."""

import warnings

from ..forces.tetrahedra import VOLUMETRIC
from .model import Model
from .values import TIES, Tie, term_values, tie_index

__all__ = ["Model", "Tie", "TIES", "tie_index", "term_values", "VOLUMETRIC"]


def __getattr__(name: str):
    if name == "SpringMassModel":
        warnings.warn("SpringMassModel is the model's name before terms, deprecated; use Model "
                      "(the same class)", DeprecationWarning, stacklevel=2)
        return Model
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
