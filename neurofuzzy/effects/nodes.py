"""Effects that act on every node (gravity, drag of the surrounding medium) or at one node (an
unmodeled load)."""

from __future__ import annotations

import numpy as np

from .base import Effect, register

__all__ = ["Gravity", "NodeDrag", "UnmodeledLoad"]


def _compile_constant(effect, layout, model, column) -> None:
    """``effect``'s force, which depends on neither positions nor velocities, in the loads
    (:meth:`~neurofuzzy.effects.compiled.KernelEffects.add_constant`)."""
    layout.add_constant(effect.force(model, None, None), column,
                        None if column is None else effect.parameter_jacobian(model, None, None))


@register
class Gravity(Effect):
    """Uniform acceleration ``g`` (direction and magnitude learned): ``F_i = m_i g``."""

    name = "gravity"
    unit = (1, -2, 0)
    _labels = ("gx", "gy", "gz")
    per_unit_mass = True

    def compile(self, layout, model, column):
        """A state-independent force: added to the loads."""
        _compile_constant(self, layout, model, column)

    def force(self, model, positions, velocities):
        return model.node_mass[:, None] * self.params[None, :]

    def parameter_jacobian(self, model, positions, velocities):
        return model.node_mass[:, None, None] * np.eye(3)[None]

    @classmethod
    def examples(cls, model):
        return [(model, cls([0.3, -0.2, -9.81]))]

    def equation(self):
        g = self.params
        return (f"gravity: F_i += m_i g, g = ({g[0]:.4g}, {g[1]:.4g}, {g[2]:.4g}), "
                f"|g| = {np.linalg.norm(g):.4g}")


@register
class NodeDrag(Effect):
    """Viscous drag of the surrounding medium on every node: ``F_i = -b v_i``."""

    name = "node_drag"
    unit = (0, -1, 1)
    _labels = ("b",)
    one_per_model = True

    def compile(self, layout, model, column):
        layout.add_drag(self.params[0], column)

    def force(self, model, positions, velocities):
        return -self.params[0] * velocities

    def parameter_jacobian(self, model, positions, velocities):
        return -velocities[:, None, :]

    def state_jvp(self, model, positions, velocities, dp, dv):
        return -self.params[0] * dv

    def state_vjp(self, model, positions, velocities, cotangent):
        return np.zeros_like(cotangent), -self.params[0] * cotangent

    @classmethod
    def examples(cls, model):
        return [(model, cls([2e-3]))]

    def equation(self):
        return f"node_drag: F_i += -b v_i, b = {self.params[0]:.4g}"


@register
class UnmodeledLoad(Effect):
    """A constant force ``f`` at one node that the data did not declare."""

    name = "unmodeled_load"
    unit = (1, -2, 1)
    _labels = ("fx", "fy", "fz")

    def compile(self, layout, model, column):
        """A state-independent force: added to the loads."""
        _compile_constant(self, layout, model, column)

    def __init__(self, params, *, node, **options):
        super().__init__(params, node=int(node), **options)

    def force(self, model, positions, velocities):
        force = np.zeros((model.n_nodes, 3))
        force[self.options["node"]] = self.params
        return force

    def parameter_jacobian(self, model, positions, velocities):
        jacobian = np.zeros((model.n_nodes, 3, 3))
        jacobian[self.options["node"]] = np.eye(3)
        return jacobian

    @classmethod
    def examples(cls, model):
        return [(model, cls([0.01, -0.02, 0.03], node=int(np.flatnonzero(model.mesh.free)[0])))]

    @classmethod
    def propose(cls, model, evidence):
        """A load at each of the three free nodes with the largest mean residual force."""
        ranked = np.argsort(-np.linalg.norm(evidence.mean_force, axis=1))[:3]
        return [cls(np.zeros(3), node=int(node)) for node in ranked
                if int(node) not in evidence.taken_nodes and model.mesh.free[node]]

    def equation(self):
        f = self.params
        return (f"unmodeled_load: F_{self.options['node']} += ({f[0]:.4g}, {f[1]:.4g}, "
                f"{f[2]:.4g})")


