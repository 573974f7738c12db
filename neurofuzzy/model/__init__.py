"""The model: a :class:`~neurofuzzy.mesh.Mesh`, node masses and a tuple of force terms
(:class:`Model`), and the tying of its springs (:func:`tie_index`)."""

from ..forces.tetrahedra import VOLUMETRIC
from .model import Model
from .values import TIES, Tie, term_values, tie_index

__all__ = ["Model", "Tie", "TIES", "tie_index", "term_values", "VOLUMETRIC"]

