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
from .simulation.static import Driven, equilibrium

__all__ = ["DrivenPath", "ToolPath", "LoadSteps", "marker_paths", "simulate_load_steps",
           "tool_at"]


@dataclass(frozen=True, eq=False)
class DrivenPath:
    """A set of nodes moved by a known displacement at each load step.

    Parameters
    ----------
    nodes : (n,) int
        The driven nodes (a plate's face).
    displacement : (n_steps, 3) float
        Their displacement from rest at steps 1..n_steps (m).
    components : str
        The components the driver holds: ``"xyz"`` a bonded plate, the normal alone (e.g.
        ``"z"``) a frictionless one.
    name : str
        How reports call it ("top plate").
    """

    nodes: np.ndarray
    displacement: np.ndarray
    components: str = "xyz"
    name: str = "plate"

    def at(self, step: int) -> Driven:
        """The driven set at step ``step`` (1-based; 0 is rest)."""
        shift = np.zeros(3) if step == 0 else np.asarray(self.displacement, float)[step - 1]
        return Driven(np.asarray(self.nodes), shift, self.components)


@dataclass(frozen=True, eq=False)
class ToolPath:
    """A rigid tool pressed into the body at each load step (an indenter on a stage).

    Parameters
    ----------
    tool : Sphere, FlatPunch or SurfaceTool
        (:mod:`neurofuzzy.simulation.contact`).
    positions : (n_steps + 1, 3) float
        The tool's reference point (a sphere's centre, a punch's face centre) at the
        reference scan (step 0: touching the surface or clear of it) and at each load step
        (m).
    stiffness : float or "auto"
        The contact penalty (Pa/m; :func:`~neurofuzzy.simulation.contact.contact_with`) at
        the start model's Young's modulus; a fit scales it with E, so that without a load
        cell the markers cannot tell E through the penalty's give.
    name : str
    orientations : (n_steps + 1, 4) float, optional
        The tool's attitude at each step, unit quaternions ``(w, x, y, z)`` turning the
        tool's own frame (a punch's axis as given) into the world's, as a tracker reports
        it; None: never turned. A sphere looks the same every way; a punch's face tilts.
        Within a step's increments the tool keeps the step's attitude.
    """

    tool: object
    positions: np.ndarray
    stiffness: float | str = "auto"
    name: str = "indenter"
    orientations: np.ndarray | None = None

    def tool_at(self, step: int):
        """The tool as it is turned at step ``step`` (0 the reference)."""
        if self.orientations is None:
            return self.tool
        from scipy.spatial.transform import Rotation

        turn = Rotation.from_quat(np.asarray(self.orientations, float)[step],
                                  scalar_first=True)
        return self.tool.turned(turn.as_matrix())

    def check_clear(self, rest: np.ndarray, source: str | None = None) -> None:
        """An :class:`InputError` when the tool at its first position (and attitude) lies
        inside the body whose nodes are at ``rest``."""
        gap = self.tool_at(0).gap(rest, np.asarray(self.positions, float)[0])[0]
        if np.any(gap < -1e-9 * float(np.ptp(rest, axis=0).max())):
            raise InputError(f"the tool {self.name!r} starts inside the body (node "
                             f"{int(np.argmin(gap))} lies {-1e3 * float(gap.min()):.3g} mm "
                             "inside it at the start): place it on the surface or clear of it",
                             source=source, key="tool")

    def contact(self, model: Model):
        """The tool's :class:`~neurofuzzy.simulation.contact.Contact` with ``model`` (at
        step 0)."""
        from .simulation.contact import contact_with

        return contact_with(model, self.tool_at(0), np.asarray(self.positions, float)[0],
                            stiffness=self.stiffness)


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
        driven = tuple(self.driven)
        if (not driven and self.tool is None) or not all(isinstance(d, DrivenPath)
                                                         for d in driven):
            raise InputError("needs at least one DrivenPath or a ToolPath (what moved the "
                             "body)", source=src, key="driven")
        if self.tool is not None:
            self._check_tool(n_steps, src)
        fixed = set(np.asarray(self.mesh.fixed).tolist())
        for path in driven:
            if np.asarray(path.displacement).dtype.kind not in "iuf":
                raise InputError(f"the driven set {path.name!r} has displacements that are not "
                                 "numbers", source=src, key="driven")
            shape = np.shape(path.displacement)
            if shape != (n_steps, 3):
                raise InputError(f"the driven set {path.name!r} has displacements of shape "
                                 f"{shape}; the scans have {n_steps} load steps, so expected "
                                 f"({n_steps}, 3)", source=src, key="driven")
            nodes = np.asarray(path.nodes)
            if nodes.size == 0:
                raise InputError(f"the driven set {path.name!r} is empty", source=src,
                                 key="driven")
            overlap = fixed.intersection(nodes.tolist())
            if overlap:
                raise InputError(f"the driven set {path.name!r} overlaps the fixed nodes "
                                 f"({len(overlap)} nodes, e.g. {min(overlap)}): a node is "
                                 "held by one boundary", source=src, key="driven")
            try:
                path.at(1).dofs(self.mesh.n_nodes)
            except InputError as error:
                raise InputError(error.detail, source=src, key=error.key) from None
        if self.markers is not None:
            self._check_markers(src)
        if self.reaction is not None:
            try:
                reaction = np.asarray(self.reaction, float)
            except (TypeError, ValueError):
                raise InputError("the load cell's reading must be numbers (N)", source=src,
                                 key="reaction") from None
            if reaction.shape != (n_steps, 3) or not np.all(np.isfinite(reaction)):
                raise InputError(f"the load cell's reading must be finite of shape "
                                 f"({n_steps}, 3) (one force per load step); got "
                                 f"{reaction.shape}", source=src, key="reaction")
        object.__setattr__(self, "driven", driven)

    def _check_tool(self, n_steps, src):
        from .simulation.contact import TOOLS

        tool = self.tool
        if not isinstance(tool, ToolPath) or not isinstance(tool.tool, TOOLS):
            raise InputError("tool must be a ToolPath of a Sphere, a FlatPunch or a "
                             "SurfaceTool", source=src, key="tool")
        positions = np.asarray(tool.positions, float)
        if positions.shape != (n_steps + 1, 3) or not np.all(np.isfinite(positions)):
            raise InputError(f"the tool {tool.name!r} needs a finite position at the reference "
                             f"scan and at each of the {n_steps} load steps, shape "
                             f"({n_steps + 1}, 3); got {positions.shape}", source=src,
                             key="tool")
        if tool.orientations is not None:
            turns = np.asarray(tool.orientations, float)
            if turns.shape != (n_steps + 1, 4) or not np.all(np.isfinite(turns)):
                raise InputError(f"the tool {tool.name!r} needs a finite attitude (qw, qx, qy, "
                                 f"qz) at each position, shape ({n_steps + 1}, 4); got "
                                 f"{turns.shape}", source=src, key="tool")
            size = np.linalg.norm(turns, axis=1)
            if np.any(np.abs(size - 1) > 1e-3):
                raise InputError(f"the tool {tool.name!r} has an attitude quaternion of length "
                                 f"{size[np.argmax(np.abs(size - 1))]:.4g} at step "
                                 f"{int(np.argmax(np.abs(size - 1)))}: unit quaternions "
                                 "(w, x, y, z) only", source=src, key="tool")
        tool.check_clear(self.mesh.rest_positions, src)
        largest = np.linalg.norm(np.diff(positions, axis=0), axis=1).max()
        if largest > tool.tool.radius:
            raise InputError(f"the tool {tool.name!r} jumps {1e3 * largest:.3g} mm between "
                             f"two steps, more than its radius ({1e3 * tool.tool.radius:.3g} "
                             "mm): give the steps in between", source=src, key="tool")

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
