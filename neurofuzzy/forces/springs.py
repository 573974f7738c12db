"""The springs' term (:class:`Springs`: the constants of every spring of a model's mesh) and the
spring force (paper eqs. 3.4–3.6) with its derivatives: the one implementation every part of
the package goes through (the compiled kernel in :mod:`neurofuzzy.kernels.stepper` is tested
equal to it).

Spring ``j`` between nodes ``a`` and ``b``::

    d = p_b - p_a,  l = |d|,  u = d / l,  closing speed c = (v_b - v_a) · u
    f_j = m_j u,  m_j = s_j (l - L0_j) + c_j c            node a gets +f_j, node b gets -f_j

Every force here is *central*: a magnitude ``m(l, c)`` along ``u``;
:mod:`neurofuzzy.forces.central` gives the exact forward and reverse derivatives of
``f = m u`` for any such magnitude, given ``m``, ``∂m/∂l`` and ``∂m/∂c``.

The geometry is computed component-major (arrays of shape (3, n_springs)), the layout in which
the stepper's hot loop is fastest; :class:`SpringState` offers the node-major views the
derivatives use.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .assembly import Incidence, incidence
from .base import MemberTerm, region_index, vector
from .central import central_jvp, central_vjp, projected_laplacian

__all__ = ["SpringState", "Springs", "spring_state", "spring_constants", "parameter_templates",
           "spring_law"]


@dataclass(frozen=True)
class SpringState:
    """Per-spring geometry of one state (eqs. 3.5, 3.6).

    Attributes
    ----------
    difference : (3, n_springs) float
        ``d = p_b - p_a``, component-major.
    relative_velocity_components : (3, n_springs) float
        ``v_b - v_a``, component-major.
    length : (n_springs,) float
        ``l = |d|``.
    stretch : (n_springs,) float
        ``l - L0``.
    closing_speed : (n_springs,) float
        ``(v_b - v_a) · u`` (positive when the spring lengthens).
    """

    difference: np.ndarray
    relative_velocity_components: np.ndarray
    length: np.ndarray
    stretch: np.ndarray
    closing_speed: np.ndarray

    @property
    def direction(self) -> np.ndarray:
        """(n_springs, 3) unit vector ``u`` from node a to node b."""
        return (self.difference / self.length).T

    @property
    def relative_velocity(self) -> np.ndarray:
        """(n_springs, 3) ``v_b - v_a``."""
        return self.relative_velocity_components.T

    def select(self, springs: np.ndarray) -> SpringState:
        """The state of a subset of springs."""
        return SpringState(self.difference[:, springs],
                           self.relative_velocity_components[:, springs],
                           self.length[springs], self.stretch[springs],
                           self.closing_speed[springs])


@dataclass(frozen=True, eq=False)
class Springs(MemberTerm):
    """The springs of a model: per spring of its mesh the stiffness ``s`` (N/m), the damping
    ``c`` (N·s/m), the rest length ``L0`` (m), the tie group and the region.

    A term of :class:`~neurofuzzy.model.Model` (``model.springs``); its topology is the
    model's ``mesh.springs``. Give the values as numbers (every spring) or (n_springs,)
    arrays; the model checks them against its mesh (:meth:`bound`) and keeps read-only
    (n_springs,) arrays.

    Parameters
    ----------
    stiffness, damping : float or (n_springs,) float
        ``s ≥ 0`` and ``c ≥ 0`` of every spring.
    rest_length : (n_springs,) float, optional
        ``L0 > 0`` (default: the mesh's rest lengths).
    tie : (n_springs,) int, optional
        Tie group of every spring (default one group per spring); springs of one group are
        learned by one common factor (:meth:`~neurofuzzy.model.Model.tied`).
    region : (n_springs,) int, optional
        The model region of every spring (default 0).
    """

    stiffness: np.ndarray
    damping: np.ndarray
    rest_length: np.ndarray | None = None
    tie: np.ndarray | None = None
    region: np.ndarray | None = None

    name = "springs"
    #: parameter names and units per spring
    parameters = {"stiffness": "N/m", "damping": "N s/m"}

    def bound(self, model) -> Springs:
        """This term checked against ``model``'s mesh and regions, as read-only (n_springs,)
        arrays with the defaults filled in.

        Raises
        ------
        InputError
            A value of the wrong shape, NaN, negative (or a rest length not positive), a tie
            group that is not an integer, a region outside the model's; the key names the
            model field (``spring_stiffness`` …).
        """
        if self._bound_to(model):
            return self
        mesh = model.mesh
        n = mesh.n_springs
        values = {"stiffness": vector(self.stiffness, n, "spring_stiffness", "n_springs"),
                  "damping": vector(self.damping, n, "spring_damping", "n_springs"),
                  "rest_length": (mesh.rest_lengths if self.rest_length is None else
                                  vector(self.rest_length, n, "spring_rest_length", "n_springs"))}
        if np.any(values["rest_length"] <= 0):
            raise InputError("must be positive", key="spring_rest_length")
        for name in ("stiffness", "damping"):
            if np.any(values[name] < 0):
                raise InputError("must not be negative", key=f"spring_{name}")
        if self.tie is None:
            tie = np.arange(n, dtype=np.intp)
        else:
            tie = np.asarray(self.tie)
            if tie.shape != (n,) or not np.issubdtype(tie.dtype, np.integer):
                raise InputError(f"got {tie.dtype} of shape {tie.shape}; expected int of shape "
                                 f"({n},)", key="spring_tie")
            tie = np.unique(tie, return_inverse=True)[1].astype(np.intp)  # 0..n_ties-1
        values["tie"] = tie
        values["region"] = region_index(self.region, n, len(model.region_names),
                                        "spring_region", "n_springs")
        for value in values.values():
            value.setflags(write=False)
        return replace(self, **values)._checked(model)

    def blocks(self, model, *, index: int = 0):
        """``log_stiffness`` and ``log_damping`` of every tie group
        (:class:`~neurofuzzy.forces.blocks.SpringBlocks`)."""
        from .blocks import SpringBlocks

        return SpringBlocks(self, model.mesh)

    # -- geometry and force -------------------------------------------------------------
    def state(self, model, positions: np.ndarray, velocities: np.ndarray,
              incidence_: Incidence | None = None) -> SpringState:
        """:class:`SpringState` at node-major ``(positions, velocities)`` (n_nodes, 3)."""
        return self.state_components(model, positions.T, velocities.T, incidence_)

    def state_components(self, model, positions_t: np.ndarray, velocities_t: np.ndarray,
                         incidence_: Incidence | None = None,
                         rest_length: np.ndarray | None = None) -> SpringState:
        """:class:`SpringState` at component-major ``(positions, velocities)`` (3, n_nodes)."""
        return spring_state_components(model.mesh, positions_t, velocities_t,
                                       self.rest_length if rest_length is None else rest_length,
                                       incidence_)

    def magnitude(self, model, state: SpringState, stiffness=None, damping=None) -> np.ndarray:
        """(n_springs,) ``m = s (l - L0) + c (v_b - v_a)·u`` (eq. 3.4), the compiled
        :func:`neurofuzzy.kernels.springs.magnitude` over arrays."""
        s = self.stiffness if stiffness is None else stiffness
        c = self.damping if damping is None else damping
        return spring_law().values(state.stretch, state.closing_speed, stiffness=s, damping=c)

    def magnitude_and_slope(self, model, state: SpringState, stiffness=None, damping=None):
        """``(m, ∂m/∂l)``, each (n_springs,), with the model's constants or ``stiffness`` /
        ``damping`` (n_springs,) instead."""
        s = self.stiffness if stiffness is None else stiffness
        c = self.damping if damping is None else damping
        return spring_law().magnitudes(state.stretch, state.closing_speed, stiffness=s,
                                       damping=c)

    def force(self, model, positions, velocities):
        """(n_nodes, 3) net spring force on every node (eq. 3.4 summed as in eq. 3.3)."""
        return self.force_components(model, positions.T, velocities.T).T

    def force_components(self, model, positions_t, velocities_t, *, incidence_=None,
                         coefficients=None) -> np.ndarray:
        """(3, n_nodes) net spring force from component-major states (3, n_nodes).

        ``coefficients`` = ``(stiffness, damping, rest_length)`` overrides the model's (the
        stepper passes them cast to its dtype once).
        """
        maps = incidence(model.mesh) if incidence_ is None else incidence_
        s, c, rest = (None, None, None) if coefficients is None else coefficients
        state = self.state_components(model, positions_t, velocities_t, maps, rest)
        return self._net_components(model, state, maps, s, c)

    def force_of_state(self, model, state: SpringState, stiffness=None,
                       damping=None) -> np.ndarray:
        """(n_nodes, 3) net spring force of an already computed :class:`SpringState` (with
        the model's constants, or ``stiffness`` / ``damping`` (n_springs,) instead)."""
        return self._net_components(model, state, incidence(model.mesh), stiffness, damping).T

    def _net_components(self, model, state, maps, stiffness=None, damping=None):
        along = self.magnitude(model, state, stiffness, damping) / state.length
        return maps.accumulate_components(state.difference * along)

    # -- derivatives ----------------------------------------------------------------------
    def parameter_templates(self, state: SpringState) -> dict[str, np.ndarray]:
        """Per-spring force per unit of each per-spring parameter
        (:func:`parameter_templates`)."""
        return parameter_templates(state)

    def state_jvp(self, model, positions, velocities, dp, dv, state=None):
        maps = incidence(model.mesh)
        state = self.state(model, positions, velocities) if state is None else state
        # ∂m/∂c is the damping (m is linear in the closing speed)
        df = central_jvp(state, *self.magnitude_and_slope(model, state), self.damping,
                         maps.difference(dp), maps.difference(dv))
        return maps.accumulate(df)

    def state_vjp(self, model, positions, velocities, cotangent, state=None):
        bar_p, bar_v, _ = self.vjp(model, cotangent, self.state(model, positions, velocities)
                                   if state is None else state)
        return bar_p, bar_v

    def vjp(self, model, cotangent: np.ndarray, state: SpringState):
        """Reverse derivative of the net spring force for a cotangent ``λ`` (n_nodes, 3).

        Returns ``(λ_p, λ_v, {"stiffness": (n_springs,), "damping": (n_springs,)})``: the
        pull-backs to positions and velocities and ``λ · ∂F/∂s_j``, ``λ · ∂F/∂c_j``.
        """
        law, maps = spring_law(), incidence(model.mesh)
        bar_f = -maps.difference(cotangent)                 # λ_a - λ_b per spring
        bar_d, bar_dv = central_vjp(state, *self.magnitude_and_slope(model, state),
                                    self.damping, bar_f)
        # d = p_b - p_a: node b gets +λ_d, node a gets -λ_d
        along = np.einsum("ij,ij->i", state.direction, bar_f)
        return (-maps.accumulate(bar_d), -maps.accumulate(bar_dv),
                {"stiffness": law.partials(law.STRETCH, state.stretch) * along,
                 "damping": law.partials(law.CLOSING, state.stretch, state.closing_speed)
                 * along})

    # -- the springs' own parameters -------------------------------------------------------
    def parameter_values(self, model):
        """``{"stiffness": s, "damping": c}``, each (n_springs,)."""
        return {"stiffness": self.stiffness, "damping": self.damping}

    def with_parameter_values(self, model, values):
        springs = self.replace(stiffness=values["stiffness"], damping=values["damping"])
        model = model.with_term(springs)
        return model, model.springs

    def parameter_jvp(self, model, positions, velocities, directions):
        """(n_nodes, P, 3): ``Σ_j (ds_j (l - L0) + dc_j closing) u`` at both ends (node a +,
        node b -) for per-spring directions ``directions["stiffness"]``, ``["damping"]``
        (n_springs, P)."""
        templates = self.parameter_templates(self.state(model, positions, velocities))
        per_spring = sum(np.asarray(directions[name].todense() if sp.issparse(directions[name])
                                    else directions[name])[:, :, None]
                         * templates[name][:, None, :] for name in templates)
        return incidence(model.mesh).accumulate(per_spring)

    def parameter_vjp(self, model, positions, velocities, cotangent):
        return self.vjp(model, cotangent, self.state(model, positions, velocities))[2]

    @classmethod
    def examples(cls, model):
        """The model's own springs, when they pull (spring networks)."""
        springs = model.springs
        return [(model, springs)] if springs is not None and np.any(springs.stiffness) else []

    def rest_matrices(self, model):
        """``Σ_j k_j (e_a - e_b)(e_a - e_b)ᵀ ⊗ u_j u_jᵀ`` at rest for ``k = s`` and ``k = c``."""
        mesh = model.mesh
        direction = mesh.rest_positions[mesh.springs[:, 1]] - mesh.rest_positions[
            mesh.springs[:, 0]]
        direction /= np.linalg.norm(direction, axis=1)[:, None]
        return tuple(projected_laplacian(mesh.springs, direction, constants, model.n_nodes)
                     for constants in (self.stiffness, self.damping))


def parameter_templates(state: SpringState) -> dict[str, np.ndarray]:
    """Per-spring force (on node a) per unit of each per-spring parameter.

    Returns ``{"stiffness": (l - L0) u, "damping": ((v_b - v_a)·u) u}``, each (n_springs, 3);
    node a gets ``+``, node b ``-`` (:meth:`Incidence.accumulate`).
    """
    law, u = spring_law(), state.direction
    return {"stiffness": law.partials(law.STRETCH, state.stretch)[:, None] * u,
            "damping": law.partials(law.CLOSING, state.stretch,
                                    state.closing_speed)[:, None] * u}


def spring_constants(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(stiffness, damping, rest_length)``, each (n_springs,), of every spring of ``model``'s
    mesh: its springs' values, or none (zero stiffness and damping, the mesh's rest lengths)
    for a model without springs, whose mesh springs the spring effects and the exports may
    still use."""
    springs = model.springs
    if springs is not None:
        return springs.stiffness, springs.damping, springs.rest_length
    none = np.zeros(model.n_springs)
    return none, none, model.mesh.rest_lengths


def spring_state(model, positions: np.ndarray, velocities: np.ndarray) -> SpringState:
    """:class:`SpringState` of every spring of ``model``'s mesh at node-major ``(positions,
    velocities)`` (n_nodes, 3), from the springs' rest lengths (the mesh's for a model without
    springs: the spring effects act along the mesh's springs of an element model too)."""
    return spring_state_components(model.mesh, positions.T, velocities.T,
                                   spring_constants(model)[2])


def spring_state_components(mesh, positions_t: np.ndarray, velocities_t: np.ndarray,
                            rest_length: np.ndarray,
                            incidence_: Incidence | None = None) -> SpringState:
    """:class:`SpringState` of ``mesh``'s springs at component-major ``(positions,
    velocities)`` (3, n_nodes) for rest lengths ``rest_length`` (n_springs,)."""
    maps = incidence(mesh) if incidence_ is None else incidence_
    d = maps.difference_components(positions_t)
    dv = maps.difference_components(velocities_t)
    length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    closing = (dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2]) / length
    return SpringState(d, dv, length, length - rest_length, closing)


@functools.cache
def spring_law():
    """:mod:`neurofuzzy.kernels.springs`, the spring's force law, imported on first use
    (numba loads when a force is evaluated, not when the package is imported; an import
    statement in every call would cost the paper learner's 86-spring steps a few per cent)."""
    from ..kernels import springs

    return springs
