"""Experiment files (``.npz``, the contract in docs/formats.md).

Every reader validates what it reads and raises :class:`~neurofuzzy.errors.InputError` naming
the file and the key. Every writer writes atomically (a temporary file in the target folder,
then a rename), so a failure never leaves a half-written file behind.
"""

from __future__ import annotations

import io as _io
import os
import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ..errors import InputError, closest_name
from ..experiment import Experiment
from ..mesh import Mesh
from .paths import (DRIVEN_KEYS, OPTIONAL_TOOL_KEYS, TOOL_KEYS, driven_keys, read_driven,
                    read_tool, tool_keys)
from .writing import atomic_write

__all__ = ["load_experiment", "save_experiment"]

REQUIRED_KEYS = ("rest_positions", "springs", "dt", "positions")
#: embedded markers (:class:`~neurofuzzy.observation.EmbeddedMarkers`): all or none
MARKER_KEYS = ("marker_positions", "marker_nodes", "marker_weights", "marker_names")
#: what moved the body, one row per frame (:mod:`.paths`): driven sets, a load cell, a tool
MOVING_KEYS = (*DRIVEN_KEYS, "reaction", *TOOL_KEYS, *OPTIONAL_TOOL_KEYS)
OPTIONAL_KEYS = ("fixed", "external_forces", "observed", "masses", "spring_groups",
                 "group_names", "tetrahedra", *MARKER_KEYS, *MOVING_KEYS)
#: most bytes the arrays of one experiment file may hold uncompressed
MAX_EXPERIMENT_BYTES = 2 * 2**30


def load_experiment(path: str | os.PathLike) -> Experiment:
    """Read and validate an experiment file (the format: docs/formats.md).

    Raises
    ------
    InputError
        The file is missing or unreadable, a required key is absent, a key is unknown, or a
        value has the wrong shape, type or range. The message names the file and the key.
    """
    source = str(path)
    data = read_npz(path)
    known = REQUIRED_KEYS + OPTIONAL_KEYS
    for key in data:
        if key not in known and not key.startswith("true_"):
            hint = closest_name(key, known)
            raise InputError("unknown key" + (f"; did you mean {hint!r}?" if hint else
                                              f"; known keys are {list(known)} and true_*"),
                             source=source, key=key)
    for key in REQUIRED_KEYS:
        if key not in data:
            raise InputError(f"required key is missing (the file has {sorted(data)})",
                             source=source, key=key)

    def check(key, make):
        try:
            return make()
        except InputError as error:
            raise InputError(error.detail, source=source, key=error.key or key) from None

    group_names = ()
    if "group_names" in data:
        names = data["group_names"]
        if names.ndim != 1 or names.dtype.kind not in "US":
            raise InputError("expected a 1-D array of strings", source=source,
                             key="group_names")
        group_names = tuple(str(n) for n in names)
    for key in ("rest_positions", "springs", "fixed", "spring_groups", "tetrahedra"):
        if key in data and data[key].dtype.kind not in "iuf":
            raise InputError(f"expected numbers, got dtype {data[key].dtype}", source=source,
                             key=key)
    for key in ("springs", "tetrahedra"):
        if key in data and data[key].dtype.kind == "f":
            raise InputError(f"expected integer node indices, got dtype {data[key].dtype}",
                             source=source, key=key)
    mesh = check("springs", lambda: Mesh(rest_positions=data["rest_positions"],
                                         springs=data["springs"],
                                         spring_group=data.get("spring_groups"),
                                         group_names=group_names,
                                         fixed=data.get("fixed", np.zeros(0, dtype=np.intp)),
                                         tetrahedra=data.get("tetrahedra")))
    truth = {key: value for key, value in data.items() if key.startswith("true_")}
    markers = check("marker_positions", lambda: _markers(data))
    driven = check("driven_set", lambda: read_driven(data))
    tool = check("tool_kind", lambda: read_tool(data))
    return Experiment(mesh=mesh, dt=data["dt"], positions=data["positions"],
                      external_forces=data.get("external_forces"),
                      observed=data.get("observed"), node_mass=data.get("masses"), truth=truth,
                      source=source, markers=markers, driven=driven,
                      reaction=data.get("reaction"), tool=tool)


def read_npz(path: str | os.PathLike, *, max_bytes: int | None = None) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` file, read member by member without trusting it.

    Every member must be a ``.npy`` array of plain (non-object) values whose header agrees
    with its size; the members together may hold at most ``max_bytes`` (default
    :data:`MAX_EXPERIMENT_BYTES`) uncompressed, checked before anything is decompressed.
    Whatever zipfile, zlib or numpy's format reader raise on a broken file becomes an
    :class:`InputError` naming the file and the member.
    """
    source = str(path)
    limit = MAX_EXPERIMENT_BYTES if max_bytes is None else max_bytes
    path = Path(path)
    if not path.exists():
        raise InputError("no such file", source=source)
    if path.is_dir():
        raise InputError("is a directory, not an experiment file", source=source)
    key = None
    try:
        with open(path, "rb") as handle:
            if handle.read(4) != b"PK\x03\x04":
                raise InputError("not a readable .npz experiment file (not a zip archive)",
                                 source=source)
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            total = sum(member.file_size for member in members)
            if total > limit:
                raise InputError(f"its arrays hold {total / 2**30:.2f} GB uncompressed; the "
                                 f"limit is {limit / 2**30:.2f} GB (split the recording into "
                                 "several experiment files)", source=source)
            data = {}
            for member in members:
                key = member.filename[:-4] if member.filename.endswith(".npy") \
                    else member.filename
                if key in data:
                    raise InputError("appears twice in the archive", source=source, key=key)
                with archive.open(member) as handle:
                    data[key] = _read_npy(handle, member.file_size)
            return data
    except InputError as error:
        raise InputError(error.detail, source=source, key=error.key or key) from None
    except PermissionError as error:
        raise InputError(f"cannot read the file ({error.strerror})", source=source) from None
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, SyntaxError,
            TypeError, KeyError, NotImplementedError, RuntimeError, OverflowError,
            MemoryError) as error:
        # a corrupt archive, deflate stream or .npy header, or an encrypted member
        what = f"member {key!r} is" if key is not None else "it is"
        raise InputError(f"not a readable .npz experiment file: {what} corrupt or not a "
                         f".npy array ({type(error).__name__}: {error})", source=source,
                         key=key) from None


def _read_npy(handle, size: int) -> np.ndarray:
    """One ``.npy`` member of ``size`` bytes; its header must agree with its size."""
    version = np.lib.format.read_magic(handle)
    if version not in ((1, 0), (2, 0), (3, 0)):
        raise InputError(f"unsupported .npy format version {version}")
    read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) \
        else np.lib.format.read_array_header_2_0
    try:
        shape, fortran, dtype = read_header(handle)
    except tokenize.TokenError as error:
        # numpy tokenizes a header of an older numpy's form; an unclosed bracket ends there
        raise InputError(f"its .npy header is not a closed Python dictionary ({error.args[0]})"
                         ) from None
    if dtype.hasobject:
        raise InputError("holds Python objects, which neurofuzzy will not unpickle; store "
                         "plain numeric arrays")
    count = int(np.prod(shape, dtype=object))
    nbytes = count * dtype.itemsize
    if nbytes > size:
        raise InputError(f"its header promises {shape} {dtype} ({nbytes} bytes) but the "
                         f"member holds {size} bytes: truncated or corrupt")
    buffer = bytearray(handle.read(nbytes))
    if len(buffer) != nbytes:
        raise InputError(f"truncated: {len(buffer)} of {nbytes} bytes")
    return np.frombuffer(buffer, dtype=dtype, count=count).reshape(
        shape, order="F" if fortran else "C")


def _markers(data: dict):
    """The embedded markers of an experiment file, or None."""
    from ..observation import EmbeddedMarkers

    present = [key for key in MARKER_KEYS if key in data]
    if not present:
        return None
    missing = [key for key in MARKER_KEYS[:3] if key not in data]
    if missing:
        raise InputError(f"embedded markers need {', '.join(MARKER_KEYS[:3])}; "
                         f"{', '.join(missing)} missing", key=missing[0])
    if data["marker_nodes"].dtype.kind not in "iu":
        raise InputError(f"expected integer node indices, got dtype "
                         f"{data['marker_nodes'].dtype}", key="marker_nodes")
    for key in ("marker_positions", "marker_weights"):
        if data[key].dtype.kind not in "iuf":
            raise InputError(f"expected numbers, got dtype {data[key].dtype}", key=key)
    names = data.get("marker_names", np.zeros(0, str))
    if names.ndim != 1 or (names.size and names.dtype.kind not in "US"):
        raise InputError("expected a 1-D array of strings", key="marker_names")
    return EmbeddedMarkers(nodes=data["marker_nodes"], weights=data["marker_weights"],
                           positions=data["marker_positions"],
                           names=tuple(str(name) for name in names))


def save_experiment(experiment: Experiment, path: str | os.PathLike) -> Path:
    """Write ``experiment`` as an ``.npz`` file (atomically); returns the path."""
    path = Path(path)
    mesh = experiment.mesh
    data = {
        "rest_positions": mesh.rest_positions,
        "springs": mesh.springs,
        "dt": np.float64(experiment.dt),
        "positions": experiment.positions,
        "fixed": mesh.fixed,
        "observed": experiment.observed,
        "spring_groups": mesh.spring_group,
        "group_names": np.array(mesh.group_names, dtype=str),
    }
    if mesh.tetrahedra is not None:
        data["tetrahedra"] = mesh.tetrahedra
    if experiment.external_forces is not None:
        data["external_forces"] = experiment.external_forces
    if experiment.node_mass is not None:
        data["masses"] = experiment.node_mass
    if experiment.markers is not None:
        markers = experiment.markers
        data.update(marker_positions=markers.positions, marker_nodes=markers.nodes,
                    marker_weights=markers.weights,
                    marker_names=np.array(markers.names, dtype=str))
    if experiment.driven:
        data.update(driven_keys(experiment.driven, experiment.n_frames))
    if experiment.reaction is not None:
        data["reaction"] = experiment.reaction
    if experiment.tool is not None:
        data.update(tool_keys(experiment.tool))
    return write_npz(path, data, experiment.truth)


def write_npz(path: Path, arrays: dict, truth: dict) -> Path:
    """``arrays`` and the ground truth ``truth`` (as ``true_*`` keys) as a compressed
    ``.npz`` file, written atomically; returns the path."""
    for key, value in truth.items():
        arrays[key if key.startswith("true_") else f"true_{key}"] = np.asarray(value)
    buffer = _io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    with atomic_write(path) as handle:
        handle.write(buffer.getvalue())
    return path
