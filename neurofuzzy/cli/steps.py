"""The commands on load-step experiments (scans at a few compressions between plates):
``import SCANS.csv --displacements PLATE.csv`` writes a load-step file, ``fit STEPS.npz``
fits E and ν to it (:func:`neurofuzzy.learn.load_step_fit.fit_load_steps`)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..errors import InputError
from .common import (Outputs, mesh_check_option, only_time_series_diagnosis, positive,
                     print_json, written)
from .tools import axis_of, surface_file, tool_option, tool_reader

__all__ = ["import_load_steps", "import_indentation", "fit_load_steps", "diagnose_load_steps",
           "top_face"]


def top_face(mesh, up: str) -> np.ndarray:
    """The nodes of the face farthest along ``up`` (within a quarter of the shortest edge)."""
    index, sign = axis_of(up)
    height = sign * mesh.rest_positions[:, index]
    return np.flatnonzero(height >= height.max() - 0.25 * mesh.rest_lengths.min())


def _specimen(args, topology: Path):
    """``(mesh, scans or None)`` of a load-step import: the model file's tetrahedral mesh
    and the scans at load steps (``step,marker,x,y,z``)."""
    from ..io import load_model
    from ..markers.steps import read_step_markers

    if topology.suffix.lower() not in (".yaml", ".yml"):
        raise InputError("a load-step import needs the model (.yaml, from 'neurofuzzy mesh "
                         "--fix-bottom')", source=str(topology), key="--topology")
    mesh = load_model(topology).mesh
    if mesh.tetrahedra is None:
        raise InputError("has no tetrahedra: load steps are fitted with elements (neurofuzzy "
                         "mesh --elements tetra)", source=str(topology), key="--topology")
    return mesh, read_step_markers(args.markers, units=args.units) if args.markers else None


def _driver(read, file, option: str, what: str, args, mesh, scans):
    """``(the driver's per-step file read by read, the embedded markers or None)``; without
    scans the file must hold the load cell's force, all there is to fit then."""
    path = read(file, units=args.units,
                n_steps=None if scans is None else scans.positions.shape[0] - 1)
    if scans is None and path.force is None:
        raise InputError("without scans the load cell's force is all there is to fit: the "
                         f"{what} file needs fx,fy,fz (and a '# force units:' line)",
                         source=str(file), key=option)
    return path, None if scans is None else _embedded(mesh, scans, args.max_distance)


def import_load_steps(args) -> int:
    """``import`` of a ``step,marker,x,y,z`` file: the markers embedded in the topology's
    tetrahedra at the reference scan, the top face driven by the plate file."""
    from ..io.load_steps import save_load_steps
    from ..load_steps import DrivenPath, LoadSteps
    from ..markers.steps import read_plate

    drivers = [name.strip() for name in (args.drive_markers or "").split(",") if name.strip()]
    if args.tool or args.tool_path:
        return import_indentation(args)
    if getattr(args, "tool_force", None):
        raise InputError("is a tool's load cell; a plate's force goes in its own file's "
                         "fx,fy,fz columns", key="--tool-force")
    if not args.displacements and not drivers:
        raise InputError("a load-step file (a 'step' column) needs the plate's displacement "
                         "at each step: --displacements PLATE.csv (step,dx,dy,dz[,fx,fy,fz]), "
                         "or markers that show how the boundary moved (--drive-markers)",
                         key="--displacements")
    for option in ("map", "forces", "dt"):
        if getattr(args, option) is not None:
            raise InputError("is for time recordings; a load-step file's frames are "
                             "equilibria", key=f"--{option.replace('_', '-')}")
    positive(args.max_distance, "--max-distance")
    topology = Path(args.topology)
    outputs = Outputs([Path(p) for p in (args.markers, topology, args.displacements) if p])
    out = outputs.file(args.out, "--out")
    mesh, scans = _specimen(args, topology)
    if not args.displacements:
        return _import_marker_driven(args, mesh, scans, drivers, outputs, out)
    plate, markers = _driver(read_plate, args.displacements, "--displacements", "plate",
                             args, mesh, scans)
    # the face 'mesh --drive-top' chose, else the one farthest along --up
    driven = mesh.driven if mesh.driven.size else top_face(mesh, args.up)
    components = "xyz" if args.plate == "bonded" else args.up[-1]
    data = LoadSteps(mesh, (DrivenPath(driven, plate.displacement, components,
                                       "top plate"),), markers, plate.force, {}, str(args.out))
    if drivers:
        data = data.drive_markers(drivers)
    with outputs:
        save_load_steps(data, out)
    count = 0 if data.markers is None else data.markers.positions.shape[1]
    summary = {"kind": "load steps", "steps": data.n_steps, "markers": count,
               "driving_markers": drivers,
               "driven_nodes": len(driven), "plate": args.plate,
               "load_cell": plate.force is not None, "out": str(args.out)}
    if args.json:
        print_json(summary)
    else:
        print(f"wrote {args.out}: {count} markers at {data.n_steps} load steps, the "
              f"top plate ({len(driven)} nodes, {args.plate}) moved to "
              + ", ".join(f"{v:g}" for v in plate.displacement[-1] * 1e3) + " mm"
              + (", with the load cell's force" if plate.force is not None
                 else ", no force measured")
              + (f"; {len(drivers)} markers drive their nodes" if drivers else ""))
    return 0


def _import_marker_driven(args, mesh, scans, drivers, outputs, out) -> int:
    """``import SCANS.csv --drive-markers A,B,...`` without a plate file: the markers' nodes
    are the whole driven boundary (measured boundary data), no load cell."""
    from ..io.load_steps import save_load_steps
    from ..load_steps import LoadSteps, marker_paths

    if scans is None:
        raise InputError("--drive-markers needs the scans (MARKERS.csv)", key="--drive-markers")
    markers = _embedded(mesh, scans, args.max_distance)
    paths, rest = marker_paths(markers, drivers, source=str(args.markers))
    if rest is None:
        raise InputError("every marker would drive its node, leaving none to fit: keep some "
                         "out of --drive-markers", key="--drive-markers")
    data = LoadSteps(mesh, paths, rest, None, {}, str(args.out))
    with outputs:
        save_load_steps(data, out)
    summary = {"kind": "load steps", "steps": data.n_steps,
               "markers": rest.positions.shape[1], "driving_markers": drivers,
               "driven_nodes": len(paths), "load_cell": False, "out": str(args.out)}
    if args.json:
        print_json(summary)
    else:
        print(f"wrote {args.out}: {summary['markers']} markers at {data.n_steps} load steps, "
              f"{len(drivers)} markers drive their nodes, no force measured")
    return 0


def diagnose_load_steps(args) -> int:
    """``diagnose`` of a load-step file: plate slip or bonding, the law
    (:func:`neurofuzzy.diagnosis.diagnose_data`, as every diagnosis of the command)."""
    from ..diagnosis import diagnose_data
    from ..io import save_model
    from ..io.load_steps import load_load_steps
    from .common import rule_base_for

    source = Path(args.experiments[0])
    with Outputs([source] + [Path(p) for p in (args.rules, args.start) if p]) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        only_time_series_diagnosis(args, "a load-step file")
        if len(args.experiments) != 1:
            raise InputError("takes one load-step file at a time", key="EXPERIMENT.npz")
        data = load_load_steps(source)
        result = diagnose_data(data, start=args.start,
                               rules=rule_base_for(args.rules, args.tissue),
                               tissue=args.tissue, law=getattr(args, "law", None),
                               max_effects=args.max_effects, progress=not args.quiet)
        if out:
            save_model(result.after.model_, out)
        if report:
            from ..report.load_steps import load_step_diagnosis_report

            load_step_diagnosis_report(result, data, report)
    if args.json:
        print_json(result.to_dict())
    else:
        print(result.summary())
        written(args.out, args.report)
    return 0


def _embedded(mesh, scans, max_distance):
    """The scans' markers embedded in ``mesh`` at the reference scan, none farther outside
    it than ``max_distance`` (default half the shortest edge)."""
    from ..observation import EmbeddedMarkers, embed_points

    nodes, weights, distance = embed_points(mesh, scans.positions[0])
    limit = max_distance or 0.5 * mesh.rest_lengths.min()
    if np.any(distance > limit):
        worst = int(np.argmax(distance))
        raise InputError(f"marker {scans.names[worst]!r} lies {distance[worst] * 1e3:.3g} mm "
                         f"outside the mesh in the reference scan (at most "
                         f"{limit * 1e3:.3g} mm; --max-distance, or check the units and the "
                         "scan's registration to the mesh)", source=scans.source)
    return EmbeddedMarkers(nodes, weights, scans.positions, scans.names)


def fit_load_steps(args) -> int:
    """``fit`` of a load-step file."""
    from ..io import save_model
    from ..pipeline.load_steps import fit_load_step_file
    from .common import rule_base_for

    source = Path(args.experiments[0])
    steps = _step_list(args.validate_on)
    if len(args.experiments) != 1:
        raise InputError("takes one load-step file at a time", key="EXPERIMENT.npz")
    with Outputs([source] + [Path(p) for p in (args.rules, args.start) if p]) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        rule_base = rule_base_for(args.rules, args.tissue)
        say = (lambda text: print(text, file=sys.stderr)) if not args.quiet else None
        outcome = fit_load_step_file(source, start=args.start, rules=rule_base,
                                     tissue=args.tissue, law=args.law, validate_on=steps,
                                     reference_noise=args.reference_noise,
                                     mesh_check=mesh_check_option(args), progress=say)
        result, data, record = outcome.result, outcome.data, outcome.record
        if out:
            save_model(result.model_, out)
        if report:
            from ..report.load_steps import load_steps_report

            labels = next(iter(record["materials"].values()), {}).get("labels", {})
            load_steps_report(outcome.start, result, data, report, labels=labels)
    if args.json:
        print_json(record)
    else:
        print(f"load steps: {data.n_steps} steps, "
              f"{0 if data.markers is None else data.markers.n_markers} markers"
              + (", the load cell's force" if data.reaction is not None else ", no force"))
        print(result.summary())
        for region, values in record["materials"].items():
            labels = values.get("labels", {})
            if labels:
                print(f"  {region}: " + ", ".join(f"{k} {v}" for k, v in labels.items()))
        written(args.out, args.report)
    return 0


def _step_list(text: str | None) -> list[int]:
    """``--validate-on 3`` or ``2,3``."""
    if not text:
        return []
    try:
        return [int(part) for part in text.split(",")]
    except ValueError:
        raise InputError(f"got {text!r}; expected load steps as numbers, e.g. 3 or 2,3",
                         key="--validate-on") from None




def import_indentation(args) -> int:
    """``import SCANS.csv --tool sphere:R=5mm --tool-path PATH.csv``: a load-step file of an
    indenter pressed into the body (held by the model's fixed nodes), the markers embedded at
    the reference scan, the load cell (if any) the tool's."""
    from ..io.load_steps import save_load_steps
    from ..load_steps import LoadSteps, ToolPath
    if not (args.tool and args.tool_path):
        missing = "--tool-path" if args.tool else "--tool"
        raise InputError(f"an indenter needs both --tool KIND:R=RADIUS and --tool-path "
                         f"PATH.csv; {missing} is missing", key=missing)
    for option in ("displacements", "drive_markers"):
        if getattr(args, option):
            raise InputError("an indenter's load steps take no plate: the body is held by the "
                             "model's fixed nodes and pressed by the tool",
                             key=f"--{option.replace('_', '-')}")
    tool = tool_option(args.tool, args.up)
    positive(args.max_distance, "--max-distance")
    topology = Path(args.topology)
    outputs = Outputs([Path(p) for p in (args.markers, topology, args.tool_path,
                                         args.tool_force, surface_file(args.tool)) if p])
    out = outputs.file(args.out, "--out")
    mesh, scans = _specimen(args, topology)
    path, markers = _driver(tool_reader(args), args.tool_path, "--tool-path", "tool", args,
                            mesh, scans)
    name = args.tool.partition(":")[0]
    data = LoadSteps(mesh, (), markers, path.force, {}, str(args.tool_path),
                     ToolPath(tool, path.displacement, name=name,
                              orientations=path.orientations))
    with outputs:
        save_load_steps(data, out)
    count = 0 if markers is None else markers.positions.shape[1]
    depth = float(np.linalg.norm(path.displacement[-1] - path.displacement[0]))
    summary = {"kind": "load steps", "steps": data.n_steps, "markers": count, "tool": name,
               "tool_radius": tool.radius, "depth": depth,
               "load_cell": path.force is not None, "out": str(args.out)}
    if args.json:
        print_json(summary)
    else:
        size = (f"radius {1e3 * tool.radius:g} mm" if name != "surface" else
                f"{len(tool.faces)} triangles reaching {1e3 * tool.radius:.3g} mm")
        print(f"wrote {args.out}: {count} markers at {data.n_steps} load steps, a {name} of "
              f"{size} pressed {1e3 * depth:.3g} mm"
              + (", with the load cell's force" if path.force is not None
                 else ", no force measured"))
    return 0
