"""What moves the body in an implicit run (:func:`~neurofuzzy.simulation.simulate_implicit`):
node sets driven along a path in time (a plate on a stage, issue 45's dynamic ramp) and a
rigid tool pressed along its path (an indenter or a tracked instrument, issue 46's tool in
time).

Both reuse the load steps' descriptions with one row per recorded frame instead of per load
step: a :class:`~neurofuzzy.load_steps.DrivenPath` whose ``displacement`` is (n_frames, 3),
the set's displacement from rest at each frame, and a :class:`~neurofuzzy.load_steps.ToolPath`
whose ``positions`` (and ``orientations``) are (n_frames, 3) (and (n_frames, 4)). Between two
frames a path is followed linearly, substep by substep: exact for a stage moved at constant
speed between frames (a ramp and hold), but for a smooth path the driven nodes' velocity at
a frame is then the last frame's mean, half a frame late. With substeps the reaction reads
that lag: on :mod:`neurofuzzy.validation.plate_ramp`'s smooth ramp (4 cells, frames 1 ms
apart) 2 steps a frame read the plate's force up to 7 % of its peak off a run on the path
sampled at every step, where one step a frame is within 0.3 %. A cubic spline through the
frames fixes that (PCHIP and Akima's cubic in part), but rounds the stop of a ramp and hold:
fitted to such a recording (``tests/test_moving_cli.py``, frames 2 ms apart, 2 steps each)
the force curve then missed by 8 to 10× its noise. So give a smooth path at the rate the
steps are taken, or take one step a frame.

A driven degree of freedom is not solved for: each implicit step gives it the velocity that
puts it where its path is at the step's end, and the step solves for the others. What the
driver exerts on the set is the set's share of the step's equation, ``M (v₁ - v₀) / h - F -
f``, summed over its nodes (:attr:`~neurofuzzy.simulation.Trajectory.reactions`: inertia
included, as a load cell on a moving stage reads it). The tool is the static solve's penalty
contact (:mod:`.contact`), its force in every Newton iteration's residual and its stiffness in
the step's matrix; :attr:`~neurofuzzy.simulation.Trajectory.tool_forces` is the force it
exerts on the body at each frame.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["Moving"]


class Moving:
    """The driven sets and the tool of an implicit run of ``model`` over ``n_frames`` frames
    (module docstring): ``driven`` DrivenPaths and ``tool`` a ToolPath (known by what they
    hold: :mod:`neurofuzzy.load_steps` builds on this package, not the reverse)."""

    def __init__(self, model, n_frames: int, driven=(), tool=None):
        n = model.n_nodes
        self.driven = tuple(driven)
        self.held = np.zeros(3 * n, bool)
        self._dofs = []                            # each driven set's held degrees of freedom
        fixed = set(np.asarray(model.mesh.fixed).tolist())
        for path in self.driven:
            if not all(hasattr(path, a) for a in ("nodes", "displacement", "at")):
                raise InputError(f"got {type(path).__name__}; driven sets are DrivenPaths",
                                 key="driven")
            shape = np.shape(path.displacement)
            if shape != (n_frames, 3) or not np.all(np.isfinite(path.displacement)):
                raise InputError(f"the driven set {path.name!r} has displacements of shape "
                                 f"{shape}; a run of {n_frames} frames needs one finite row "
                                 f"per frame, ({n_frames}, 3)", key="driven")
            nodes = np.asarray(path.nodes)
            if nodes.size == 0 or fixed.intersection(nodes.tolist()):
                raise InputError(f"the driven set {path.name!r} is empty or overlaps the fixed "
                                 "nodes: a node is held by one boundary", key="driven")
            dofs = path.at(1).dofs(n)[0]
            if self.held[dofs].any():
                raise InputError(f"the driven set {path.name!r} holds a degree of freedom "
                                 "another driven set holds", key="driven")
            self.held[dofs] = True
            self._dofs.append(dofs)
        self.tool, self.contact = tool, None
        if tool is not None:
            if not all(hasattr(tool, a) for a in ("positions", "contact", "tool_at")):
                raise InputError(f"got {type(tool).__name__}; a tool is a ToolPath",
                                 key="tool")
            positions = np.asarray(tool.positions, float)
            turns = tool.orientations
            if positions.shape != (n_frames, 3) or not np.all(np.isfinite(positions)) or (
                    turns is not None and np.shape(turns) != (n_frames, 4)):
                raise InputError(f"the tool {tool.name!r} needs a finite position (and, if "
                                 f"any, attitude) at each of the {n_frames} frames; got "
                                 f"{positions.shape}", key="tool")
            tool.check_clear(model.mesh.rest_positions)
            self.contact = tool.contact(model)

    def start(self, rest: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """``positions`` (n_nodes, 3) with the driven sets where their paths are at frame 0."""
        out = positions.reshape(-1).copy()
        if self.driven:
            dofs, values = self.targets(0, 0.0, rest)
            out[dofs] = values
        return out.reshape(-1, 3)

    def targets(self, frame: int, fraction: float, rest: np.ndarray):
        """``(dofs, positions)`` of every driven degree of freedom at ``fraction`` of the way
        from frame ``frame - 1`` to ``frame``, or None without driven sets."""
        if not self.driven:
            return None
        dofs = np.concatenate(self._dofs)
        shifts = np.concatenate([_between(path.displacement, frame, fraction)[held % 3]
                                 for path, held in zip(self.driven, self._dofs)])
        return dofs, rest.reshape(-1)[dofs] + shifts

    def touch(self, frame: int, fraction: float):
        """The tool's :class:`~.contact.Contact` at ``fraction`` of the way from frame
        ``frame - 1`` to ``frame`` (the attitude of ``frame``), or None without a tool."""
        if self.tool is None:
            return None
        return self.contact.at(_between(self.tool.positions, frame, fraction),
                               self.tool.tool_at(frame))

    def reactions(self, balance: np.ndarray) -> np.ndarray | None:
        """(n_sets, 3): ``balance`` (3 n_nodes,), the step's ``M (v₁ - v₀) / h - F - f`` at
        every degree of freedom, summed over each driven set's held ones."""
        if not self.driven:
            return None
        out = np.zeros((len(self.driven), 3))
        for k, dofs in enumerate(self._dofs):
            np.add.at(out[k], dofs % 3, balance[dofs])
        return out


def _between(rows, frame: int, fraction: float) -> np.ndarray:
    """A path's row ``fraction`` of the way from frame ``frame - 1`` to ``frame`` (frame 0's
    own at frame 0)."""
    rows = np.asarray(rows, float)
    before = rows[max(frame - 1, 0)]
    return before + fraction * (rows[frame] - before)
