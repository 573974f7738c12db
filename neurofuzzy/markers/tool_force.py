"""A tool's load cell in a file of its own: ``step,fx,fy,fz`` (load steps) or ``time,fx,fy,fz``
(a recording in time) with a ``# force units:`` line (``import --tool-force FORCE.csv``).

A tracked instrument's path often comes from one system (a navigation system's C3D recording,
a robot's log) and its force from another (the load cell's own logger): the force file gives
the force the tool exerts on the body, as the ``fx,fy,fz`` columns of a tool path file would
(:func:`~.steps.read_tool_path`). Per step, every step 1..n needs a row (a step 0 row, the
tool clear of the body, is allowed and not used); in time, the load cell usually runs faster
than the cameras and is read at the frames' times by linear interpolation, as a path in time
is (:mod:`.timed`), a frame outside its span an error.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from .csvtable import number, read_csv_table
from .timed import sampler
from .units import load_cell_factor

__all__ = ["read_tool_force"]

COLUMNS = ("fx", "fy", "fz")


def read_tool_force(path: str | os.PathLike, *, n_steps: int | None = None,
                    times: np.ndarray | None = None) -> np.ndarray:
    """The force (N) the tool exerts on the body: ``(n_steps, 3)`` at load steps
    1..``n_steps`` of a ``step,fx,fy,fz`` CSV, or ``(len(times), 3)`` at the frame ``times``
    (s) of a ``time,fx,fy,fz`` one (module docstring); one of ``n_steps`` and ``times``."""
    source = str(path)
    header, rows, stated = read_csv_table(Path(path), required=[("step", "time"),
                                                                *((c,) for c in COLUMNS)])
    newton = load_cell_factor(header, stated, source)
    if not rows:
        raise InputError("no data rows", source=source)
    if times is None:
        if "step" not in header:
            raise InputError("has a 'time' column: load steps need the load cell's force per "
                             "'step' (1..n, as the scans)", source=source)
        return _per_step(header, rows, newton, int(n_steps), source)
    if "time" not in header:
        raise InputError("has a 'step' column: a recording in time needs the load cell's force "
                         "per 'time' (seconds)", source=source)
    return _in_time(header, rows, newton, np.asarray(times, float), source)


def _force(row, header, newton, source, line) -> list:
    values = [number(row[header[c]], source, line, c) * newton for c in COLUMNS]
    if not np.all(np.isfinite(values)):
        raise InputError("a force is not finite", source=source, line=line)
    return values


def _per_step(header, rows, newton, n_steps, source) -> np.ndarray:
    force = np.full((n_steps + 1, 3), np.nan)
    for line, row in rows:
        value = number(row[header["step"]], source, line, "step")
        step = int(value)
        if step != value or not 0 <= step <= n_steps:
            raise InputError(f"step {value:g} is not one of the tool path's steps 0..{n_steps}",
                             source=source, line=line)
        if np.isfinite(force[step]).any():
            raise InputError(f"step {step} appears twice", source=source, line=line)
        force[step] = _force(row, header, newton, source, line)
    absent = [s for s in range(1, n_steps + 1) if not np.isfinite(force[s]).all()]
    if absent:
        raise InputError(f"has no row for step(s) {absent}: the tool path has steps "
                         f"1..{n_steps}, and the load cell's force is needed at each",
                         source=source)
    return force[1:]


def _in_time(header, rows, newton, times, source) -> np.ndarray:
    clock, force = [], []
    for line, row in rows:
        clock.append(number(row[header["time"]], source, line, "time"))
        if len(clock) > 1 and not clock[-1] > clock[-2]:
            raise InputError(f"time {clock[-1]:g} s does not follow {clock[-2]:g} s: the "
                             "times must increase", source=source, line=line)
        force.append(_force(row, header, newton, source, line))
    if len(clock) < 2:
        raise InputError("needs at least two rows (times)", source=source)
    return sampler(np.array(clock), times, source, "the load cell's force")(force)
