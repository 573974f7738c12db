"""The tool options of ``import``: ``--tool KIND:R=RADIUS`` or ``surface:FILE,units=UNIT``
(:func:`tool_option`) and how ``--tool-path`` (a CSV or a C3D rigid body) and
``--tool-force`` are read (:func:`tool_reader`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["tool_option", "tool_reader", "surface_file", "surface_tool", "TOOLS", "AXES",
           "axis_of"]

#: ``--tool`` kinds and their classes' names
TOOLS = {"sphere": "Sphere", "punch": "FlatPunch", "surface": "SurfaceTool"}

#: the axes a scan's "up" may be
AXES = ("x", "y", "z", "-x", "-y", "-z")


def axis_of(up: str) -> tuple[int, float]:
    """``(index, sign)`` of an ``--up`` axis."""
    if up not in AXES:
        raise InputError(f"got {up!r}; expected one of {', '.join(AXES)}", key="--up")
    return "xyz".index(up[-1]), -1.0 if up.startswith("-") else 1.0


def tool_option(text: str, up: str):
    """The tool of ``--tool KIND:R=RADIUS`` (``sphere:R=5mm``, ``punch:R=2mm``; m, cm or mm,
    metres without a unit; a punch's axis points along ``up``) or ``surface:FILE,units=mm``
    (:func:`surface_tool`)."""
    from ..markers.units import LENGTH_UNITS
    from ..simulation import contact

    kind, _, rest = text.partition(":")
    if kind == "surface":
        return surface_tool(rest)
    key, _, value = rest.partition("=")
    number, unit = _unit_suffix(value)
    try:
        radius = float(number) * (LENGTH_UNITS[unit] if unit else 1.0)
    except ValueError:
        radius = None
    if kind not in TOOLS or key.strip().upper() != "R" or radius is None:
        raise InputError(f"got {text!r}; expected KIND:R=RADIUS with KIND sphere or punch "
                         "(e.g. sphere:R=5mm), or surface:FILE,units=mm", key="--tool")
    if kind == "sphere":
        return contact.Sphere(radius)
    index, sign = axis_of(up)
    return contact.FlatPunch(radius, tuple(sign * np.eye(3)[index]))


def _unit_suffix(text: str) -> tuple[str, str | None]:
    """``("5", "mm")`` of ``"5mm"``: the text before a length unit it ends with, and that unit
    (None without one)."""
    from ..markers.units import LENGTH_UNITS

    text = text.strip()
    unit = next((u for u in sorted(LENGTH_UNITS, key=len, reverse=True) if text.endswith(u)),
                None)
    return (text[:-len(unit)] if unit else text), unit


def surface_file(tool: str) -> str | None:
    """The file of ``--tool surface:FILE,units=UNIT`` (None for another tool)."""
    return tool.partition(":")[2].rpartition(",units=")[0] if tool.startswith(
        "surface:") else None


def tool_reader(args):
    """How ``--tool-path`` is read: a ``step,x,y,z…`` CSV, or a C3D rigid body with
    ``--tool-frames`` and ``--tool-tip`` (:func:`~neurofuzzy.markers.steps.read_tool_c3d`);
    with ``--tool-force``, the load cell's force from that file
    (:func:`~neurofuzzy.markers.tool_force.read_tool_force`)."""
    read = _tool_path_reader(args)
    if not getattr(args, "tool_force", None):
        return read

    def with_force(file, **options):
        from dataclasses import replace

        from ..markers.tool_force import read_tool_force

        path = read(file, **options)
        if path.force is not None:
            raise InputError("gives the tool's force in its fx, fy, fz columns and "
                             "--tool-force gives it again: keep one load cell",
                             source=str(file), key="--tool-force")
        return replace(path, force=read_tool_force(
            args.tool_force, n_steps=path.displacement.shape[0] - 1))

    return with_force


def _tool_path_reader(args):
    """:func:`tool_reader` without ``--tool-force``."""
    from functools import partial

    from ..markers.steps import read_tool_c3d, read_tool_path
    from ..markers.units import LENGTH_UNITS

    c3d = Path(args.tool_path).suffix.lower() == ".c3d"
    given = [o for o in ("tool_frames", "tool_tip", "tool_markers") if getattr(args, o)]
    if not c3d:
        if given:
            raise InputError(f"--{given[0].replace('_', '-')} belongs to a C3D tool path "
                             "(--tool-path TOOL.c3d)", key=f"--{given[0].replace('_', '-')}")
        return read_tool_path
    for option in ("tool_frames", "tool_tip"):
        if not getattr(args, option):
            raise InputError("a C3D tool path needs --tool-frames (the frame of each scan) "
                             "and --tool-tip (the tool's reference point there, X,Y,Zmm)",
                             key=f"--{option.replace('_', '-')}")
    numbers, unit = _unit_suffix(args.tool_tip)
    try:
        tip = [float(v) for v in numbers.split(",")]
        frames = [int(v) for v in args.tool_frames.split(",")]
    except ValueError:
        tip, frames = [], []
    if unit is None or len(tip) != 3 or not np.all(np.isfinite(tip)) or not frames:
        raise InputError(f"got --tool-tip {args.tool_tip!r} --tool-frames "
                         f"{args.tool_frames!r}; expected X,Y,Z with a unit (10,10,25mm) and "
                         "frame numbers (0,120,240)", key="--tool-tip")
    markers = args.tool_markers.split(",") if args.tool_markers else None
    return partial(read_tool_c3d, frames=frames, markers=markers,
                   tip=np.array(tip) * LENGTH_UNITS[unit])


def surface_tool(text: str):
    """The :class:`~neurofuzzy.simulation.contact.SurfaceTool` of ``FILE,units=UNIT``: a
    closed triangle surface read by trimesh (STL, OBJ, PLY, OFF …) in the length unit given,
    which no such file states."""
    import trimesh

    from ..markers.units import LENGTH_UNITS
    from ..simulation.contact import SurfaceTool

    file, unit = surface_file("surface:" + text), text.rpartition(",units=")[2]
    if not file or unit not in LENGTH_UNITS:
        raise InputError(f"got surface:{text}; expected surface:FILE,units=UNIT with UNIT one "
                         f"of {', '.join(LENGTH_UNITS)}: a surface file states no unit, and "
                         "it is never guessed", key="--tool")
    if not Path(file).is_file():
        raise InputError("no such file", source=file, key="--tool")
    try:
        surface = trimesh.load(file, force="mesh")          # an STL's corners merged
        vertices, faces = np.asarray(surface.vertices), np.asarray(surface.faces)
    except Exception as error:   # trimesh raises what its format's reader raises
        raise InputError(f"not a readable triangle surface ({type(error).__name__}: "
                         f"{error})", source=file, key="--tool") from None
    try:
        return SurfaceTool(vertices * LENGTH_UNITS[unit], faces)
    except InputError as error:
        raise InputError(error.detail, source=file, key="--tool") from None


