"""Experiments whose frames are equilibria: a specimen compressed between plates (or pulled,
or sheared) by a stage moved a known amount, scanned at a few load steps, perhaps with a load
cell: the :class:`LoadSteps`.

Step 0 is the reference (the unloaded scan); at step ``s ≥ 1`` every :class:`DrivenPath` sits
at its ``displacement[s - 1]`` from rest, the mesh's fixed nodes at rest, and the markers
(embedded anywhere in the body, :class:`~neurofuzzy.observation.EmbeddedMarkers`) were scanned
where the body came to rest. A load cell, when there was one, measured the total reaction
force on one driven set at each step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import InputError, index_of
from .mesh import Mesh
from .model import Model
from .observation import EmbeddedMarkers
from .paths import (DrivenPath, Span, ToolPath, check_driven, check_reaction,
                    check_tool)
from .simulation.static import Driven, equilibrium

__all__ = ["DrivenPath", "ToolPath", "LoadSteps", "marker_paths", "simulate_load_steps",
           "tool_at"]


@dataclass(frozen=True, eq=False)
class LoadSteps:
    """Markers scanned at a few load steps of a displacement-controlled test.

    Parameters
    ----------
    mesh : Mesh
        The body, its fixed nodes (the anvil under a bonded specimen) held at rest.
    driven : tuple of DrivenPath
        What the stage moved.
    markers : EmbeddedMarkers or None
        Marker positions (n_steps + 1, n_markers, 3): step 0 the reference scan, NaN where a
        marker was not found. None for a force–displacement curve alone (then ``reaction``
        is required).
    reaction : (n_steps, 3) float, optional
        The load cell's reading at each step: the total force the first driven set exerts on
        the body (N), or the tool's when there is one.
    truth : dict
        Ground truth of synthetic data: reported, never read by a fitter.
    source : str
        Where the data came from, for messages.
    tool : ToolPath, optional
        A rigid tool pressed into the body (then ``driven`` may be empty: the sets that hold
        the body, such as symmetry planes).
    """

    mesh: Mesh
    driven: tuple
    markers: EmbeddedMarkers
    reaction: np.ndarray | None = None
    truth: dict = field(default_factory=dict)
    source: str = "<load steps>"
    tool: ToolPath | None = None

    def __post_init__(self):
        src = self.source
        if self.markers is None:
            if self.reaction is None:
                raise InputError("needs markers, a load cell's force, or both: with neither "
                                 "there is nothing to fit", source=src, key="markers")
            n_steps = (np.shape(self.reaction) or (0,))[0]
        elif not isinstance(self.markers, EmbeddedMarkers):
            raise InputError("markers must be EmbeddedMarkers", source=src, key="markers")
        else:
            n_steps = self.markers.positions.shape[0] - 1
        if n_steps < 1:
            raise InputError("needs the reference scan and at least one load step",
                             source=src, key="markers")
        span = Span(n_steps, n_steps + 1, "load step",
                    f"the scans have {n_steps} load steps, so",
                    f"at the reference scan and at each of the {n_steps} load steps")
        driven = check_driven(self.mesh, self.driven, span, src)
        if not driven and self.tool is None:
            raise InputError("needs at least one DrivenPath or a ToolPath (what moved the "
                             "body)", source=src, key="driven")
        if self.tool is not None:
            check_tool(self.mesh, self.tool, span, src)
        if self.markers is not None:
            self._check_markers(src)
        if self.reaction is not None:
            check_reaction(self.reaction, span, src)
        object.__setattr__(self, "driven", driven)

    def _check_markers(self, src):
        try:
            self.markers.operator(self.mesh.n_nodes)
        except InputError as error:
            raise InputError(error.detail, source=src, key=error.key) from None
        if not np.isfinite(self.markers.positions[0]).all():
            raise InputError("every marker needs a position in the reference scan (step 0)",
                             source=src, key="marker_positions")

    @property
    def n_steps(self) -> int:
        """Load steps after the reference scan."""
        return (np.shape(self.reaction)[0] if self.markers is None
                else self.markers.positions.shape[0] - 1)

    def boundary(self, step: int) -> list[Driven]:
        """Every driven set at step ``step``."""
        return [path.at(step) for path in self.driven]

    def drive_markers(self, markers, *, replace: bool = False) -> LoadSteps:
        """Measured boundary data: the node under each of ``markers`` (names or indices; the
        corner of its tetrahedron it sits nearest to) driven along that marker's measured
        path (its scan at each step minus the reference scan), the marker no longer fitted
        (:func:`marker_paths`).

        For a boundary whose motion a lab saw but did not prescribe (a plate that tilted, a
        clamp that slipped, tissue held by hand). ``replace=True`` drops the driven sets
        there were (the markers are the whole boundary); a load cell, which reads the first
        of them, cannot be kept then.
        """
        if replace and self.reaction is not None:
            raise InputError("the load cell reads the driven set the markers would replace: "
                             "drop the load cell or keep the driven sets",
                             source=self.source, key="reaction")
        paths, rest = marker_paths(self.markers, markers, source=self.source,
                                   taken=() if replace else self.driven)
        return LoadSteps(self.mesh, paths if replace else self.driven + paths, rest,
                         self.reaction, self.truth, self.source, self.tool)


def simulate_load_steps(model: Model, driven, markers: EmbeddedMarkers, *,
                        load_cell: bool = True, marker_noise: float = 0.0,
                        force_noise: float = 0.0, increments: int = 2,
                        seed: int = 0, tool: ToolPath | None = None) -> LoadSteps:
    """Synthetic :class:`LoadSteps` of ``model``: the equilibria at each step of ``driven``
    (DrivenPaths) and ``tool``, the markers' positions there (``markers.positions`` gives only
    the number of scans; their weights place them), with Gaussian noise of ``marker_noise``
    (m) and, with ``load_cell``, the first driven set's reaction (the tool's force, with a
    tool) with noise of ``force_noise`` (N)."""
    driven = tuple(driven)
    n_steps = markers.positions.shape[0] - 1
    touch = None if tool is None else tool.contact(model)
    H = markers.operator(model.n_nodes)
    rng = np.random.default_rng(seed)
    scans = [H @ model.mesh.rest_positions]
    forces = []
    positions = None
    for step in range(1, n_steps + 1):
        result = equilibrium(model, driven=[path.at(step) for path in driven],
                             start=positions, increments=increments,
                             **tool_at(tool, touch, step))
        positions = result.positions
        scans.append(H @ positions)
        forces.append(result.contact_force if tool is not None
                      else result.reaction_on(driven[0].nodes))
    scans = np.array(scans)
    scans[1:] += rng.normal(scale=marker_noise, size=scans[1:].shape) if marker_noise else 0.0
    reaction = np.array(forces)
    if force_noise:
        reaction = reaction + rng.normal(scale=force_noise, size=reaction.shape)
    elements = model.elements
    truth = {} if elements is None else {
        "true_youngs_modulus": np.asarray(elements.youngs_modulus),
        "true_poisson_ratio": np.asarray(elements.poisson_ratio)}
    return LoadSteps(model.mesh, driven,
                     EmbeddedMarkers(markers.nodes, markers.weights, scans, markers.names),
                     reaction if load_cell else None, truth, "<simulated load steps>", tool)


def tool_at(tool: ToolPath | None, contact, step: int) -> dict:
    """:func:`~neurofuzzy.simulation.static.equilibrium`'s ``contact`` and ``tool_start``
    keywords at load step ``step`` (none without a tool): the tool moved from its place at
    the step before."""
    if tool is None:
        return {}
    positions = np.asarray(tool.positions, float)
    return {"contact": contact.at(positions[step], tool.tool_at(step)),
            "tool_start": positions[step - 1]}


def marker_paths(markers: EmbeddedMarkers | None, chosen, *, source: str = "<load steps>",
                 taken=()) -> tuple[tuple, EmbeddedMarkers | None]:
    """``(paths, the other markers)``: a :class:`DrivenPath` for the node under each chosen
    marker (:meth:`LoadSteps.drive_markers`), none of them a node of the ``taken`` paths."""
    if markers is None:
        raise InputError("has no markers to drive nodes with", source=source, key="markers")
    names = list(markers.names) or [str(i) for i in range(len(markers.nodes))]
    index = []
    for item in chosen:
        index.append(index_of(item, names))
        if index[-1] is None:
            raise InputError(f"no marker {item!r} (markers: {', '.join(names[:8])}"
                             f"{' …' if len(names) > 8 else ''})", source=source,
                             key="markers")
    if not index:
        raise InputError("name at least one marker to drive", source=source, key="markers")
    positions = markers.positions
    if not np.isfinite(positions[:, index]).all():
        raise InputError("a marker that drives its node must be seen in every scan",
                         source=source, key="markers")
    nodes = np.asarray(markers.nodes)[index, np.argmax(np.asarray(markers.weights)[index],
                                                       axis=1)]
    held = {int(n) for path in taken for n in path.nodes}
    if held & set(nodes.tolist()):
        raise InputError(f"marker {names[index[0]]!r}'s node is driven already (by "
                         f"{taken[0].name!r}): drive the markers instead of that set "
                         "(replace=True) or choose markers elsewhere", source=source,
                         key="markers")
    if len(set(nodes.tolist())) < len(nodes):
        raise InputError("two of these markers sit nearest the same node; drive one of them",
                         source=source, key="markers")
    paths = tuple(DrivenPath(np.array([node]), positions[1:, i] - positions[0, i], "xyz",
                             f"marker {names[i]}") for node, i in zip(nodes, index))
    keep = np.setdiff1d(np.arange(len(names)), index)
    rest = None if not keep.size else EmbeddedMarkers(
        np.asarray(markers.nodes)[keep], np.asarray(markers.weights)[keep],
        positions[:, keep], tuple(names[i] for i in keep) if markers.names else ())
    return paths, rest
