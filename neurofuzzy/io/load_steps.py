"""Load-step experiment files (``.npz``, docs/formats.md "Load-step files"): the scans of a
displacement-controlled test, its driven sets and, where there was one, the load cell's force.

A load-step file is told from a time-series experiment by its ``load_steps`` key. Read with
the same safe reader as experiment files (:func:`neurofuzzy.io.experiments.read_npz`), checked
key by key, written atomically.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError, closest_name
from ..load_steps import DrivenPath, LoadSteps, ToolPath
from ..mesh import from_tetra
from ..simulation.contact import FlatPunch, Sphere, SurfaceTool
from .experiments import _markers, read_npz, write_npz

__all__ = ["save_load_steps", "load_load_steps", "is_load_steps_file", "KEYS"]

#: the keys of a load-step file (``true_*`` besides)
KEYS = ("load_steps", "rest_positions", "tetrahedra", "fixed", "marker_positions",
        "marker_nodes", "marker_weights", "marker_names", "driven_nodes", "driven_set",
        "driven_displacement", "driven_components", "driven_names", "reaction",
        "tool_kind", "tool_radius", "tool_axis", "tool_positions", "tool_stiffness",
        "tool_name", "tool_orientations", "tool_vertices", "tool_faces")
#: an indenter's keys (all or none): its kind (``sphere``, ``flat punch`` or ``surface``),
#: radius (m; a surface's reach from its reference point), a punch's axis, its positions at
#: steps 0..n (m), the penalty (Pa/m; NaN: automatic), name; ``tool_orientations`` (its
#: attitude at steps 0..n, quaternions w, x, y, z) is optional; a surface's ``tool_vertices``
#: (m, in the tool's frame) and ``tool_faces`` are required for it and refused for another
TOOL_KEYS = KEYS[14:20]
#: the markers are optional (a force–displacement curve alone), the rest is required
REQUIRED = KEYS[:4] + KEYS[8:13]
#: the dtype kinds each key may have: integers, numbers, text
KINDS_INTEGER = (("load_steps", "tetrahedra", "fixed", "driven_nodes", "driven_set",
                  "marker_nodes", "tool_faces"), "iu", "integers")
KINDS_NUMBER = (("rest_positions", "marker_positions", "marker_weights",
                 "driven_displacement", "reaction", "tool_radius", "tool_axis",
                 "tool_positions", "tool_stiffness", "tool_orientations", "tool_vertices"),
                "iuf", "numbers")
KINDS_TEXT = (("driven_components", "driven_names", "marker_names", "tool_kind",
               "tool_name"), "US", "strings")


def is_load_steps_file(path: str | os.PathLike) -> bool:
    """True for an ``.npz`` file with the ``load_steps`` key (the archive's member list only)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            return "load_steps.npy" in archive.namelist()
    except (OSError, zipfile.BadZipFile):
        return False


def save_load_steps(data: LoadSteps, path: str | os.PathLike) -> Path:
    """Write ``data`` as a load-step file (atomically); returns the path."""
    path = Path(path)
    mesh, markers = data.mesh, data.markers
    out = {"load_steps": np.int64(data.n_steps), "rest_positions": mesh.rest_positions,
           "tetrahedra": mesh.tetrahedra, "fixed": mesh.fixed,
           "driven_nodes": np.concatenate([np.asarray(d.nodes, np.int64)
                                           for d in data.driven] or [np.zeros(0, np.int64)]),
           "driven_set": np.concatenate([np.full(len(d.nodes), i) for i, d
                                         in enumerate(data.driven)] or [np.zeros(0, int)]),
           "driven_displacement": np.array([d.displacement for d in data.driven],
                                           float).reshape(-1, data.n_steps, 3),
           "driven_components": np.array([d.components for d in data.driven], dtype=str),
           "driven_names": np.array([d.name for d in data.driven], dtype=str)}
    if markers is not None:
        out.update(marker_positions=markers.positions, marker_nodes=markers.nodes,
                   marker_weights=markers.weights,
                   marker_names=np.array(markers.names, dtype=str))
    if data.reaction is not None:
        out["reaction"] = np.asarray(data.reaction, float)
    if data.tool is not None:
        out.update(_tool_keys(data.tool))
    return write_npz(path, out, data.truth)


def _tool_keys(path: ToolPath) -> dict:
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


def _tool(data) -> ToolPath | None:
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


def load_load_steps(path: str | os.PathLike) -> LoadSteps:
    """Read and check a load-step file; :class:`InputError` naming the file and key."""
    source = str(path)
    data = read_npz(path)
    for key in data:
        if key not in KEYS and not key.startswith("true_"):
            hint = closest_name(key, KEYS)
            raise InputError("unknown key" + (f"; did you mean {hint!r}?" if hint else ""),
                             source=source, key=key)
    for key in REQUIRED:
        if key not in data:
            raise InputError(f"required key is missing (the file has {sorted(data)})",
                             source=source, key=key)
    try:
        for keys, kinds, what in (KINDS_INTEGER, KINDS_NUMBER, KINDS_TEXT):
            for key in keys:
                if key in data and data[key].dtype.kind not in kinds:
                    raise InputError(f"expected {what}, got dtype {data[key].dtype}", key=key)
        if data["load_steps"].ndim != 0:
            raise InputError("expected one integer (the number of load steps)",
                             key="load_steps")
        for key, ndim in (("driven_nodes", 1), ("driven_set", 1), ("driven_components", 1),
                          ("driven_names", 1), ("reaction", 2), ("driven_displacement", 3)):
            if key in data and data[key].ndim != ndim:
                raise InputError(f"expected {ndim} dimension(s), got shape {data[key].shape}",
                                 key=key)
        mesh = from_tetra(data["rest_positions"], data["tetrahedra"]).with_fixed(data["fixed"])
        sets = data["driven_set"]
        displacement = data["driven_displacement"]
        n_sets = len(data["driven_names"])
        if sets.shape != data["driven_nodes"].shape or (sets.size and (
                sets.min() < 0 or sets.max() >= n_sets)) or displacement.ndim != 3 \
                or displacement.shape[0] != n_sets or len(data["driven_components"]) != n_sets:
            raise InputError(f"driven_nodes, driven_set, driven_displacement (n_sets, "
                             f"n_steps, 3), driven_components and driven_names must describe "
                             f"the same {n_sets} sets", key="driven_set")
        driven = tuple(DrivenPath(data["driven_nodes"][sets == i], displacement[i],
                                  str(data["driven_components"][i]),
                                  str(data["driven_names"][i])) for i in range(n_sets))
        truth = {key: value for key, value in data.items() if key.startswith("true_")}
        return LoadSteps(mesh, driven, _markers(data), data.get("reaction"), truth, source,
                         _tool(data))
    except InputError as error:
        if error.source:
            raise
        raise InputError(error.detail, source=source, key=error.key) from None
