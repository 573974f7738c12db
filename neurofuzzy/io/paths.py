"""The keys that describe what moved a body, shared by load-step files (per load step) and
experiment files (per frame): driven node sets and their paths, and a rigid tool's path
(docs/formats.md)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..paths import DrivenPath, ToolPath
from ..simulation.contact import FlatPunch, Sphere, SurfaceTool

__all__ = ["DRIVEN_KEYS", "TOOL_KEYS", "OPTIONAL_TOOL_KEYS", "driven_keys", "read_driven",
           "tool_keys", "read_tool", "is_moved_file"]

#: the driven sets: every driven node, its set's index, each set's displacement per row
#: (n_sets, n_rows, 3), held components and name
DRIVEN_KEYS = ("driven_nodes", "driven_set", "driven_displacement", "driven_components",
               "driven_names")
#: an indenter's keys (all or none): its kind (``sphere``, ``flat punch`` or ``surface``),
#: radius (m; a surface's reach from its reference point), a punch's axis, its positions per
#: row (m), the penalty (Pa/m; NaN: automatic), name
TOOL_KEYS = ("tool_kind", "tool_radius", "tool_axis", "tool_positions", "tool_stiffness",
             "tool_name")
#: ``tool_orientations`` (its attitude per row, quaternions w, x, y, z) is optional; a
#: surface's ``tool_vertices`` (m, in the tool's frame) and ``tool_faces`` are required for
#: it and refused for another
OPTIONAL_TOOL_KEYS = ("tool_orientations", "tool_vertices", "tool_faces")


def driven_keys(driven, n_rows: int) -> dict:
    """The file keys of ``driven`` (DrivenPaths of ``n_rows`` rows each)."""
    return {"driven_nodes": np.concatenate([np.asarray(d.nodes, np.int64) for d in driven]
                                           or [np.zeros(0, np.int64)]),
            "driven_set": np.concatenate([np.full(len(d.nodes), i) for i, d
                                          in enumerate(driven)] or [np.zeros(0, int)]),
            "driven_displacement": np.array([d.displacement for d in driven],
                                            float).reshape(-1, n_rows, 3),
            "driven_components": np.array([d.components for d in driven], dtype=str),
            "driven_names": np.array([d.name for d in driven], dtype=str)}


def read_driven(data) -> tuple:
    """The DrivenPaths of a file's :data:`DRIVEN_KEYS` (all or none)."""
    given = [key for key in DRIVEN_KEYS if key in data]
    if not given:
        return ()
    if len(given) < len(DRIVEN_KEYS):
        missing = sorted(set(DRIVEN_KEYS) - set(given))
        raise InputError(f"driven sets need all of {', '.join(DRIVEN_KEYS)}; missing "
                         f"{', '.join(missing)}", key=missing[0])
    for key, kinds, ndim in (("driven_nodes", "iu", 1), ("driven_set", "iu", 1),
                             ("driven_displacement", "iuf", 3),
                             ("driven_components", "US", 1), ("driven_names", "US", 1)):
        if data[key].dtype.kind not in kinds or data[key].ndim != ndim:
            raise InputError(f"expected {ndim} dimension(s) of "
                             f"{'text' if kinds == 'US' else 'numbers'}, got "
                             f"{data[key].dtype} of shape {data[key].shape}", key=key)
    sets = data["driven_set"]
    displacement = data["driven_displacement"]
    n_sets = len(data["driven_names"])
    if sets.shape != data["driven_nodes"].shape or (sets.size and (
            sets.min() < 0 or sets.max() >= n_sets)) or displacement.shape[0] != n_sets \
            or len(data["driven_components"]) != n_sets:
        raise InputError(f"driven_nodes, driven_set, driven_displacement (n_sets, n_rows, "
                         f"3), driven_components and driven_names must describe the same "
                         f"{n_sets} sets", key="driven_set")
    return tuple(DrivenPath(data["driven_nodes"][sets == i], displacement[i],
                            str(data["driven_components"][i]), str(data["driven_names"][i]))
                 for i in range(n_sets))


def tool_keys(path: ToolPath) -> dict:
    """The file keys of a tool's path (:data:`TOOL_KEYS` and the optional ones)."""
    tool = path.tool
    punch = isinstance(tool, FlatPunch)
    surface = ({"tool_vertices": tool.vertices, "tool_faces": tool.faces}
               if isinstance(tool, SurfaceTool) else {})
    kind = "flat punch" if punch else "surface" if surface else "sphere"
    return {"tool_kind": np.array(kind), **surface,
            "tool_radius": np.float64(tool.radius),
            "tool_axis": np.array(tool.axis if punch else (0.0, 0.0, 1.0), float),
            "tool_positions": np.asarray(path.positions, float),
            "tool_stiffness": np.float64(np.nan if path.stiffness == "auto"
                                         else path.stiffness),
            "tool_name": np.array(path.name),
            **({} if path.orientations is None
               else {"tool_orientations": np.asarray(path.orientations, float)})}


def read_tool(data) -> ToolPath | None:
    """The file's indenter (:data:`TOOL_KEYS`, all or none), or None."""
    given = [key for key in TOOL_KEYS if key in data]
    if not given:
        if "tool_orientations" in data:
            raise InputError("has a tool's attitudes but no tool", key="tool_orientations")
        return None
    if len(given) < len(TOOL_KEYS):
        missing = sorted(set(TOOL_KEYS) - set(given))
        raise InputError(f"an indenter needs all of {', '.join(TOOL_KEYS)}; missing "
                         f"{', '.join(missing)}", key=missing[0])
    kind = str(data["tool_kind"])
    if kind not in ("sphere", "flat punch", "surface"):
        raise InputError(f"got {kind!r}; expected 'sphere', 'flat punch' or 'surface'",
                         key="tool_kind")
    shape = [key for key in ("tool_vertices", "tool_faces") if key in data]
    if (kind == "surface") != bool(shape) or len(shape) == 1:
        raise InputError(f"a {kind} tool " + ("needs both tool_vertices and tool_faces"
                                              if kind == "surface" else
                                              f"takes no {shape[0]}"), key="tool_kind")
    radius = float(data["tool_radius"])
    tool = (Sphere(radius) if kind == "sphere"
            else SurfaceTool(data["tool_vertices"], data["tool_faces"]) if shape
            else FlatPunch(radius, tuple(np.asarray(data["tool_axis"], float).ravel())))
    stiffness = float(data["tool_stiffness"])
    turns = data["tool_orientations"] if "tool_orientations" in data else None
    return ToolPath(tool, np.asarray(data["tool_positions"], float),
                    "auto" if np.isnan(stiffness) else stiffness, str(data["tool_name"]),
                    None if turns is None else np.asarray(turns, float))


def is_moved_file(path) -> bool:
    """True for an experiment file in time (no ``load_steps`` key) with driven sets or a
    tool (the archive's member list only)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
    except (OSError, zipfile.BadZipFile):
        return False
    return "load_steps.npy" not in names and bool({"driven_set.npy", "tool_kind.npy"} & names)
