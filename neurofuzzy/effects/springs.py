"""Effects along springs: :class:`SpringEffect`, a central force with one coefficient per
spring group (the base of :class:`~.stiffening.NonlinearStiffening` and of the inclusions)."""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from ..forces import central_jvp, central_vjp, incidence
from ..forces.springs import spring_constants, spring_state
from .base import Effect

__all__ = ["SpringEffect"]


class SpringEffect(Effect):
    """A central, position-dependent force along a subset of springs (all when no ``springs``),
    with one coefficient per spring group (stiffness units, N/m), so that it does not depend
    on the springs' own stiffness while the learners change it.

    Options: ``groups`` (the spring-group indices that have a coefficient, in parameter order),
    ``group_names`` (for labels) and optionally ``springs``. Subclasses implement
    :meth:`shape`, the magnitude per unit coefficient and its derivative by length.
    """

    unit = (0, -2, 1)

    def __init__(self, params, *, groups, group_names=None, springs=None, **options):
        if springs is not None:
            options["springs"] = [int(j) for j in np.ravel(springs)]
        options["groups"] = [int(g) for g in np.ravel(groups)]
        if group_names is not None:
            options["group_names"] = [str(n) for n in group_names]
        super().__init__(params, **options)

    @classmethod
    def for_model(cls, model, params=None, springs=None):
        """The effect on ``springs`` (default all) of ``model``, one coefficient per group."""
        selection = np.arange(model.n_springs) if springs is None else np.asarray(springs, int)
        groups = np.unique(model.mesh.spring_group[selection])
        names = [model.mesh.group_names[g] for g in groups]
        params = np.zeros(len(groups)) if params is None else np.broadcast_to(
            np.asarray(params, float), (len(groups),))
        return cls(params, groups=groups, group_names=names, springs=springs)

    @property
    def labels(self):
        names = self.options.get("group_names") or [f"group{g}" for g in self.options["groups"]]
        return tuple(f"{self.coefficient}[{n}]" for n in names)

    coefficient: ClassVar[str] = "k"

    def selected(self, model) -> np.ndarray:
        """The indices of the springs the effect acts on (all without ``springs``)."""
        springs = self.options.get("springs")
        return np.arange(model.n_springs) if springs is None else np.asarray(springs, int)

    @abstractmethod
    def shape(self, model, state, selection):
        """``(g, dg_dl)`` per selected spring: magnitude and its length derivative per unit
        coefficient."""

    def parameter_index(self, model, selection=None) -> np.ndarray:
        """The index of each selected spring's coefficient in :attr:`params` (-1 for a
        spring of a group without one); ``selection`` defaults to the effect's springs."""
        if selection is None:
            selection = self.selected(model)
        group = model.mesh.spring_group[selection]
        index = np.minimum(np.searchsorted(self.options["groups"], group), len(self.params) - 1)
        known = np.asarray(self.options["groups"])[index] == group
        return np.where(known, index, -1)

    def learned_springs(self, model, column: int | None):
        """``(springs, columns)``: the springs with a coefficient and its column, the
        coefficients learned from ``column`` on (None when they are held)."""
        if column is None:
            return None
        selection = self.selected(model)
        index = self.parameter_index(model, selection)
        return selection[index >= 0], column + index[index >= 0]

    def per_spring(self, model) -> np.ndarray:
        """(n_springs,) every spring's coefficient (0 off the selection)."""
        selection = self.selected(model)
        index = self.parameter_index(model, selection)
        out = np.zeros(model.n_springs)
        out[selection] = np.where(index >= 0, self.params[index], 0.0)
        return out

    def magnitude(self, model, state, selection):
        """``(m, dm_dl, dm_dparams)`` of shapes (n,), (n,), (n_params, n)."""
        index = self.parameter_index(model, selection)
        known = index >= 0
        coefficient = np.where(known, self.params[index], 0.0)
        g, dg = self.shape(model, state, selection)
        dm = np.zeros((len(self.params), len(selection)))
        dm[index[known], np.flatnonzero(known)] = g[known]
        return coefficient * g, coefficient * dg, dm

    def _parts(self, model, positions, velocities):
        selection = self.selected(model)
        state = spring_state(model, positions, velocities).select(selection)
        return selection, state, self.magnitude(model, state, selection)

    def _scatter(self, model, selection, per_spring):
        """(n_nodes, ...) net of a per-selected-spring array (node a +, node b -)."""
        full = np.zeros((model.n_springs, *per_spring.shape[1:]))
        full[selection] = per_spring
        return incidence(model.mesh).accumulate(full)

    def force(self, model, positions, velocities):
        selection, state, (m, _, _) = self._parts(model, positions, velocities)
        return self._scatter(model, selection, m[:, None] * state.direction)

    def parameter_jacobian(self, model, positions, velocities):
        selection, state, (_, _, dm) = self._parts(model, positions, velocities)
        return self._scatter(model, selection,
                             dm.T[:, :, None] * state.direction[:, None, :])

    def state_jvp(self, model, positions, velocities, dp, dv):
        selection, state, (m, dm_dl, _) = self._parts(model, positions, velocities)
        dd = incidence(model.mesh).difference(dp)[selection]            # (n, P, 3)
        return self._scatter(model, selection, central_jvp(state, m, dm_dl, None, dd, None))

    def state_vjp(self, model, positions, velocities, cotangent):
        selection, state, (m, dm_dl, _) = self._parts(model, positions, velocities)
        bar_f = -incidence(model.mesh).difference(cotangent)[selection]
        bar_d, _ = central_vjp(state, m, dm_dl, None, bar_f)
        return -self._scatter(model, selection, bar_d), np.zeros_like(cotangent)

    def relative(self, model) -> dict[str, float]:
        """Each coefficient relative to the mean stiffness of its group's selected springs."""
        selection = self.selected(model)
        out = {}
        for label, group, value in zip(self.labels, self.options["groups"], self.params):
            chosen = selection[model.mesh.spring_group[selection] == group]
            out[label] = float(value / np.mean(spring_constants(model)[0][chosen]))
        return out
