"""Commands that move data: ``simulate``, ``mesh``, ``import``, ``export`` (to MuJoCo, SOFA,
FEBio and ParaView)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..forces.laws import LAWS
from .common import (Outputs, at_least, naming, positive, print_json, require_tissue,
                     vtu_series, written)

__all__ = ["simulate", "mesh", "import_markers", "export"]


def simulate(args) -> int:
    from ..datasets import CUBE, paper_cube_model, top_centre_node
    from ..experiment import simulate_experiment
    from ..io import load_model, save_experiment
    from ..plausibility import check_length_option, extent

    positive(args.dt, "--dt")
    at_least(args.frames, 2, "--frames")
    at_least(args.noise, 0, "--noise")
    at_least(args.seed, 0, "--seed")
    substeps = _substeps(args.substeps)
    outputs = Outputs([Path(args.model)])
    out = outputs.file(args.out, "--out")
    model = paper_cube_model() if args.model == "cube" else load_model(args.model)
    check_length_option(args.noise, extent(model.mesh.rest_positions), "--noise",
                        "a marker noise", refused=0.25, warned=0.02)
    loads = np.zeros((model.n_nodes, 3))
    if args.force:
        for node, *force in args.force:
            try:
                index, vector = int(node), [float(x) for x in force]
            except ValueError:
                raise InputError(f"got {[node, *force]}; expected NODE FX FY FZ (an integer "
                                 "and three numbers)", key="--force") from None
            if not 0 <= index < model.n_nodes:
                raise InputError(f"node {index} is out of range 0..{model.n_nodes - 1}",
                                 key="--force")
            if not np.all(np.isfinite(vector)):
                raise InputError(f"got {vector}; a force needs finite numbers", key="--force")
            loads[index] += vector
    else:
        loads[top_centre_node(model.mesh)] = CUBE["force"]
    with outputs, naming(args.model):
        experiment = simulate_experiment(model, dt=args.dt or CUBE["dt"], n_frames=args.frames,
                                         external_forces=loads, substeps=substeps,
                                         noise=args.noise, seed=args.seed, source=args.out,
                                         integrator=args.integrator)
        save_experiment(experiment, out)
    print(f"wrote {args.out}: {experiment.n_frames} frames of {experiment.n_nodes} nodes")
    return 0


def mesh(args) -> int:
    from dataclasses import replace

    from ..io import save_model
    from ..mesh import read_mesh
    from ..mesh.files import SURFACE_SUFFIXES
    from ..plausibility import check_body_size
    from ..tissues import initialize
    from .common import load_rule_base, rule_file

    source = Path(args.mesh)
    if args.tetra:
        from ..extras import require

        require("tetra", "--tetra (TetGen)")              # before any work
    positive(args.pitch, "--pitch")
    positive(args.max_edge, "--max-edge")
    positive(args.scale, "--scale")
    if args.fix_below is not None and not np.isfinite(args.fix_below):
        raise InputError(f"got {args.fix_below}; expected a height in metres", key="--fix-below")
    tissue_of = _region_options(args.region)
    outputs = Outputs([source, rule_file(args.rules)])
    out = outputs.file(args.out, "--out")
    method = "tetra" if args.tetra else "voxel"
    rule_base = load_rule_base(args.rules, quiet=True)     # said once the model is written
    for option, tissue in [("--tissue", args.tissue)] + [
            (f"--region {region}={tissue}", tissue) for region, tissue in tissue_of.items()]:
        if tissue:
            require_tissue(rule_base, tissue, option)
    read = read_mesh(source, pitch=args.pitch, max_edge=args.max_edge, method=method)
    mesh = read.mesh
    if not (np.isfinite(args.scale) and args.scale > 0):
        raise InputError(f"got {args.scale}; expected a positive factor", key="--scale")
    if args.scale != 1.0:
        mesh = replace(mesh, rest_positions=mesh.rest_positions * args.scale)
    tissues = ", ".join(dict.fromkeys(filter(None, [args.tissue, *tissue_of.values()])))
    check_body_size(mesh.rest_positions, source=str(source), what="the mesh",
                    tissue=tissues or None, scale=args.scale)
    if args.elements == "tetra" and mesh.tetrahedra is None:
        from ..mesh import lattice_to_tetra

        # six tetrahedra per voxel, stretched onto the surface's bounding box
        bounds = None if read.surface_bounds is None else read.surface_bounds * args.scale
        mesh = lattice_to_tetra(mesh, bounds=bounds)
    if args.fix_bottom:
        from .tools import axis_of

        index, sign = axis_of(args.up)
        z = sign * mesh.rest_positions[:, index]
        mesh = mesh.with_fixed(where=lambda p: z <= z.min() + 0.25 * mesh.rest_lengths.min())
    elif args.fix_below is not None:
        z = mesh.rest_positions[:, 2]
        if args.fix_below >= z.max():
            raise InputError(f"got {args.fix_below:g} m, at or above the top of the mesh "
                             f"(z from {z.min():.4g} to {z.max():.4g} m): every node would be "
                             "held and nothing could move", key="--fix-below")
        mesh = mesh.with_fixed(where=lambda p: p[:, 2] <= args.fix_below)
    if args.drive_top:
        from .steps import top_face

        mesh = mesh.with_driven(top_face(mesh, args.up))
    regions = {}
    if tissue_of:
        of = "tetrahedra" if read.tetrahedron_regions else "nodes"
        _check_regions(read, tissue_of, args.tissue, source)
        regions = {("tetrahedron_regions" if of == "tetrahedra" else "regions"):
                   read.tissue_regions(tissue_of, of=of)}
    elif read.regions and len(read.regions) > 1:
        print(f"neurofuzzy: note: {source} has regions {list(read.regions)}; give them "
              "tissues with --region REGION=TISSUE", file=sys.stderr)
    if not args.tissue and not tissue_of:
        raise InputError("give --tissue NAME (and --region REGION=TISSUE for regions)",
                         key="--tissue")
    model = initialize(rule_base, mesh, args.tissue, elements=args.elements == "tetra",
                       **regions).tied(args.tie)
    if model.elements is not None:
        model = model.with_elements(law=args.law)
    elif args.law != LAWS[0]:
        raise InputError(f"a material law ({args.law!r}) is one of tetrahedral elements; "
                         "this model is a spring network (--elements springs)", key="--law")
    with outputs:
        save_model(model, out, rules=rule_base.provenance())
    print(f"rules: {rule_base.origin}", file=sys.stderr)
    print(model.summary())
    print(f"{len(mesh.fixed)} fixed nodes" + ("" if len(mesh.fixed) else
                                              " (none: use --fix-bottom or --fix-below)")
          + (f", {len(mesh.driven)} driven (the top plate's face)" if len(mesh.driven)
             else ""))
    if source.suffix.lower() in SURFACE_SUFFIXES:
        bounds = (read.surface_bounds if read.surface_bounds is not None else np.array(
            [read.mesh.rest_positions.min(axis=0), read.mesh.rest_positions.max(axis=0)]))
        print(_resolution(args, bounds))
    written(args.out)
    return 0


def _region_options(items) -> dict[str, str]:
    """``--region REGION=TISSUE`` options as a mapping; a region named twice is refused."""
    tissue_of: dict[str, str] = {}
    for item in items:
        region, _, tissue = item.partition("=")
        region, tissue = region.strip(), tissue.strip()
        if not region or not tissue:
            raise InputError(f"got {item!r}; expected REGION=TISSUE", key="--region")
        if region in tissue_of:
            raise InputError(f"region {region!r} is given twice ({region}={tissue_of[region]} "
                             f"and {item}); give each region one tissue", key="--region")
        tissue_of[region] = tissue
    return tissue_of


def _check_regions(read, tissue_of: dict, tissue: str | None, source: Path) -> None:
    """Every --region names a region of the mesh, and every region has a tissue."""
    from ..errors import closest_name

    known = list(read.tetrahedron_regions or read.regions)
    if not known:
        asked = ", ".join(f"{region!r} ({region}={tissue_of[region]})" for region in tissue_of)
        raise InputError(f"has no regions, so no region {asked} (--region names regions of a "
                         "volume mesh whose cells carry region ids, e.g. Gmsh physical "
                         "groups); give --tissue for the whole object", source=str(source),
                         key="--region")
    for region in tissue_of:
        if region not in known:
            hint = closest_name(region, known)
            raise InputError(f"no region {region!r}" + (f"; did you mean {hint!r}?" if hint
                                                         else "") + f"; the regions are "
                             f"{known}", source=str(source), key="--region")
    missing = [region for region in known if region not in tissue_of]
    if missing and not tissue:
        raise InputError(f"region{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))} of the mesh "
                         f"{'have' if len(missing) > 1 else 'has'} no tissue: give --region "
                         f"{missing[0]}=TISSUE for each, or --tissue TISSUE for the rest",
                         source=str(source), key="--region")


def _resolution(args, bounds) -> str:
    """What resolution a surface was meshed at, and the option that changes it (a finer mesh
    resolves more and fits slower: fit time grows with the node count)."""
    from ..mesh.files import DEFAULT_DIVISIONS, TETRA_EDGE_FACTOR

    extent = float(np.max(bounds[1] - bounds[0])) * args.scale
    if args.tetra:
        size = args.max_edge * args.scale if args.max_edge else (
            TETRA_EDGE_FACTOR * extent / DEFAULT_DIVISIONS)
        how = "" if args.max_edge else f" (default 1.5 x extent / {DEFAULT_DIVISIONS})"
        return f"TetGen tetrahedra, edges up to {size:.3g} m{how}; --max-edge L refines or coarsens"
    size = args.pitch * args.scale if args.pitch else extent / DEFAULT_DIVISIONS
    how = "" if args.pitch else f" (default extent / {DEFAULT_DIVISIONS})"
    return f"voxel cells of {size:.3g} m{how}; --pitch P refines or coarsens"


def import_markers(args) -> int:
    from ..io import load_experiment, load_model, save_experiment
    from ..markers import markers_to_experiment, read_marker_map, read_markers
    from ..markers.steps import has_step_column
    from ..plausibility import check_body_size, check_length_option, check_recording
    from .moving import check_moving_options, moved_in_time
    from .steps import import_load_steps
    from .tools import surface_file

    if args.markers is None and (args.displacements or args.tool_path):
        return import_load_steps(args)
    if args.markers is None:
        raise InputError("give the marker recording (MARKERS.csv or .c3d), or, for a "
                         "compression test with a load cell alone, --displacements PLATE.csv",
                         key="MARKERS")
    if Path(args.markers).suffix.lower() == ".csv" and has_step_column(args.markers):
        return import_load_steps(args)
    check_moving_options(args)
    inputs = [Path(p) for p in (args.markers, args.topology, args.map, args.forces,
                                args.displacements, args.tool_path, args.tool_force,
                                args.tool and surface_file(args.tool)) if p]
    positive(args.dt, "--dt")
    positive(args.max_distance, "--max-distance")
    at_least(args.force_spread, 1, "--force-spread")
    at_least(args.probe_radius, 0, "--probe-radius")
    outputs = Outputs(inputs)
    out = outputs.file(args.out, "--out")
    topology = Path(args.topology)
    model = None
    if topology.suffix.lower() == ".npz":
        reference = load_experiment(topology)
        mesh, masses, dt = reference.mesh, reference.node_mass, reference.dt
    elif topology.suffix.lower() in (".yaml", ".yml"):
        model = load_model(topology)
        mesh, masses, dt = model.mesh, model.node_mass, None
    else:
        raise InputError("expected a model (.yaml) or an experiment file (.npz)",
                         source=str(topology), key="--topology")
    body = check_body_size(mesh.rest_positions, source=str(topology), what="its mesh",
                           option="")
    check_length_option(args.max_distance, body, "--max-distance",
                        "a marker's distance from the mesh")
    check_length_option(args.probe_radius, body, "--probe-radius", "a probe's contact radius")
    if args.forces:
        _check_force_options(args)
    markers = read_markers(args.markers, units=args.units)
    check_recording(markers, mesh, dt=args.dt or dt, model=model, topology=str(topology),
                    dt_option="--dt" if args.dt else None)
    mapping = read_marker_map(args.map, markers=markers, n_nodes=mesh.n_nodes) \
        if args.map else None
    imported = markers_to_experiment(
        markers, mesh, dt=args.dt or dt, mapping=mapping, max_distance=args.max_distance,
        forces=args.forces, node_mass=masses, source=args.out,
        force_spread=args.force_spread or 1, probe_radius=args.probe_radius,
        attach=args.attach)
    experiment, summary = imported.experiment, imported.summary
    if args.displacements or args.tool:
        experiment = moved_in_time(args, experiment, summary)
    elif args.forces is None:
        print("neurofuzzy: note: no --forces; the experiment has no applied load",
              file=sys.stderr)
    with outputs:
        save_experiment(experiment, out)
    summary.update(markers_file=str(args.markers), topology=str(topology), out=str(args.out))
    if args.json:
        print_json(summary)
    else:
        unmatched = (f"; {len(summary['unmatched'])} marker(s) not in the map"
                     if summary["unmatched"] else "")
        how = ("embedded in the mesh's tetrahedra" if summary["attach"] == "embed"
               else f"on nodes of {mesh.n_nodes}")
        print(f"wrote {args.out}: {summary['markers']} markers {how}, "
              f"{summary['frames']} frames of {summary['dt']:.4g} s (capture period "
              f"{summary['capture_period']:.4g} s), {100 * summary['gaps']:.1f} % gaps"
              f"{unmatched}")
        if summary.get("offset_markers"):
            print(f"  {summary['offset_markers']} marker(s) lie outside the mesh (up to "
                  f"{1e3 * summary['max_distance_outside']:.3g} mm): their constant offset, "
                  f"from {summary['rest_frames']} frame(s) at rest, is removed")
        if args.displacements or args.tool:
            print(f"  {summary['moved_by']} follows {args.displacements or args.tool_path}"
                  + (", with the load cell's force" if summary["load_cell"]
                     else ", no force measured"))
        if summary["dropped_leading_frames"]:
            print(f"  dropped the first {summary['dropped_leading_frames']} capture frames: "
                  "not every marker was seen yet")
    return 0


def _check_force_options(args) -> None:
    """--force-spread shares a point force among nodes: not for a node-numbered file, and
    not together with a contact radius, which decides the spread itself."""
    from ..markers.forces import force_file_form

    if args.force_spread is None:
        return
    if force_file_form(args.forces) == "node":
        raise InputError("shares a force given at a point (time,x,y,z,fx,fy,fz) among surface "
                         "nodes; this force file names nodes", source=str(args.forces),
                         key="--force-spread")
    if args.probe_radius is not None:
        raise InputError("--force-spread and --probe-radius both say how a point force is "
                         "shared; give one (a contact radius spreads it over the patch the "
                         "probe presses)", key="--force-spread")


def export(args) -> int:
    if args.to == "vtu":
        return _export_paraview(args)
    from ..export import TARGETS, export as write
    from ..io import load_experiment, load_model
    from ..io.models import load_fit_record

    for option, value in (("--stem", args.stem), ("--every", args.every),
                          ("--formats", args.formats)):
        if value is not None:
            raise InputError(f"applies to --to vtu only, not --to {args.to}", key=option)
    at_least(args.max_materials, 1, "--max-materials")
    substeps = _substeps(args.substeps or "auto")
    suffix = TARGETS[args.to]
    if Path(args.out).suffix.lower() != suffix:
        raise InputError(f"expected a {suffix} file for --to {args.to}", source=str(args.out),
                         key="--out")
    outputs = Outputs([Path(p) for p in (args.model, args.experiment) if p])
    out = outputs.file(args.out, "--out")
    with outputs, naming(args.model):
        model = load_model(args.model)
        fit = load_fit_record(args.model)
        experiment = load_experiment(args.experiment) if args.experiment else None
        result = write(model, to=args.to, path=out, experiment=experiment, fit=fit,
                       substeps=substeps, max_materials=args.max_materials)
    for note in result.notes:
        print(f"note: {note}")
    if fit is None:
        print(f"note: {args.model} holds no fit record: the file says 'lack of fit: not "
              "recorded' (models written by 'neurofuzzy fit --out' have one)")
    written(args.out)
    return 0


def _export_paraview(args) -> int:
    from ..export import export as write
    from ..io import load_experiment, load_model
    from ..io.models import load_fit_record

    every = 1 if args.every is None else args.every
    stem = args.stem or "neurofuzzy"
    at_least(every, 1, "--every")
    substeps = _substeps(args.substeps or "auto")
    outputs = Outputs([Path(p) for p in (args.model, args.experiment) if p])
    folder = outputs.folder(args.out, "--out", owns=vtu_series(stem))
    with outputs, naming(args.model):
        model = load_model(args.model)
        experiment = load_experiment(args.experiment) if args.experiment else None
        result = write(model, to="vtu", path=folder, experiment=experiment,
                       fit=load_fit_record(args.model), substeps=substeps, every=every,
                       stem=stem, formats=args.formats or ["vtu", "xdmf"])
        files = [outputs.target_of(path) for path in result.files]
    frames = sum(1 for path in files if path.suffix == ".vtu") or 1
    written(*[path for path in files if path.suffix in (".pvd", ".xdmf")])
    print(f"{frames} frames; open the .pvd in ParaView to play the simulation")
    return 0


def _substeps(value):
    from ..simulation import check_substeps

    return check_substeps(value, "--substeps")
