"""Files of load-step experiments: scans of markers at a few load steps
(``step,marker,x,y,z``) and the driven plate's displacement (and a load cell's force) per step
(``step,dx,dy,dz[,fx,fy,fz]``). Units are stated in ``# length units:`` and
``# force units:`` lines (or given as options), never assumed; docs/formats.md has the
layouts."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .csvtable import number, read_csv_table
from .units import LENGTH_UNITS, check_statements, load_cell_factor, unit_factor

__all__ = ["StepScans", "PlatePath", "read_step_markers", "read_plate", "read_tool_path",
           "read_tool_c3d", "RIGID_TOLERANCE",
           "has_step_column"]

_NO_UNIT = ("states no length unit: add a line '# length units: mm' (m, cm or mm) or pass "
            "--units")


@dataclass(frozen=True, eq=False)
class StepScans:
    """Marker positions at load steps.

    Attributes
    ----------
    names : tuple of str
    positions : (n_steps + 1, n_markers, 3) float
        Metres; step 0 the reference scan; NaN where a marker was not found.
    source : str
    """

    names: tuple
    positions: np.ndarray
    source: str


@dataclass(frozen=True, eq=False)
class PlatePath:
    """The driven plate per load step: ``displacement`` (n_steps, 3) m from rest and, where
    a load cell was read, ``force`` (n_steps, 3) N."""

    displacement: np.ndarray
    force: np.ndarray | None
    source: str
    orientations: np.ndarray | None = None


def has_step_column(path: str | os.PathLike) -> bool:
    """True when the CSV's header names a ``step`` column (a load-step file)."""
    try:
        header, _, _ = read_csv_table(Path(path), required=[])
    except InputError:
        return False
    return "step" in header


def _steps(header, rows, source) -> np.ndarray:
    """The ``step`` column as non-negative integers; a file with ``step`` and ``time`` is
    refused."""
    if "time" in header:
        raise InputError("has both a 'step' and a 'time' column: a file's frames are load "
                         "steps (equilibria) or times, not both", source=source)
    steps = []
    for line, row in rows:
        value = number(row[header["step"]], source, line, "step")
        if not math.isfinite(value) or value < 0 or value != int(value):
            raise InputError(f"step is {row[header['step']]!r}; expected 0, 1, 2, … (0 the "
                             "reference)", source=source, line=line)
        steps.append(int(value))
    return np.array(steps, int)


def read_step_markers(path: str | os.PathLike, *, units: str | None = None) -> StepScans:
    """Read a ``step,marker,x,y,z`` CSV: step 0 the reference scan (every marker in it), then
    steps 1, 2, … without a gap."""
    path = Path(path)
    source = str(path)
    header, rows, stated = read_csv_table(path, required=[("step",), ("marker",), ("x",),
                                                         ("y",), ("z",)])
    check_statements(stated, ("units", "length units"), source)
    unit = unit_factor(LENGTH_UNITS, what="length", stated=stated,
                       keys=("units", "length units"), source=source, given=units,
                       given_as="--units", missing=_NO_UNIT)
    if not rows:
        raise InputError("no data rows", source=source)
    steps = _steps(header, rows, source)
    names = [row[header["marker"]].strip() for _, row in rows]
    for name, (line, _) in zip(names, rows):
        if not name:
            raise InputError("empty marker name", source=source, line=line)
    present = np.unique(steps)
    if present[0] != 0 or not np.array_equal(present, np.arange(len(present))):
        raise InputError(f"has the steps {present.tolist()}; expected 0 (the reference scan), "
                         "1, 2, … without a gap", source=source)
    if len(present) < 2:
        raise InputError("has only the reference scan (step 0); a fit needs load steps too",
                         source=source)
    marker_names, first = np.unique(np.asarray(names), return_index=True)
    marker_names = marker_names[np.argsort(first, kind="stable")]
    index = {name: i for i, name in enumerate(marker_names)}
    positions = np.full((len(present), len(marker_names), 3), np.nan)
    for (line, row), step, name in zip(rows, steps, names):
        if np.isfinite(positions[step, index[name]]).any():
            raise InputError(f"marker {name!r} appears twice at step {step}", source=source,
                             line=line)
        positions[step, index[name]] = [number(row[header[a]], source, line, a,
                                               allow_missing=True) * unit for a in "xyz"]
    missing = ~np.isfinite(positions[0]).all(axis=-1)
    if missing.any():
        raise InputError(f"marker {marker_names[np.argmax(missing)]!r} has no position in the "
                         "reference scan (step 0)", source=source)
    return StepScans(tuple(str(n) for n in marker_names), positions, source)


def read_plate(path: str | os.PathLike, *, n_steps: int | None = None,
               units: str | None = None) -> PlatePath:
    """Read a ``step,dx,dy,dz[,fx,fy,fz]`` CSV: the plate's displacement from rest at steps
    1..``n_steps`` (a step 0 row, if any, must be at rest) and the load cell's force;
    ``n_steps`` None: the file's last step (no scans to match)."""
    source = str(path)
    displacement, force, _ = _read_steps(path, ("dx", "dy", "dz"), n_steps, units, "plate")
    if np.isfinite(displacement[0]).all() and np.abs(displacement[0]).max() > 0:
        raise InputError("step 0 is the reference: its displacement must be 0 0 0",
                         source=source)
    return PlatePath(displacement[1:], None if force is None else force[1:], source)


def read_tool_path(path: str | os.PathLike, *, n_steps: int | None = None,
                   units: str | None = None) -> PlatePath:
    """Read a ``step,x,y,z[,qw,qx,qy,qz][,fx,fy,fz]`` CSV: an indenter's reference point (a
    sphere's centre, a punch's face centre) at the reference scan (step 0, required) and at
    steps 1..``n_steps``, its attitude as a tracker gives it (unit quaternions, scalar
    first; normalised here) and its load cell's force (the force the tool exerts on the
    body); returned as a :class:`PlatePath` whose ``displacement`` holds the
    (n_steps + 1, 3) positions and ``orientations`` the (n_steps + 1, 4) attitudes."""
    source = str(path)
    positions, force, turns = _read_steps(path, ("x", "y", "z"), n_steps, units, "tool",
                                          attitude=True)
    if not np.isfinite(positions[0]).all():
        raise InputError("has no step 0 row: the tool's position at the reference scan is "
                         "where it starts", source=source)
    return PlatePath(positions, None if force is None else force[1:], source, turns)


#: how far (m, RMS over the markers) a tracked tool's markers may stray from one rigid
#: motion of their cluster at a chosen frame before the file is refused: a tracker's own
#: noise is a tenth of a millimetre or less
RIGID_TOLERANCE = 0.5e-3


def read_tool_c3d(path: str | os.PathLike, *, frames, tip, markers=None,
                  units: str | None = None, n_steps: int | None = None) -> PlatePath:
    """A tracked tool's pose at each load step from a C3D recording of the markers fixed to
    it (a rigid body): :class:`PlatePath` as :func:`read_tool_path` gives it, positions and
    attitudes, no force.

    Parameters
    ----------
    path : path-like
        The C3D file (its ``POINT:UNITS``, or ``units``).
    frames : sequence of int
        The file's frame (0 its first) at the reference scan and at each load step.
    tip : (3,) float
        The tool's reference point (a sphere's centre, a punch's face centre, a surface
        tool's origin) at the reference scan's frame, in the recording's coordinates (m).
        The tool's own frame is the world's there: at each step the cluster's rigid motion
        from that frame (the least-squares one over the markers seen at both, SciPy's
        ``Rotation.align_vectors``) moves the point and turns the tool.
    markers : sequence of str, optional
        The labels of the tool's markers (default: every point of the file).
    n_steps : int, optional
        The scans' load steps, which ``frames`` must match.
    """
    from scipy.spatial.transform import Rotation

    from .readers import read_c3d

    source = str(path)
    data = read_c3d(path, units=units)
    names = list(data.names) if markers is None else list(markers)
    unknown = [name for name in names if name not in data.names]
    if unknown:
        raise InputError(f"names no tool marker {unknown[0]!r}; the file's points: "
                         f"{', '.join(data.names)}", source=source, key="--tool-markers")
    frames = [int(f) for f in frames]
    if n_steps is not None and len(frames) != n_steps + 1:
        raise InputError(f"got {len(frames)} frames; the scans have the reference and "
                         f"{n_steps} load steps, so {n_steps + 1} frames are needed",
                         source=source, key="--tool-frames")
    if len(frames) < 2 or min(frames) < 0 or max(frames) >= len(data.times):
        raise InputError(f"frames {frames}: needs the reference's and at least one load "
                         f"step's, each one of the file's 0..{len(data.times) - 1}",
                         source=source, key="--tool-frames")
    cluster = data.positions[:, [data.names.index(name) for name in names]][frames]
    tip = np.asarray(tip, float)
    positions, turns = [tip], [np.array([1.0, 0.0, 0.0, 0.0])]
    for step, frame in enumerate(frames[1:], start=1):
        seen = np.isfinite(cluster[0]).all(axis=1) & np.isfinite(cluster[step]).all(axis=1)
        before, after = cluster[0][seen], cluster[step][seen]
        if seen.sum() < 3 or np.linalg.matrix_rank(before - before.mean(axis=0),
                                                   tol=1e-9) < 2:
            raise InputError(f"frame {frame}: {int(seen.sum())} of the tool's markers are seen "
                             "there and at the reference's frame, not three apart in a "
                             "plane: its attitude cannot be told", source=source,
                             key="--tool-path")
        centre, centre_after = before.mean(axis=0), after.mean(axis=0)
        R = Rotation.align_vectors(after - centre_after, before - centre)[0].as_matrix()
        t = centre_after - R @ centre
        stray = float(np.sqrt(np.mean(np.sum((before @ R.T + t - after) ** 2, axis=1))))
        if stray > RIGID_TOLERANCE:
            raise InputError(f"frame {frame}: the tool's markers stray {1e3 * stray:.3g} mm "
                             f"(RMS) from one rigid motion, more than "
                             f"{1e3 * RIGID_TOLERANCE:g} mm: are they all on the tool?",
                             source=source, key="--tool-markers")
        positions.append(R @ tip + t)
        turns.append(Rotation.from_matrix(R).as_quat(scalar_first=True))
    return PlatePath(np.array(positions), None, source, np.array(turns))


def _read_steps(path, columns, n_steps, units, what, attitude=False):
    """``(values (n_steps + 1, 3) with NaN where a step has no row, force or None, attitude
    or None)`` of a per-step CSV of ``columns`` and optional ``fx,fy,fz`` (metres and
    newtons) and, with ``attitude``, ``qw,qx,qy,qz`` (unit quaternions)."""
    path = Path(path)
    source = str(path)
    header, rows, stated = read_csv_table(path, required=[("step", "time"),
                                                          *((c,) for c in columns)])
    if "step" not in header:
        raise InputError(f"has a 'time' column: a load-step experiment's {what} file gives "
                         "its place per 'step' (0 the reference)", source=source)
    unit, newton, turned = path_units(header, stated, source, units, attitude)
    steps = _steps(header, rows, source)
    if not rows:
        raise InputError("no data rows", source=source)
    if n_steps is None:
        n_steps = int(steps.max())
        if n_steps < 1:
            raise InputError("has only step 0; a fit needs load steps", source=source)
    values = np.full((n_steps + 1, 3), np.nan)
    force = np.full((n_steps + 1, 3), np.nan)
    turns = np.full((n_steps + 1, 4), np.nan) if turned else None
    for (line, row), step in zip(rows, steps):
        if step > n_steps:
            raise InputError(f"step {step} is not one of the scans' steps 0..{n_steps}",
                             source=source, line=line)
        if np.isfinite(values[step]).any():
            raise InputError(f"step {step} appears twice", source=source, line=line)
        values[step] = [number(row[header[c]], source, line, c) * unit for c in columns]
        if newton is not None:
            force[step] = [number(row[header[c]], source, line, c) * newton
                           for c in ("fx", "fy", "fz")]
        if turned:
            turns[step] = [number(row[header[c]], source, line, c) for c in QUATERNION]
            if not np.linalg.norm(turns[step]) > 1e-6:
                raise InputError(f"step {step}'s attitude qw, qx, qy, qz is zero or not "
                                 "finite: a unit quaternion is needed", source=source,
                                 line=line)
    absent = [s for s in range(1, n_steps + 1) if not np.isfinite(values[s]).all()]
    if absent:
        raise InputError(f"has no row for step(s) {absent}: the scans have steps 1..{n_steps}, "
                         f"and the {what}'s place is needed at each", source=source)
    if not np.all(np.isfinite(values[1:])) or (
            newton is not None and not np.all(np.isfinite(force[1:]))):
        raise InputError("a displacement or force is not finite", source=source)
    if turned:
        turns = turns / np.linalg.norm(turns, axis=1, keepdims=True)
    return values, None if newton is None else force, turns


#: a tool's attitude columns, a unit quaternion scalar first
QUATERNION = ("qw", "qx", "qy", "qz")


def has_attitude(header: dict, source: str) -> bool:
    """Whether a tool file gives its attitude: all of :data:`QUATERNION`, or none."""
    turned = any(c in header for c in QUATERNION)
    if turned and not all(c in header for c in QUATERNION):
        raise InputError("names some of qw, qx, qy, qz; a tool's attitude needs all four "
                         "(a unit quaternion, scalar first)", source=source)
    return turned


def path_units(header: dict, stated, source: str, units: str | None,
               attitude: bool) -> tuple[float, float | None, bool]:
    """``(metres per length unit, newtons per force unit or None, whether the attitude is
    given)`` of a plate's or tool's path file, per step or in time: its units lines (or
    ``--units``), never guessed, and its force and attitude columns all or none."""
    check_statements(stated, ("units", "length units", "force units"), source)
    unit = unit_factor(LENGTH_UNITS, what="length", stated=stated,
                       keys=("units", "length units"), source=source, given=units,
                       given_as="--units", missing=_NO_UNIT)
    return (unit, load_cell_factor(header, stated, source),
            attitude and has_attitude(header, source))
