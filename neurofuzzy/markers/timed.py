"""Paths in time: a plate's (``time,dx,dy,dz[,fx,fy,fz]``, the stage's displacement from rest)
and a tool's (``time,x,y,z[,qw,qx,qy,qz][,fx,fy,fz]``, its reference point and attitude), each
with a load cell's force, sampled at their own times, read at a marker recording's frames.

The same layouts as the load-step files (:func:`~.steps.read_plate`,
:func:`~.steps.read_tool_path`) with a ``time`` column (seconds) instead of ``step``; units
are stated in ``# length units:`` and ``# force units:``
lines (or ``--units`` for lengths), never assumed. The stage and the load cell usually run
faster than the cameras: each is read at the recording's frame times by linear
interpolation between its two nearest samples, and a frame outside the file's span is an
error rather than a guess.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from .csvtable import number, read_csv_table
from .steps import QUATERNION, path_units

__all__ = ["read_plate_in_time", "read_tool_in_time"]

#: a frame this close to the file's first or last time (s, relative to its span) is inside
TIME_TOLERANCE = 1e-9


def read_plate_in_time(path: str | os.PathLike, times: np.ndarray, *,
                       units: str | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """``(displacement (n_frames, 3) m, force (n_frames, 3) N or None)`` of a
    ``time,dx,dy,dz[,fx,fy,fz]`` CSV at the recording's frame ``times`` (s, on the file's
    clock; module docstring)."""
    values, force, _ = _read_in_time(path, times, ("dx", "dy", "dz"), units, "plate")
    return values, force


def read_tool_in_time(path: str | os.PathLike, times: np.ndarray, *,
                      units: str | None = None):
    """``(positions (n_frames, 3) m, force (n_frames, 3) N or None, attitudes (n_frames, 4)
    or None)`` of a ``time,x,y,z[,qw,qx,qy,qz][,fx,fy,fz]`` CSV at the frame ``times``:
    a tool's reference point, its force on the body and its attitude (unit quaternions, scalar
    first, each frame's the normalised blend of the two nearest samples')."""
    return _read_in_time(path, times, ("x", "y", "z"), units, "tool", attitude=True)


def _read_in_time(path, times, columns, units, what, attitude=False):
    source = str(path)
    header, rows, stated = read_csv_table(Path(path), required=[("time", "step"),
                                                                *((c,) for c in columns)])
    if "step" in header:
        raise InputError(f"has a 'step' column: a recording in time needs the {what}'s place "
                         "per 'time' (seconds); load steps go with scans at load steps",
                         source=source)
    unit, newton, turned = path_units(header, stated, source, units, attitude)
    if len(rows) < 2:
        raise InputError("needs at least two rows (times)", source=source)
    clock, values, force, turns = [], [], [], []
    for line, row in rows:
        clock.append(number(row[header["time"]], source, line, "time"))
        values.append([number(row[header[c]], source, line, c) * unit for c in columns])
        if newton is not None:
            force.append([number(row[header[c]], source, line, c) * newton
                          for c in ("fx", "fy", "fz")])
        if turned:
            turn = np.array([number(row[header[c]], source, line, c) for c in QUATERNION])
            if not np.linalg.norm(turn) > 1e-6:
                raise InputError(f"the attitude qw, qx, qy, qz at {clock[-1]:g} s is zero or "
                                 "not finite: a unit quaternion is needed", source=source,
                                 line=line)
            turn = turn / np.linalg.norm(turn)
            turns.append(-turn if turns and turn @ turns[-1] < 0 else turn)   # one sign
        if len(clock) > 1 and not clock[-1] > clock[-2]:
            raise InputError(f"time {clock[-1]:g} s does not follow {clock[-2]:g} s: the "
                             "times must increase", source=source, line=line)
    clock = np.array(clock)
    if not (np.all(np.isfinite(values)) and np.all(np.isfinite(force))):
        raise InputError(f"a {'displacement' if what == 'plate' else 'position'} or force is "
                         "not finite", source=source)
    at_frames = sampler(clock, times, source, f"the {what}'s place")

    if turned:
        turns = at_frames(turns)
        turns = turns / np.linalg.norm(turns, axis=1, keepdims=True)
    return (at_frames(values), None if newton is None else at_frames(force),
            turns if turned else None)


def sampler(clock: np.ndarray, times, source: str, what: str):
    """A function reading (n_samples, k) samples taken at ``clock`` (s, increasing) at the
    frame ``times`` by linear interpolation; an :class:`InputError` naming ``what`` when the
    file's span does not cover every frame."""
    times = np.asarray(times, float)
    slack = TIME_TOLERANCE * (clock[-1] - clock[0])
    if times[0] < clock[0] - slack or times[-1] > clock[-1] + slack:
        raise InputError(f"covers {clock[0]:g} to {clock[-1]:g} s; the recording's frames run "
                         f"from {times[0]:g} to {times[-1]:g} s: {what} is needed at every "
                         "frame", source=source)
    times = np.clip(times, clock[0], clock[-1])

    def at_frames(samples):
        samples = np.asarray(samples, float)
        return np.stack([np.interp(times, clock, samples[:, k])
                         for k in range(samples.shape[1])], axis=1)

    return at_frames
