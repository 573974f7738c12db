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
from ..load_steps import LoadSteps
from ..mesh import from_tetra
from .experiments import MARKER_KEYS, _markers, read_npz, write_npz
from .paths import (DRIVEN_KEYS, OPTIONAL_TOOL_KEYS, TOOL_KEYS, driven_keys, read_driven,
                    read_tool, tool_keys)

__all__ = ["save_load_steps", "load_load_steps", "is_load_steps_file", "KEYS"]

#: the keys of a load-step file (``true_*`` besides); the driven sets' and the tool's
#: (:mod:`.paths`) have a row per load step, the tool's from step 0
KEYS = ("load_steps", "rest_positions", "tetrahedra", "fixed", *MARKER_KEYS, *DRIVEN_KEYS,
        "reaction", *TOOL_KEYS, *OPTIONAL_TOOL_KEYS)
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
           **driven_keys(data.driven, data.n_steps)}
    if markers is not None:
        out.update(marker_positions=markers.positions, marker_nodes=markers.nodes,
                   marker_weights=markers.weights,
                   marker_names=np.array(markers.names, dtype=str))
    if data.reaction is not None:
        out["reaction"] = np.asarray(data.reaction, float)
    if data.tool is not None:
        out.update(tool_keys(data.tool))
    return write_npz(path, out, data.truth)


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
        driven = read_driven(data)
        truth = {key: value for key, value in data.items() if key.startswith("true_")}
        return LoadSteps(mesh, driven, _markers(data), data.get("reaction"), truth, source,
                         read_tool(data))
    except InputError as error:
        if error.source:
            raise
        raise InputError(error.detail, source=source, key=error.key) from None
