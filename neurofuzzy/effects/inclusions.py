"""Inclusions: a compact region stiffer (or softer) than the rest of the object.

On a spring network the region is a set of springs with extra stiffness ``k`` (N/m, one per
spring group): they pull with ``(s_j + k) (l - L0)``. On a tetrahedral-element model it is a
set of elements with extra Young's modulus ``δ`` (Pa) at a Poisson's ratio ``ν_R`` fixed
when the inclusion is made (the region's own at the time): the element force of the
materials ``(δ on the region, ν_R, no viscosity)`` added to the model's own (the force is
linear in the material constants, for both volumetric forms). With ``ν_R`` the region's
Poisson's ratio this is exactly the model with ``E_e + δ`` there; keeping it fixed keeps the
inclusion's force independent of the model's own parameters, so the learners' derivatives
stay exact when both are fitted.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..forces import ElementConstants, tetrahedron_geometry
from ..forces.element_forces import (element_force, element_rest_matrices, element_state_jvp,
                                     element_state_vjp)
from ..forces.springs import spring_constants, spring_law
from .base import Effect, register
from .springs import SpringEffect

__all__ = ["StiffInclusion", "SoftInclusion"]


class _Inclusion(SpringEffect):
    """A compact region of springs (``springs=``) or of tetrahedral elements (``elements=``)
    with extra stiffness: ``k`` per spring group, or one extra Young's modulus ``δ``."""

    coefficient = "extra_stiffness"

    def __init__(self, params, *, springs=None, elements=None, poisson_ratio=None, **options):
        if (springs is None) == (elements is None):
            raise InputError("an inclusion needs its springs or its elements (one of them)",
                             key="params")
        if elements is None:
            super().__init__(params, springs=springs, **options)
            return
        options["elements"] = sorted(int(e) for e in np.ravel(elements))
        if not options["elements"]:
            raise InputError("an inclusion needs at least one element", key="elements")
        if poisson_ratio is None or not 0 < float(poisson_ratio) < 0.5:
            raise InputError(f"got {poisson_ratio!r}; an inclusion of elements needs the "
                             "Poisson's ratio of its extra stiffness, in (0, 0.5)",
                             key="poisson_ratio")
        options["poisson_ratio"] = float(poisson_ratio)
        Effect.__init__(self, params, **options)

    @classmethod
    def of_elements(cls, model, elements, extra: float = 0.0):
        """The inclusion of ``elements`` of ``model`` at their own Poisson's ratio (median)."""
        nu = float(np.median(model.elements.poisson_ratio[np.asarray(elements, int)]))
        return cls([extra], elements=elements, poisson_ratio=nu)

    @property
    def on_elements(self) -> bool:
        return "elements" in self.options

    def compile(self, layout, model, column):
        """Extra element constants, or extra stiffness along springs."""
        if self.on_elements:
            layout.add_element_constants(
                self.added_constants(model, self.params[0]),
                None if column is None else (self.elements, column,
                                             self.added_constants(model, 1.0)))
        else:
            layout.add_spring_stretch(self.per_spring(model), self.learned_springs(model, column))

    #: the sign of the examples' extra stiffness
    _sign = 1.0

    @classmethod
    def examples(cls, model):
        """Half the springs (spring networks) or half the elements (element models)."""
        if model.elements is not None:
            elements = np.arange(model.mesh.n_tetrahedra // 2)
            return [(model, cls.of_elements(model, elements, cls._sign * 1e3))]
        springs = np.arange(model.n_springs // 2)
        return [(model, cls.for_model(model, cls._sign * 10.0, springs=springs))]

    @property
    def labels(self):
        return ("extra_youngs_modulus",) if self.on_elements else super().labels

    @property
    def unit(self):
        """Pa for elements, N/m for springs (exponents of length, time, mass)."""
        return (-1, -2, 1) if self.on_elements else (0, -2, 1)

    def shape(self, model, state, selection):
        """``(x, 1)``: the magnitude of a unit extra stiffness
        (:func:`neurofuzzy.kernels.springs.magnitude`)."""
        return spring_law().magnitudes(state.stretch, stiffness=1.0)

    # -- elements -----------------------------------------------------------------------------
    def added_constants(self, model, extra: float) -> ElementConstants:
        """The region's extra element constants: Young's modulus ``extra`` on its elements, zero
        elsewhere, the inclusion's Poisson's ratio, no viscosity, the elements' own law."""
        if model.elements is None:
            raise InputError("an inclusion of elements needs a model with tetrahedral elements",
                             key="elements")
        modulus = np.zeros(model.mesh.n_tetrahedra)
        modulus[self.elements] = extra
        return ElementConstants.from_values(tetrahedron_geometry(model.mesh), modulus,
                                            self.options["poisson_ratio"],
                                            np.zeros_like(modulus),
                                            nodal=model.elements.volumetric == "nodal",
                                            law=model.elements.law,
                                            stiffening=model.elements.stiffening)

    def force(self, model, positions, velocities):
        if not self.on_elements:
            return super().force(model, positions, velocities)
        return element_force(self.added_constants(model, self.params[0]), positions,
                                   velocities)

    def parameter_jacobian(self, model, positions, velocities):
        if not self.on_elements:
            return super().parameter_jacobian(model, positions, velocities)
        return element_force(self.added_constants(model, 1.0), positions,
                                   velocities)[:, None, :]

    def state_jvp(self, model, positions, velocities, dp, dv):
        if not self.on_elements:
            return super().state_jvp(model, positions, velocities, dp, dv)
        return element_state_jvp(self.added_constants(model, self.params[0]), positions,
                                       velocities, dp, dv)

    def state_vjp(self, model, positions, velocities, cotangent):
        if not self.on_elements:
            return super().state_vjp(model, positions, velocities, cotangent)
        return element_state_vjp(self.added_constants(model, self.params[0]), positions,
                                       velocities, cotangent)

    def rest_matrices(self, model):
        """The region's extra stiffness at rest (elements; springs add none to the bound)."""
        if not self.on_elements:
            return None
        return element_rest_matrices(self.added_constants(model, max(self.params[0], 0.0)))

    def relative(self, model) -> dict[str, float]:
        """The extra stiffness relative to the region's own (per spring group, or ``δ / E``)."""
        if not self.on_elements:
            return super().relative(model)
        own = float(np.mean(model.elements.youngs_modulus[self.elements]))
        return {self.labels[0]: float(self.params[0] / own)}

    def equation(self):
        if self.on_elements:
            return (f"{self.name}: {len(self.elements)} elements stiffer by δ (E_e + δ); "
                    f"{self._values()} Pa")
        return (f"{self.name}: {len(self.springs)} springs pull harder by k (l - L0); "
                f"{self._values()}")


@register
class StiffInclusion(_Inclusion):
    """A compact region stiffer than the rest (k > 0 or δ > 0)."""

    name = "stiff_inclusion"

    @classmethod
    def propose(cls, model, evidence):
        """The compact region (of springs, or of elements for element models) that best
        explains the residual (the diagnosis names it soft_inclusion when the fitted extra
        stiffness comes out negative)."""
        if model.elements is not None and not np.any(spring_constants(model)[0]):
            region = evidence.element_region(evidence.taken_elements)
            return [cls.of_elements(model, region)] if region else []
        region = evidence.inclusion_region(evidence.taken_springs)
        return [cls.for_model(model, [0.0], springs=region)] if region else []


@register
class SoftInclusion(_Inclusion):
    """A compact region softer than the rest (k < 0 or δ < 0)."""

    name = "soft_inclusion"
    _sign = -1.0

    @classmethod
    def propose(cls, model, evidence):
        """None of its own: :class:`StiffInclusion`'s region, refitted, turns soft when its
        extra stiffness is negative."""
        return []
