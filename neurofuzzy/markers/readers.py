"""Readers of marker recordings (CSV, C3D), marker-to-node maps and force files."""

from __future__ import annotations

import csv
import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, closest_name

__all__ = ["MarkerData", "read_markers", "read_marker_csv", "read_c3d", "read_marker_map",
           "read_forces", "read_csv_table", "LENGTH_UNITS", "TIME_TOLERANCE"]

#: metres per unit of every length unit a file may state
LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}

#: relative tolerance on times: a time within this fraction of a frame period is "on" a frame
TIME_TOLERANCE = 1e-6


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

    ``units`` states (CSV) or overrides (C3D) the length unit of the file: ``"m"``, ``"cm"``
    or ``"mm"``.
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
    """Read a ``time,marker,x,y,z`` (or ``time,node,x,y,z``) CSV; see the module docstring."""
    path = Path(path)
    source = str(path)
    header, rows, stated = read_csv_table(path, required=[("time",), ("marker", "node"),
                                                     ("x",), ("y",), ("z",)])
    unit = _length_unit(units, stated.get("units"), source)
    label = "node" if "node" in header else "marker"
    times, names, coordinates = [], [], []
    for line, row in rows:
        time = _number(row[header["time"]], source, line, "time")
        if not math.isfinite(time):
            raise InputError(f"time is {row[header['time']]!r}; expected a number of seconds",
                             source=source, line=line)
        name = row[header[label]].strip()
        if not name:
            raise InputError(f"empty {label} name", source=source, line=line)
        times.append(time)
        names.append(name)
        coordinates.append([_number(row[header[axis]], source, line, axis, allow_missing=True)
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
    unit = _length_unit(units, stated, source)
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


def read_forces(path: str | os.PathLike, *, times: np.ndarray, n_nodes: int | None = None,
                mesh=None, spread: int = 1, radius: float | None = None) -> np.ndarray:
    """Applied forces of a force CSV (newtons) at the given frame times.

    Two forms, told apart by the header:

    - ``time,node,fx,fy,fz``: a node's force holds from its row's time until the next row of
      that node (zero before its first row).
    - ``time,x,y,z,fx,fy,fz`` (optional ``probe`` and ``radius`` columns): the force of a
      probe acting at a point, for users who know where the probe touched rather than our
      node numbering. With a contact radius (the ``radius`` column, in the file's length
      unit, or ``radius``) the force is a uniform traction on the surface within that radius
      of the point, given to the nodes as its consistent loads
      (:func:`~neurofuzzy.mesh.patch_loads`; radius 0: the nearest surface point, shared by
      its triangle's corners), so models of any resolution feel the same probe. Without
      one, the point goes to the nearest surface node at rest, or is shared by the
      ``spread`` nearest surface nodes (weights proportional to inverse distance). A
      probe's row holds until that probe's next row (without a ``probe`` column every row
      belongs to one probe). The coordinates' length unit must be stated in a line
      ``# length units: mm`` (m, cm or mm); a point farther from the surface than the
      mesh's longest edge is refused.

    Parameters
    ----------
    times : (n_frames,) float
        Frame times (seconds, on the file's clock).
    n_nodes : int, optional
        Number of nodes (node form; taken from ``mesh`` when given).
    mesh : Mesh, optional
        The model's mesh; required for the point form.
    spread : int
        Surface nodes sharing a point force (point form without a radius).
    radius : float, optional
        Contact radius of every probe (m; point form), unless the file has a ``radius``
        column.

    Returns
    -------
    forces : (n_frames, n_nodes, 3) float
        ``forces[t]`` is the force in effect at ``times[t]`` (and until the next frame).
    """
    path = Path(path)
    source = str(path)
    if mesh is not None:
        n_nodes = mesh.n_nodes
    if n_nodes is None:
        raise ValueError("read_forces needs n_nodes or mesh")
    header, rows, stated = read_csv_table(path, required=[("time",), ("node", "x"), ("fx",),
                                                     ("fy",), ("fz",)])
    if stated.get("units") not in (None, "N", "n"):
        raise InputError(f"force unit {stated['units']!r}; forces must be in newtons (N)",
                         source=source)
    times = np.asarray(times, float)
    period = float(np.median(np.diff(times))) if len(times) > 1 else 1.0
    forces = np.zeros((len(times), n_nodes, 3))
    if "node" not in header:
        return _point_forces(header, rows, stated, source, times, period, forces, mesh,
                             spread, radius)
    entries = []
    for line, row in rows:
        time = _number(row[header["time"]], source, line, "time")
        node = row[header["node"]].strip()
        if not re.fullmatch(r"\d+", node) or int(node) >= n_nodes:
            raise InputError(f"node {node!r} is not a node index of this model (0.."
                             f"{n_nodes - 1})", source=source, line=line)
        value = _force_value(row, header, source, line, time)
        entries.append((time, int(node), value))
    entries.sort(key=lambda entry: entry[0])          # stable: file order within a time
    for time, node, value in entries:
        start = np.searchsorted(times, time - TIME_TOLERANCE * period)
        forces[start:, node] = value
    return forces


def _force_value(row, header, source: str, line: int, time: float) -> list[float]:
    value = [_number(row[header[key]], source, line, key) for key in ("fx", "fy", "fz")]
    if not (math.isfinite(time) and all(map(math.isfinite, value))):
        raise InputError("NaN or infinite value; every force row needs numbers",
                         source=source, line=line)
    return value


def _point_forces(header, rows, stated, source, times, period, forces, mesh, spread, radius):
    """The ``time,x,y,z,fx,fy,fz`` form of :func:`read_forces`."""
    from ..mesh import patch_weights, surface_nodes

    for column in ("y", "z"):
        if column not in header:
            raise InputError(f"missing column {column!r}; a point force needs x,y,z",
                             source=source)
    if mesh is None:
        raise InputError("forces at points (x,y,z) need the model's mesh", source=source)
    if "length units" not in stated:
        raise InputError("the points' length unit is not stated; add a line "
                         "'# length units: mm' (m, cm or mm)", source=source)
    scale = _length_unit(None, stated["length units"], source)
    if not (isinstance(spread, (int, np.integer)) and spread >= 1):
        raise InputError(f"got {spread!r}; expected a positive number of nodes",
                         key="spread")
    surface = np.flatnonzero(surface_nodes(mesh))
    rest = mesh.rest_positions[surface]
    reach = float(mesh.rest_lengths.max()) if mesh.n_springs else np.inf
    spread = min(int(spread), len(surface))
    if radius is not None and not (np.isfinite(radius) and radius >= 0):
        raise InputError(f"got {radius!r}; expected a contact radius >= 0 (m)", key="radius")
    entries = []
    for line, row in rows:
        time = _number(row[header["time"]], source, line, "time")
        point = np.array([_number(row[header[key]], source, line, key) for key in "xyz"])
        if not np.all(np.isfinite(point)):
            raise InputError("NaN or infinite point", source=source, line=line)
        distance = np.linalg.norm(rest - scale * point, axis=1)
        nearest = np.argsort(distance)[:spread]
        if distance[nearest[0]] > reach:
            raise InputError(f"the point ({', '.join(f'{c:g}' for c in point)}) is "
                             f"{distance[nearest[0]]:.3g} m from the nearest surface node, "
                             f"farther than the longest edge ({reach:.3g} m); check the "
                             "coordinates and their unit", source=source, line=line)
        contact = radius
        if "radius" in header:
            contact = scale * _number(row[header["radius"]], source, line, "radius")
            if not (math.isfinite(contact) and contact >= 0):
                raise InputError(f"radius {row[header['radius']]!r}: expected a contact "
                                 "radius >= 0", source=source, line=line)
        if contact is None:
            weight = 1.0 / np.maximum(distance[nearest], 1e-12 * reach)
            nodes, weight = surface[nearest], weight / weight.sum()
        else:
            shares = patch_weights(mesh, scale * point, contact)
            nodes = np.flatnonzero(shares)
            weight = shares[nodes]
        probe = row[header["probe"]].strip() if "probe" in header else ""
        entries.append((time, probe, nodes, weight,
                        np.array(_force_value(row, header, source, line, time))))
    entries.sort(key=lambda entry: entry[0])
    acting: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for time, probe, nodes, weight, value in entries:
        start = np.searchsorted(times, time - TIME_TOLERANCE * period)
        if probe in acting:                           # the probe's previous row stops here
            old_nodes, old_load = acting[probe]
            np.add.at(forces[start:], (slice(None), old_nodes), -old_load)
        load = weight[:, None] * value
        np.add.at(forces[start:], (slice(None), nodes), load)
        acting[probe] = (nodes, load)
    return forces


def _length_unit(flag: str | None, stated: str | None, source: str) -> float:
    unit = flag or stated
    if unit is None:
        raise InputError("the length unit is not stated; add a line '# units: mm' (m, cm or mm)"
                         " or pass the unit (--units)", source=source)
    unit = unit.strip().lower()
    if unit not in LENGTH_UNITS:
        hint = closest_name(unit, LENGTH_UNITS)
        raise InputError(f"unknown length unit {unit!r}; expected one of "
                         f"{', '.join(LENGTH_UNITS)}" + (f" (did you mean {hint!r}?)"
                                                        if hint else ""), source=source)
    return LENGTH_UNITS[unit]


def _c3d_units(reader) -> str | None:
    parameter = reader.get("POINT:UNITS")
    if parameter is None:
        return None
    try:
        return parameter.string_value.strip() or None
    except (ValueError, UnicodeDecodeError):
        return None


def read_csv_table(path: Path, required: list[tuple[str, ...]]):
    """Header (column name → index), data rows as (line, cells), stated ``# key: value``."""
    source = str(path)
    if not path.is_file():
        raise InputError("no such file", source=source)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read the file ({error})", source=source) from None
    stated: dict[str, str] = {}
    header = None
    rows = []
    for line, cells in enumerate(csv.reader(text.splitlines()), start=1):
        if not cells or not "".join(cells).strip():
            continue
        if cells[0].lstrip().startswith("#"):
            comment = ",".join(cells).lstrip()[1:]
            if ":" in comment:
                key, value = comment.split(":", 1)
                stated[key.strip().lower()] = value.strip()
            continue
        if header is None:
            header = {name.strip().lower(): i for i, name in enumerate(cells)}
            for choices in required:
                if not any(choice in header for choice in choices):
                    wanted = ",".join(choice[0] if len(choice) == 1 else "|".join(choice)
                                      for choice in required)
                    raise InputError(f"missing column {'/'.join(choices)!r}; the header must "
                                     f"name the columns {wanted}, got {','.join(cells)}",
                                     source=source, line=line)
            width = len(cells)
            continue
        if len(cells) != width:
            raise InputError(f"{len(cells)} values; the header has {width} columns",
                             source=source, line=line)
        rows.append((line, cells))
    if header is None:
        raise InputError("empty file: no header line", source=source)
    return header, rows, stated


def _number(text: str, source: str, line: int, column: str, *,
            allow_missing: bool = False) -> float:
    text = text.strip()
    if allow_missing and text.lower() in ("", "nan", "na"):
        return float("nan")
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{column} is {text!r}; expected a number", source=source,
                         line=line) from None
    if allow_missing and math.isinf(value):
        raise InputError(f"{column} is infinite", source=source, line=line)
    return value
