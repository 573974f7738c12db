"""Recordings in time whose body a stage moved: ``import MARKERS.csv --displacements
PLATE.csv`` (or ``--tool sphere:R=5mm --tool-path TOOL.csv``) with a ``time`` column
(:func:`moved_in_time`), and their ``fit`` through implicit steps
(:func:`~neurofuzzy.pipeline.moving.fit_moving_file`) and ``diagnose``
(:func:`~neurofuzzy.diagnosis.moving.diagnose_moving`)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..errors import InputError
from .common import (Outputs, mesh_check_option, only_time_series_diagnosis,
                     print_json, written)

__all__ = ["fit_moved", "diagnose_moved", "check_moving_options", "moved_in_time"]

#: ``fit`` options of the time-series fit that a fit through implicit steps has no use for
UNUSED = ("validate_on", "target", "dt", "reference_noise")


def fit_moved(args) -> int:
    """``fit`` of one experiment file with driven sets or a tool."""
    from ..io import save_model
    from ..pipeline.moving import fit_moving_file, moving_fit_report
    from .common import rule_base_for

    source, substeps = _one_recording(args)
    for option in UNUSED:
        if getattr(args, option, None):
            raise InputError("is not available for a recording whose body a stage moved (it is "
                             "fitted through implicit steps)",
                             key=f"--{option.replace('_', '-')}")
    with Outputs([source] + [Path(p) for p in (args.rules, args.start) if p]) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        say = (lambda text: print(text, file=sys.stderr)) if not args.quiet else None
        outcome = fit_moving_file(source, start=args.start,
                                  rules=rule_base_for(args.rules, args.tissue),
                                  tissue=args.tissue, law=args.law, substeps=substeps,
                                  mesh_check=mesh_check_option(args), progress=say)
        record, data = outcome.record, outcome.data
        if out:
            save_model(outcome.result.model, out)
        if report:
            moving_fit_report(outcome, report, substeps=substeps)
    if args.json:
        print_json(record)
        return 0
    markers = 0 if data.markers is None else data.markers.n_markers
    print(f"moved in time: {data.n_frames} frames of {data.dt:.4g} s, {markers} markers"
          + (", the load cell's force" if data.reaction is not None else ", no force"))
    print(f"  E = {record['youngs_modulus']:.4g} Pa, nu = {record['poisson_ratio']:.4f}, "
          f"viscosity = {record['viscosity']:.4g} Pa s ({record['scheme']} steps of "
          f"{record['step']:.3g} s, {record['evaluations']} evaluations: {record['reason']})")
    print(f"  markers: RMS {1e6 * record['marker_rms_error']:.3g} um"
          + ("" if record["force_rms_error"] is None else
             f"; force: RMS {1e3 * record['force_rms_error']:.3g} mN (noise "
             f"{1e3 * record['force_noise']:.3g} mN)"))
    check = record["mesh_check"]
    if check is not None:
        print(f"  on a fine mesh (from {check['elements'][0]} and {check['elements'][1]} "
              f"tetrahedra): E = {check['youngs_modulus']['extrapolated']:.4g} Pa, nu = "
              f"{check['poisson_ratio']['extrapolated']:.4f}, viscosity = "
              f"{check['viscosity']['extrapolated']:.4g} Pa s")
    elif record["mesh_check_skipped"]:
        print(f"  no mesh check: {record['mesh_check_skipped']}")
    for region, values in record["materials"].items():
        labels = values.get("labels", {})
        if labels:
            print(f"  {region}: " + ", ".join(f"{k} {v}" for k, v in labels.items()))
    for note in record["notes"]:
        print(f"  note: {note}")
    written(args.out, args.report)
    return 0


def diagnose_moved(args) -> int:
    """``diagnose`` of one experiment file with driven sets or a tool: plate slip or bonding,
    the law, each refitted through implicit steps."""
    from ..diagnosis import diagnose_data
    from ..io import load_experiment, save_model
    from .common import rule_base_for

    source, substeps = _one_recording(args)
    only_time_series_diagnosis(args, "a recording whose body a stage moved")
    with Outputs([source] + [Path(p) for p in (args.rules, args.start) if p]) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        data = load_experiment(source)
        result = diagnose_data(data, start=args.start,
                               rules=rule_base_for(args.rules, args.tissue),
                               tissue=args.tissue, law=getattr(args, "law", None),
                               substeps=substeps, max_effects=args.max_effects,
                               progress=not args.quiet)
        if out:
            save_model(result.after.model, out)
        if report:
            from ..pipeline.moving import moving_diagnosis_report

            moving_diagnosis_report(result, data, report, substeps=substeps)
    if args.json:
        print_json(result.to_dict())
    else:
        print(result.summary())
        written(args.out, args.report)
    return 0


def _one_recording(args) -> tuple[Path, int]:
    """``(the one experiment file, implicit steps per frame)`` of ``fit`` or ``diagnose`` of
    a moved recording: ``--substeps`` checked as everywhere, ``auto`` one step a frame."""
    from ..simulation import check_substeps

    if len(args.experiments) != 1:
        raise InputError("takes one recording of a plate or tool at a time",
                         key="EXPERIMENT.npz")
    substeps = check_substeps(args.substeps, "--substeps")
    return Path(args.experiments[0]), 1 if substeps == "auto" else substeps


def check_moving_options(args) -> None:
    """What may move the body of a recording in time: a plate (``--displacements``) or a
    tool (``--tool`` with a CSV ``--tool-path``), one of them; markers driving their nodes
    belong to load steps."""
    if args.drive_markers:
        raise InputError("drives nodes at load steps, which go with scans at load steps (a "
                         "marker CSV with a 'step' column); this recording is in time",
                         source=str(args.markers), key="--drive-markers")
    if args.tool_force and not args.tool:
        raise InputError("is a tool's load cell: give the tool too (--tool KIND:R=RADIUS "
                         "--tool-path PATH.csv)", key="--tool-force")
    if bool(args.tool) != bool(args.tool_path):
        missing = "--tool-path" if args.tool else "--tool"
        raise InputError(f"a tool needs both --tool KIND:R=RADIUS and --tool-path PATH.csv; "
                         f"{missing} is missing", key=missing)
    if args.tool and args.displacements:
        raise InputError("a recording in time is moved by a plate or by a tool, one of them "
                         "(the load cell reads it)", key="--tool")
    if args.tool_path and Path(args.tool_path).suffix.lower() == ".c3d":
        raise InputError("a C3D tool path is read at load steps (--tool-frames); in time give "
                         "time,x,y,z[,qw,qx,qy,qz][,fx,fy,fz]", key="--tool-path")


def moved_in_time(args, experiment, summary):
    """``experiment`` moved by the plate file ``--displacements`` (its top face driven) or
    the tool of ``--tool`` along ``--tool-path`` (each a ``time`` column, read at the frames'
    times), with its load cell's force, if any."""
    from ..markers.timed import read_plate_in_time, read_tool_in_time
    from ..paths import DrivenPath, ToolPath
    from .steps import top_face
    from .tools import tool_option

    mesh = experiment.mesh
    if mesh.tetrahedra is None:
        raise InputError("a plate or a tool presses a body of elements: make the model with "
                         "'neurofuzzy mesh --elements tetra'", source=str(args.topology),
                         key="--displacements" if args.displacements else "--tool")
    times = summary["start_time"] + experiment.dt * np.arange(experiment.n_frames)
    if args.tool:
        tool = tool_option(args.tool, args.up)
        positions, force, turns = read_tool_in_time(args.tool_path, times, units=args.units)
        if args.tool_force:
            from ..markers.tool_force import read_tool_force

            if force is not None:
                raise InputError("gives the tool's force in its fx, fy, fz columns and "
                                 "--tool-force gives it again: keep one load cell",
                                 source=str(args.tool_path), key="--tool-force")
            force = read_tool_force(args.tool_force, times=times)
        name = args.tool.partition(":")[0]
        summary.update(moved_by=f"the {name}", load_cell=force is not None)
        return experiment.replace(tool=ToolPath(tool, positions, name=name,
                                                orientations=turns), reaction=force)
    displacement, force = read_plate_in_time(args.displacements, times, units=args.units)
    nodes = mesh.driven if mesh.driven.size else top_face(mesh, args.up)
    components = "xyz" if args.plate == "bonded" else args.up[-1]
    summary.update(driven_nodes=int(len(nodes)), plate=args.plate, load_cell=force is not None,
                   moved_by=f"the top plate ({len(nodes)} nodes, {args.plate})")
    return experiment.replace(driven=(DrivenPath(nodes, displacement, components,
                                                 "top plate"),), reaction=force)
