"""Readers of marker recordings (CSV, C3D), marker-to-node maps and force files."""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, closest_name
from .csvtable import TIME_TOLERANCE, number, read_csv_table
from .forces import read_forces
from .units import LENGTH_UNITS, TIME_UNITS, Stated, check_statements, unit_factor

__all__ = ["MarkerData", "read_markers", "read_marker_csv", "read_c3d", "read_marker_map",
           "read_forces", "read_csv_table", "LENGTH_UNITS", "TIME_TOLERANCE",
           "MARKER_STATEMENTS"]

#: the unit statements a marker CSV may make (``units`` and ``length units`` are one)
MARKER_STATEMENTS = ("units", "length units", "time units")


@dataclass(frozen=True, eq=False)
class MarkerData:
    """A marker recording.

    Parameters
    ----------
    names : tuple of str, (n_markers,)
        Marker labels (for a ``node`` CSV, the node indices as strings).
    times : (n_frames,) float
        Capture times in seconds, increasing.
    positions : (n_frames, n_markers, 3) float
        Positions in metres; NaN where the marker was not seen.
    source : str
        The file, for messages.
    by_node : bool
        The names are node indices (a ``time,node,x,y,z`` CSV).
    """

    names: tuple[str, ...]
    times: np.ndarray
    positions: np.ndarray
    source: str = "<markers>"
    by_node: bool = False

    @property
    def n_markers(self) -> int:
        return len(self.names)

    @property
    def frame_period(self) -> float:
        """Median spacing of the capture times."""
        return float(np.median(np.diff(self.times))) if len(self.times) > 1 else float("nan")


def read_markers(path: str | os.PathLike, *, units: str | None = None) -> MarkerData:
    """Read a marker recording, ``.csv`` or ``.c3d`` (by extension); see the module docstring.

    ``units`` states the length unit of the file: ``"m"``, ``"cm"`` or ``"mm"``; a file that
    states its own (a CSV's ``# units:`` line, a C3D's ``POINT:UNITS``) must agree with it.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_marker_csv(path, units=units)
    if suffix == ".c3d":
        return read_c3d(path, units=units)
    raise InputError(f"unknown marker file type {suffix or '(none)'!r}; expected .csv or .c3d",
                     source=str(path))


def read_marker_csv(path: str | os.PathLike, *, units: str | None = None) -> MarkerData:
    """Read a ``time,marker,x,y,z`` (or ``time,node,x,y,z``) CSV; see the module docstring.

    The length unit is stated in a line ``# units: mm`` (or ``# length units: mm``) or given
    as ``units``; both, differently, is refused. Times are in seconds unless a line
    ``# time units: ms`` says otherwise.
    """
    path = Path(path)
    source = str(path)
    header, rows, stated = read_csv_table(path, required=[("time",), ("marker", "node"),
                                                     ("x",), ("y",), ("z",)])
    check_statements(stated, MARKER_STATEMENTS, source)
    unit = unit_factor(LENGTH_UNITS, what="length", stated=stated,
                       keys=("units", "length units"), source=source, given=units,
                       given_as="--units", missing=_NO_UNIT)
    seconds = unit_factor(TIME_UNITS, what="time", stated=stated, keys=("time units",),
                          source=source, default="s")
    label = "node" if "node" in header else "marker"
    times, names, coordinates = [], [], []
    for line, row in rows:
        time = number(row[header["time"]], source, line, "time")
        if not math.isfinite(time):
            raise InputError(f"time is {row[header['time']]!r}; expected a number of seconds",
                             source=source, line=line)
        name = row[header[label]].strip()
        if not name:
            raise InputError(f"empty {label} name", source=source, line=line)
        times.append(time * seconds)
        names.append(name)
        coordinates.append([number(row[header[axis]], source, line, axis, allow_missing=True)
                            for axis in "xyz"])
    if not rows:
        raise InputError("no data rows", source=source)
    if label == "node":
        for name, (line, _) in zip(names, rows):
            if not re.fullmatch(r"\d+", name):
                raise InputError(f"node {name!r} is not a node index (a non-negative integer)",
                                 source=source, line=line)
    frame_times, frame_of = np.unique(np.asarray(times), return_inverse=True)
    marker_names, first_row, marker_of = np.unique(np.asarray(names), return_index=True,
                                                   return_inverse=True)
    # markers in the order they first appear (nodes by index)
    order = np.argsort(marker_names.astype(int) if label == "node" else first_row, kind="stable")
    marker_names = marker_names[order]
    marker_of = np.argsort(order)[marker_of]
    positions = np.full((len(frame_times), len(marker_names), 3), np.nan)
    seen = np.zeros(positions.shape[:2], dtype=bool)
    for line_index, (frame, marker) in enumerate(zip(frame_of, marker_of)):
        if seen[frame, marker]:
            line = rows[line_index][0]
            raise InputError(f"{label} {str(marker_names[marker])!r} appears twice at time "
                             f"{frame_times[frame]:g} s", source=source, line=line)
        seen[frame, marker] = True
    if len(frame_times) < 2:
        raise InputError(f"every row has the time {frame_times[0]:g} s: a recording needs at "
                         "least two capture times (frames)", source=source, line=rows[-1][0])
    positions[frame_of, marker_of] = np.asarray(coordinates, dtype=float) * unit
    return MarkerData(names=tuple(str(n) for n in marker_names), times=frame_times,
                      positions=positions, source=source, by_node=label == "node")


def read_c3d(path: str | os.PathLike, *, units: str | None = None) -> MarkerData:
    """Read the 3-D points of a C3D optical-capture file (``c3d`` package)."""
    import struct

    import c3d

    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise InputError("no such file", source=source)
    with open(path, "rb") as handle:
        head = handle.read(2)
        if len(head) == 2 and head[0] >= 1:
            handle.seek(512 * (head[0] - 1) + 3)
            processor = handle.read(1)
    if len(head) < 2 or head[1] != 0x50 or head[0] < 1:
        raise InputError("not a C3D file (byte 2 of a C3D file is 0x50, the key of its "
                         "parameter section)", source=source)
    if processor not in (b"\x54", b"\x55", b"\x56"):
        raise InputError("not a readable C3D file: its parameter section names no known "
                         "processor type (84 Intel, 85 DEC, 86 MIPS)", source=source)
    try:
        with open(path, "rb") as handle, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            reader = c3d.Reader(handle)
            labels = [str(name).strip() for name in reader.point_labels]
            rate = float(reader.point_rate)
            expected = int(reader.last_frame) - int(reader.first_frame) + 1
            stated = _c3d_units(reader)
            frames = [points[:, :4].astype(float) for _, points, _ in reader.read_frames()]
    # the c3d package checks its file with assert and trusts the header's sizes
    except (struct.error, ValueError, KeyError, IndexError, EOFError, OSError, AttributeError,
            TypeError, AssertionError, MemoryError, OverflowError, ZeroDivisionError,
            UnboundLocalError) as error:
        raise InputError(f"not a readable C3D file ({type(error).__name__}: {error})",
                         source=source) from None
    truncated = [w for w in caught if "end of file" in str(w.message).lower()]
    if truncated or len(frames) < expected:
        raise InputError(f"truncated C3D file: the header announces {expected} frames, the "
                         f"file holds {len(frames)}", source=source)
    if not frames or not labels:
        raise InputError("the file holds no 3-D points", source=source)
    if not (math.isfinite(rate) and rate > 0):
        raise InputError(f"point rate {rate} is not a positive number", source=source)
    if len(frames) < 2:
        raise InputError(f"holds {len(frames)} frame: a recording needs at least two",
                         source=source)
    declared = Stated()
    if stated is not None:
        declared.state("point:units", stated, 0, source)
    unit = unit_factor(LENGTH_UNITS, what="length", stated=declared, keys=("point:units",),
                       source=source, given=units, given_as="--units", missing=_NO_UNIT)
    data = np.stack(frames)                                    # (T, M, 4)
    positions = np.where(data[:, :, 3:4] < 0, np.nan, data[:, :, :3]) * unit
    names = tuple(label or f"marker{i}" for i, label in enumerate(labels))
    if len(set(names)) != len(names):
        raise InputError("two points share a label; labels must be unique", source=source)
    times = np.arange(len(frames)) / rate
    return MarkerData(names=names, times=times, positions=positions[:, :len(names)],
                      source=source)


def read_marker_map(path: str | os.PathLike, *, markers: MarkerData | None = None,
                    n_nodes: int | None = None) -> dict[str, int]:
    """Read a ``marker,node`` CSV: marker name → node index.

    Given the recording (``markers``) and the model's ``n_nodes``, every row is checked
    against them here, so a bad row is reported as the map's ``FILE:LINE``.
    """
    path = Path(path)
    source = str(path)
    header, rows, _ = read_csv_table(path, required=[("marker",), ("node",)])
    mapping: dict[str, int] = {}
    by_node: dict[int, str] = {}
    for line, row in rows:
        name = row[header["marker"]].strip()
        node = row[header["node"]].strip()
        if not re.fullmatch(r"\d+", node):
            raise InputError(f"node {node!r} is not a node index (a non-negative integer)",
                             source=source, line=line)
        if name in mapping:
            raise InputError(f"marker {name!r} is mapped twice", source=source, line=line)
        if markers is not None and name not in markers.names:
            hint = closest_name(name, markers.names)
            raise InputError(f"marker {name!r} is not in {markers.source}" +
                             (f"; did you mean {hint!r}?" if hint else ""), source=source,
                             line=line)
        if n_nodes is not None and int(node) >= n_nodes:
            raise InputError(f"node {node} is out of range: the model has {n_nodes} nodes "
                             f"(0..{n_nodes - 1})", source=source, line=line)
        if int(node) in by_node:
            raise InputError(f"markers {by_node[int(node)]!r} and {name!r} both belong to node "
                             f"{node}; attach each marker to its own node", source=source,
                             line=line)
        by_node[int(node)] = name
        mapping[name] = int(node)
    if not mapping:
        raise InputError("no rows: expected marker,node pairs", source=source)
    return mapping


_NO_UNIT = ("the length unit is not stated; add a line '# units: mm' (m, cm or mm) or pass "
            "the unit (--units)")


def _c3d_units(reader) -> str | None:
    parameter = reader.get("POINT:UNITS")
    if parameter is None:
        return None
    try:
        return parameter.string_value.strip() or None
    except (ValueError, UnicodeDecodeError):
        return None
