"""A plate's path in time (``time,dx,dy,dz[,fx,fy,fz]``): the stage's displacement from rest
and a load cell's force, sampled at their own times, read at a marker recording's frames.

The same layout as a load-step plate file (:func:`~.steps.read_plate`) with a ``time`` column
(seconds) instead of ``step``; units are stated in ``# length units:`` and ``# force units:``
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
from .units import LENGTH_UNITS, check_statements, load_cell_factor, unit_factor

__all__ = ["read_plate_in_time"]

#: a frame this close to the file's first or last time (s, relative to its span) is inside
TIME_TOLERANCE = 1e-9


def read_plate_in_time(path: str | os.PathLike, times: np.ndarray, *,
                       units: str | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """``(displacement (n_frames, 3) m, force (n_frames, 3) N or None)`` of a
    ``time,dx,dy,dz[,fx,fy,fz]`` CSV at the recording's frame ``times`` (s, on the file's
    clock; module docstring)."""
    source = str(path)
    header, rows, stated = read_csv_table(Path(path), required=[("time", "step"), ("dx",), ("dy",),
                                                          ("dz",)])
    if "step" in header:
        raise InputError("has a 'step' column: a recording in time needs the plate's place "
                         "per 'time' (seconds); load steps go with scans at load steps",
                         source=source)
    check_statements(stated, ("units", "length units", "force units"), source)
    unit = unit_factor(LENGTH_UNITS, what="length", stated=stated,
                       keys=("units", "length units"), source=source, given=units,
                       given_as="--units",
                       missing=("states no length unit: add a line '# length units: mm' (m, "
                                "cm or mm) or pass --units"))
    newton = load_cell_factor(header, stated, source)
    if len(rows) < 2:
        raise InputError("needs at least two rows (times)", source=source)
    clock, values, force = [], [], []
    for line, row in rows:
        clock.append(number(row[header["time"]], source, line, "time"))
        values.append([number(row[header[c]], source, line, c) * unit for c in ("dx", "dy",
                                                                                 "dz")])
        if newton is not None:
            force.append([number(row[header[c]], source, line, c) * newton
                          for c in ("fx", "fy", "fz")])
        if len(clock) > 1 and not clock[-1] > clock[-2]:
            raise InputError(f"time {clock[-1]:g} s does not follow {clock[-2]:g} s: the "
                             "times must increase", source=source, line=line)
    clock = np.array(clock)
    if not (np.all(np.isfinite(values)) and np.all(np.isfinite(force))):
        raise InputError("a displacement or force is not finite", source=source)
    times = np.asarray(times, float)
    slack = TIME_TOLERANCE * (clock[-1] - clock[0])
    if times[0] < clock[0] - slack or times[-1] > clock[-1] + slack:
        raise InputError(f"covers {clock[0]:g} to {clock[-1]:g} s; the recording's frames run "
                         f"from {times[0]:g} to {times[-1]:g} s: the plate's place is needed "
                         "at every frame", source=source)
    times = np.clip(times, clock[0], clock[-1])

    def at_frames(samples):
        samples = np.asarray(samples, float)
        return np.stack([np.interp(times, clock, samples[:, k]) for k in range(3)], axis=1)

    return at_frames(values), None if newton is None else at_frames(force)
