"""What moves a body in a displacement-controlled test: node sets a stage drives
(:class:`DrivenPath`) and a rigid tool pressed along a path (:class:`ToolPath`), one row per
load step (:class:`~neurofuzzy.load_steps.LoadSteps`) or per frame of a recording in time
(:class:`~neurofuzzy.experiment.Experiment`), and the checks both kinds of test share: the
paths' shapes, a driven set that is empty or overlaps the fixed nodes, a tool that starts
inside the body or jumps further than its size, a load cell's reading per row.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .errors import InputError
from .mesh import Mesh
from .model import Model
from .simulation.static import Driven

__all__ = ["DrivenPath", "ToolPath", "Span", "check_driven", "check_tool", "check_reaction",
           "check_moving"]


@dataclass(frozen=True, eq=False)
class DrivenPath:
    """A set of nodes moved by a known displacement at each load step (or frame).

    Parameters
    ----------
    nodes : (n,) int
        The driven nodes (a plate's face).
    displacement : (n_steps, 3) float
        Their displacement from rest at steps 1..n_steps (m); in a recording in time
        (:class:`~neurofuzzy.experiment.Experiment`) (n_frames, 3), frame 0 included.
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
        (m); in a recording in time (n_frames, 3), one per frame.
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

    def first_rows(self, n: int) -> ToolPath:
        """The path cut to its first ``n`` positions (and attitudes)."""
        turns = None if self.orientations is None else self.orientations[:n]
        return replace(self, positions=np.asarray(self.positions)[:n], orientations=turns)

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


@dataclass(frozen=True)
class Span:
    """How many rows the paths of a test need, and how its messages say so: ``driven`` rows
    of a DrivenPath, ``tool`` of a ToolPath, ``driven`` of a load cell's reading, each one
    ``row`` ("load step", "frame"); ``expected`` and ``at_each`` finish the messages."""

    driven: int
    tool: int
    row: str
    expected: str
    at_each: str


def check_driven(mesh: Mesh, driven, span: Span, source: str) -> tuple:
    """``driven`` as a tuple of DrivenPaths of ``span.driven`` rows each, none empty or
    overlapping ``mesh``'s fixed nodes; an :class:`InputError` otherwise."""
    driven = tuple(driven)
    if not all(isinstance(d, DrivenPath) for d in driven):
        raise InputError("driven sets must be DrivenPaths", source=source, key="driven")
    fixed = set(np.asarray(mesh.fixed).tolist())
    for path in driven:
        if np.asarray(path.displacement).dtype.kind not in "iuf":
            raise InputError(f"the driven set {path.name!r} has displacements that are not "
                             "numbers", source=source, key="driven")
        shape = np.shape(path.displacement)
        if shape != (span.driven, 3):
            raise InputError(f"the driven set {path.name!r} has displacements of shape "
                             f"{shape}; {span.expected} expected ({span.driven}, 3)",
                             source=source, key="driven")
        if not np.all(np.isfinite(path.displacement)):
            raise InputError(f"the driven set {path.name!r} has displacements that are NaN "
                             "or infinite", source=source, key="driven")
        nodes = np.asarray(path.nodes)
        if nodes.size == 0:
            raise InputError(f"the driven set {path.name!r} is empty", source=source,
                             key="driven")
        overlap = fixed.intersection(nodes.tolist())
        if overlap:
            raise InputError(f"the driven set {path.name!r} overlaps the fixed nodes "
                             f"({len(overlap)} nodes, e.g. {min(overlap)}): a node is "
                             "held by one boundary", source=source, key="driven")
        try:
            path.at(1).dofs(mesh.n_nodes)
        except InputError as error:
            raise InputError(error.detail, source=source, key=error.key) from None
    return driven


def check_tool(mesh: Mesh, tool, span: Span, source: str) -> None:
    """An :class:`InputError` unless ``tool`` is a ToolPath of a known tool with a finite
    position (and unit attitude, if any) at each of ``span.tool`` rows, clear of the body at
    the first and never jumping further than its radius."""
    from .simulation.contact import TOOLS

    if not isinstance(tool, ToolPath) or not isinstance(tool.tool, TOOLS):
        raise InputError("tool must be a ToolPath of a Sphere, a FlatPunch or a "
                         "SurfaceTool", source=source, key="tool")
    positions = np.asarray(tool.positions, float)
    if positions.shape != (span.tool, 3) or not np.all(np.isfinite(positions)):
        raise InputError(f"the tool {tool.name!r} needs a finite position {span.at_each}, "
                         f"shape ({span.tool}, 3); got {positions.shape}", source=source,
                         key="tool")
    if tool.orientations is not None:
        turns = np.asarray(tool.orientations, float)
        if turns.shape != (span.tool, 4) or not np.all(np.isfinite(turns)):
            raise InputError(f"the tool {tool.name!r} needs a finite attitude (qw, qx, qy, "
                             f"qz) at each position, shape ({span.tool}, 4); got "
                             f"{turns.shape}", source=source, key="tool")
        size = np.linalg.norm(turns, axis=1)
        if np.any(np.abs(size - 1) > 1e-3):
            raise InputError(f"the tool {tool.name!r} has an attitude quaternion of length "
                             f"{size[np.argmax(np.abs(size - 1))]:.4g} at {span.row} "
                             f"{int(np.argmax(np.abs(size - 1)))}: unit quaternions "
                             "(w, x, y, z) only", source=source, key="tool")
    tool.check_clear(mesh.rest_positions, source)
    largest = np.linalg.norm(np.diff(positions, axis=0), axis=1).max(initial=0.0)
    if largest > tool.tool.radius:
        raise InputError(f"the tool {tool.name!r} jumps {1e3 * largest:.3g} mm between "
                         f"two {span.row}s, more than its radius "
                         f"({1e3 * tool.tool.radius:.3g} mm): give the {span.row}s in "
                         "between", source=source, key="tool")


def check_reaction(reaction, span: Span, source: str) -> np.ndarray:
    """A load cell's reading as a finite (``span.driven``, 3) float array, or an
    :class:`InputError`."""
    try:
        reaction = np.asarray(reaction, float)
    except (TypeError, ValueError):
        raise InputError("the load cell's reading must be numbers (N)", source=source,
                         key="reaction") from None
    if reaction.shape != (span.driven, 3) or not np.all(np.isfinite(reaction)):
        raise InputError(f"the load cell's reading must be finite of shape "
                         f"({span.driven}, 3) (one force per {span.row}); got "
                         f"{reaction.shape}", source=source, key="reaction")
    return reaction


def check_moving(mesh: Mesh, driven, tool, reaction, n_frames: int,
                 source: str) -> tuple[tuple, np.ndarray | None]:
    """``(driven, reaction)`` of a recording in time of ``n_frames`` frames, checked: the
    DrivenPaths and the ToolPath one row per frame, the load cell's reading one force per
    frame, with a driven set or a tool whose force it reads."""
    span = Span(n_frames, n_frames, "frame", f"the recording has {n_frames} frames, so",
                f"at each of the {n_frames} frames")
    driven = check_driven(mesh, driven, span, source)
    if tool is not None:
        check_tool(mesh, tool, span, source)
    if reaction is not None:
        if not driven and tool is None:
            raise InputError("a load cell's reading needs what it measures: driven sets or a "
                             "tool", source=source, key="reaction")
        reaction = check_reaction(reaction, span, source)
    return driven, reaction
