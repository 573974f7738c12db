"""The model: a :class:`~neurofuzzy.mesh.Mesh`, node masses and a tuple of force terms
(:class:`Model`), and the tying of its springs (:func:`tie_index`).

``SpringMassModel`` is the model's name before a model was made of terms (the same class)."""

from ..forces.tetrahedra import VOLUMETRIC
from .model import Model
from .values import TIES, Tie, tie_index

#: The model's former name (one class holds spring networks and element models alike).
SpringMassModel = Model

__all__ = ["Model", "SpringMassModel", "Tie", "TIES", "tie_index", "VOLUMETRIC"]
