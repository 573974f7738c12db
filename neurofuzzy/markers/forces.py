"""Force files: the load a recording was made under, by node number or at points of the
surface, checked against the recording (times) and the body (fixed nodes, its surface, its
size); :func:`write_node_forces` writes the node form with the mesh it was made for."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..mesh import mesh_fingerprint
from ..plausibility import extent, warn
from .csvtable import TIME_TOLERANCE, number, read_csv_table
from .units import (FORCE_UNITS, LENGTH_UNITS, TIME_UNITS, check_statements, unit_factor)

__all__ = ["read_forces", "write_node_forces", "force_file_form", "FORCE_STATEMENTS"]

#: the unit statements a force file may make
FORCE_STATEMENTS = ("force units", "length units", "time units", "units")
#: a share of a force on fixed nodes above this is worth a warning…
FIXED_SHARE_NOTED = 0.01
#: …and above this the force is lost: refused
FIXED_SHARE_REFUSED = 0.99

_COLUMNS = [("time",), ("node", "x"), ("fx",), ("fy",), ("fz",)]


class _Load(NamedTuple):
    """One row of a force file: from ``time`` on, ``value`` (N) shared by ``nodes`` with
    ``weight``; ``probe`` names what it replaces; ``point`` as written (point form)."""

    time: float
    probe: str
    nodes: np.ndarray
    weight: np.ndarray
    value: np.ndarray
    line: int
    point: np.ndarray | None = None


def force_file_form(path: str | os.PathLike) -> str:
    """``"node"`` for a ``time,node,fx,fy,fz`` file, ``"point"`` for ``time,x,y,z,…``."""
    header, _, _ = read_csv_table(Path(path), required=_COLUMNS)
    return "node" if "node" in header else "point"


def write_node_forces(path: str | os.PathLike, rows, mesh) -> Path:
    """Write a ``time,node,fx,fy,fz`` force file (newtons, seconds) that names the mesh it was
    made for (a ``# mesh:`` line, :func:`~neurofuzzy.mesh.mesh_fingerprint`), so that
    :func:`read_forces` refuses it on another mesh.

    Parameters
    ----------
    rows : iterable of (time, node, fx, fy, fz)
    mesh : Mesh
        The mesh whose node numbers the rows use.
    """
    path = Path(path)
    lines = [f"# mesh: {mesh_fingerprint(mesh)}", "time,node,fx,fy,fz"]
    lines += [f"{t:.6g},{int(node)},{fx:.6g},{fy:.6g},{fz:.6g}" for t, node, fx, fy, fz in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def read_forces(path: str | os.PathLike, *, times: np.ndarray, n_nodes: int | None = None,
                mesh=None, spread: int = 1, radius: float | None = None) -> np.ndarray:
    """Applied forces of a force CSV at the given frame times.

    Two forms, told apart by the header:

    - ``time,node,fx,fy,fz``: a node's force holds from its row's time until the next row of
      that node (zero before its first row). Node numbers belong to one mesh: a file made by
      :func:`write_node_forces` names it in a ``# mesh:`` line and is refused on another; a
      file without one is read with a warning. Forces at points are the recommended form.
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
      ``# length units: mm`` (m, cm or mm).

    Units: forces in newtons unless a line ``# force units: mN`` (N, mN, kN) says otherwise,
    times in seconds unless ``# time units: ms`` (s, ms, us). A unit statement this reader
    does not know is refused, never ignored.

    Refused (naming FILE:LINE): a point farther from the surface than the mesh's longest
    edge, a force that acts only on fixed nodes (where it never acts), a contact radius larger
    than the body, loads that all start after the recording ends; a ``radius`` for a
    node-numbered file. Warned about: a share of a force on fixed nodes, rows after the end.

    Parameters
    ----------
    times : (n_frames,) float
        Frame times (seconds, on the file's clock).
    n_nodes : int, optional
        Number of nodes (node form; taken from ``mesh`` when given).
    mesh : Mesh, optional
        The model's mesh; required for the point form and for the checks against fixed
        nodes and the mesh's fingerprint.
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
    header, rows, stated = read_csv_table(path, required=_COLUMNS)
    check_statements(stated, FORCE_STATEMENTS + ("mesh",), source)
    point_form = "node" not in header
    newtons = _force_unit(stated, source, point_form)
    seconds = unit_factor(TIME_UNITS, what="time", stated=stated, keys=("time units",),
                          source=source, default="s")
    times = np.asarray(times, float)
    period = float(np.median(np.diff(times))) if len(times) > 1 else 1.0
    if point_form:
        entries = _point_entries(header, rows, stated, source, mesh, spread, radius)
    else:
        if radius is not None:
            raise InputError("a contact radius (--probe-radius) applies to forces at points "
                             "(time,x,y,z,fx,fy,fz); this file names nodes", source=source,
                             key="radius")
        entries = _node_entries(header, rows, stated, source, n_nodes, mesh)
    entries = [entry._replace(time=seconds * entry.time, value=newtons * entry.value)
               for entry in entries]
    _check_times(entries, times, period, source)
    if mesh is not None:
        _check_fixed(entries, mesh, source, stated)
    forces = np.zeros((len(times), n_nodes, 3))
    entries.sort(key=lambda entry: entry.time)        # stable: file order within a time
    acting: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for time, probe, nodes, weight, value, _, _ in entries:
        start = np.searchsorted(times, time - TIME_TOLERANCE * period)
        if probe in acting:                           # the probe's previous row stops here
            old_nodes, old_load = acting[probe]
            np.add.at(forces[start:], (slice(None), old_nodes), -old_load)
        load = weight[:, None] * value
        np.add.at(forces[start:], (slice(None), nodes), load)
        acting[probe] = (nodes, load)
    return forces


def _force_unit(stated, source: str, point_form: bool) -> float:
    keys = ["force units"]
    if "units" in stated:
        value = stated["units"].strip()
        if value.lower() in (u.lower() for u in LENGTH_UNITS):
            raise InputError(f"'# units: {value}' is ambiguous in a force file: write "
                             f"'# length units: {value}' for the points' coordinates"
                             + ("" if point_form else " (this file names nodes and has none)")
                             + " and '# force units: N' for the forces",
                             source=source, line=stated.line_of("units"))
        keys.append("units")
    return unit_factor(FORCE_UNITS, what="force", stated=stated, keys=tuple(keys),
                       source=source, default="N")


def _value(row, header, source: str, line: int, time: float) -> np.ndarray:
    value = [number(row[header[key]], source, line, key) for key in ("fx", "fy", "fz")]
    if not (math.isfinite(time) and all(map(math.isfinite, value))):
        raise InputError("NaN or infinite value; every force row needs numbers",
                         source=source, line=line)
    return np.array(value)


def _node_entries(header, rows, stated, source, n_nodes, mesh) -> list:
    if mesh is not None:
        _check_fingerprint(stated, mesh, source)
    entries = []
    for line, row in rows:
        time = number(row[header["time"]], source, line, "time")
        node = row[header["node"]].strip()
        if not re.fullmatch(r"\d+", node) or int(node) >= n_nodes:
            raise InputError(f"node {node!r} is not a node index of this model (0.."
                             f"{n_nodes - 1})", source=source, line=line)
        entries.append(_Load(time, f"node {int(node)}", np.array([int(node)]), np.ones(1),
                             _value(row, header, source, line, time), line))
    return entries


def _check_fingerprint(stated, mesh, source: str) -> None:
    """Node numbers belong to one mesh: refuse a file made for another."""
    this = mesh_fingerprint(mesh)
    points = ("give the forces at points instead (time,x,y,z,fx,fy,fz with a "
              "'# length units: mm' line), which fit any mesh of the body")
    if "mesh" not in stated:
        warn(f"{source}: forces by node number, with no '# mesh:' line naming the mesh they "
             f"were made for: node numbers change when a body is re-meshed, so check they "
             f"are this model's (add '# mesh: {this}'), or {points}")
        return
    if stated["mesh"].strip() != this:
        raise InputError(f"these forces by node number were made for another mesh "
                         f"('# mesh: {stated['mesh'].strip()}'; this model's mesh is "
                         f"'{this}'): node numbers change when a body is re-meshed, so the "
                         f"forces would act on other nodes; {points}", source=source,
                         line=stated.line_of("mesh"))


def _point_entries(header, rows, stated, source, mesh, spread, radius) -> list:
    """The ``time,x,y,z,fx,fy,fz`` form: where each point's force goes."""
    from ..mesh import patch_weights, surface_nodes

    for column in ("y", "z"):
        if column not in header:
            raise InputError(f"missing column {column!r}; a point force needs x,y,z",
                             source=source)
    if mesh is None:
        raise InputError("forces at points (x,y,z) need the model's mesh", source=source)
    scale = unit_factor(LENGTH_UNITS, what="length", stated=stated, keys=("length units",),
                        source=source, missing="the points' length unit is not stated; add a "
                        "line '# length units: mm' (m, cm or mm)")
    if not (isinstance(spread, (int, np.integer)) and spread >= 1):
        raise InputError(f"got {spread!r}; expected a positive number of nodes",
                         key="spread")
    surface = np.flatnonzero(surface_nodes(mesh))
    rest = mesh.rest_positions[surface]
    reach = float(mesh.rest_lengths.max()) if mesh.n_springs else np.inf
    body = extent(mesh.rest_positions)
    spread = min(int(spread), len(surface))
    if radius is not None:
        if not (np.isfinite(radius) and radius >= 0):
            raise InputError(f"got {radius!r}; expected a contact radius >= 0 (m)",
                             key="radius")
        if "radius" in header:
            raise InputError(f"the file has a radius column and a contact radius "
                             f"(--probe-radius {radius:g}) is given too; give it once",
                             source=source, key="radius")
        _check_radius(radius, body, source, None, "--probe-radius")
    entries = []
    for line, row in rows:
        time = number(row[header["time"]], source, line, "time")
        point = np.array([number(row[header[key]], source, line, key) for key in "xyz"])
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
            contact = scale * number(row[header["radius"]], source, line, "radius")
            if not (math.isfinite(contact) and contact >= 0):
                raise InputError(f"radius {row[header['radius']]!r}: expected a contact "
                                 "radius >= 0", source=source, line=line)
            _check_radius(contact, body, source, line, "radius")
        if contact is None:
            weight = 1.0 / np.maximum(distance[nearest], 1e-12 * reach)
            nodes, weight = surface[nearest], weight / weight.sum()
        else:
            shares = patch_weights(mesh, scale * point, contact)
            nodes = np.flatnonzero(shares)
            weight = shares[nodes]
        probe = row[header["probe"]].strip() if "probe" in header else ""
        entries.append(_Load(time, probe, nodes, weight,
                             _value(row, header, source, line, time), line, point))
    return entries


def _check_radius(radius: float, body: float, source: str, line, name: str) -> None:
    """A probe wider than the body presses on all of it, fixed nodes included."""
    if body > 0 and radius > body:
        raise InputError(f"a contact radius of {radius:.3g} m ({name}) is larger than the "
                         f"body ({body:.3g} m across): the probe would press on the whole "
                         "surface, the fixed nodes included; give the probe's contact radius "
                         "(in metres for --probe-radius, in the file's length unit for the "
                         "column)", source=source, line=line,
                         key="radius" if line is None else None)


def _check_times(entries, times, period, source) -> None:
    """Loads that start after the last frame never act: all of them is a unit mistake."""
    if not len(times):
        return
    end = times[-1] + TIME_TOLERANCE * period
    loads = [entry for entry in entries if np.any(entry.value)]
    late = [entry for entry in loads if entry.time > end]
    if not late:
        return
    first = min(late, key=lambda entry: entry.time)
    said = (f"this force starts at {first.time:.4g} s, after the recording ends (its last "
            f"frame is at {times[-1]:.4g} s)")
    if len(late) == len(loads):
        raise InputError(f"{said}, and so does every other: no load would act. Were the "
                         "times written in milliseconds? Times are in seconds; state "
                         "'# time units: ms' or convert them", source=source, line=first.line)
    warn(f"{source}:{first.line}: {said}; {len(late)} of {len(loads)} force rows never act")


def _check_fixed(entries, mesh, source, stated) -> None:
    """A force on fixed nodes never acts: refuse a load that acts only there, say so when a
    share of one does."""
    fixed = np.zeros(mesh.n_nodes, bool)
    fixed[mesh.fixed] = True
    noted = []
    for entry in entries:
        if not np.any(entry.value):
            continue
        share = float(np.sum(entry.weight[fixed[entry.nodes]]))
        if share >= FIXED_SHARE_REFUSED:
            nodes = entry.nodes[fixed[entry.nodes]].tolist()
            if entry.point is None:
                raise InputError(f"node {nodes[0]} is fixed: a force there never acts; check "
                                 "the node numbers (or give the forces at points)",
                                 source=source, line=entry.line)
            raise InputError(f"the point ({', '.join(f'{c:g}' for c in entry.point)}) lies "
                             f"on fixed nodes only ({', '.join(map(str, nodes[:6]))}"
                             + ("" if share > 1 - 1e-9 else f": {share:.1%} of its force")
                             + "), where a force never acts; check the coordinates and their "
                             "unit "
                             f"('# length units: {stated.get('length units', '?')}')"
                             + _unit_hint(entry.point, mesh, fixed,
                                          stated.get("length units", "")), source=source,
                             line=entry.line)
        if share >= FIXED_SHARE_NOTED:
            noted.append((share, entry.line))
    if noted:
        share, line = max(noted)
        warn(f"{source}:{line}: {100 * share:.0f} % of this force falls on fixed nodes, "
             "where it never acts" + (f" ({len(noted)} rows like it)" if len(noted) > 1
                                      else ""))


def _unit_hint(point: np.ndarray, mesh, fixed: np.ndarray, current: str) -> str:
    """"; in m it would be on the surface, on free nodes" when another length unit puts the
    point next to a free surface node."""
    from ..mesh import surface_nodes

    surface = np.flatnonzero(surface_nodes(mesh))
    reach = float(mesh.rest_lengths.max()) if mesh.n_springs else 0.0
    for name, factor in LENGTH_UNITS.items():
        if name == current.strip():
            continue
        gaps = np.linalg.norm(mesh.rest_positions[surface] - factor * point, axis=1)
        nearest = int(np.argmin(gaps))
        if gaps[nearest] <= reach and not fixed[surface[nearest]]:
            return (f"; with '# length units: {name}' it would touch the surface on free "
                    "nodes")
    return ""
