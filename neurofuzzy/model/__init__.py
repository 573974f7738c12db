"""The model: a :class:`~neurofuzzy.mesh.Mesh` with node masses and the constants of its force
terms (:class:`SpringMassModel`), and the tying of its springs (:func:`tie_index`)."""

from .springmass import VOLUMETRIC, SpringMassModel
from .values import TIES, Tie, tie_index

__all__ = ["SpringMassModel", "Tie", "TIES", "tie_index", "VOLUMETRIC"]
