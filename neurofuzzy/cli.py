"""The ``neurofuzzy`` command.

Every sub-command reports bad input as one line on stderr (``neurofuzzy: error: FILE: …``) and
exits with status 2; ``--json`` output goes to stdout, progress to stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from .errors import InputError, NeurofuzzyError

EXIT_BAD_INPUT = 2


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        return args.run(args) or 0
    except NeurofuzzyError as error:
        print(f"neurofuzzy: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as error:   # an output we cannot write: the user's path, not our bug
        print(f"neurofuzzy: error: {error.filename or ''}: {error.strerror or error}",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("neurofuzzy: interrupted", file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="neurofuzzy",
        description="Deformable-tissue models from words and measurements: spring-mass "
                    "simulation, the paper's recurrent learner and exact-gradient fitting.")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = commands.add_parser("demo", help="the paper's cube experiments end to end",
                               description="Reproduce the paper's three experiments on the "
                                           "27-node / 86-spring cube (built-in data), then "
                                           "rules -> model -> fit -> words, and a diagnosis; "
                                           "writes the table, the error plot and reports.")
    demo.add_argument("--out", default="neurofuzzy-demo", help="output folder "
                      "(default: ./neurofuzzy-demo)")
    demo.add_argument("--cycles", type=int, default=100, help="learning cycles (default 100)")
    demo.add_argument("--quiet", action="store_true", help="no progress on stderr")
    demo.set_defaults(run=_demo)

    fit = commands.add_parser("fit", help="learn model parameters from experiment files",
                              description="Fit stiffness, viscosity (and masses) of the "
                                          "spring-mass model in the experiment files.")
    fit.add_argument("experiments", nargs="+", metavar="EXPERIMENT.npz")
    fit.add_argument("--tie", choices=("global", "groups", "none"), default="groups",
                     help="share spring parameters: one value for all springs, one per "
                          "spring group of the file, or one per spring (default groups)")
    fit.add_argument("--learn-masses", action="store_true",
                     help="learn node masses too (default: keep the file's masses)")
    fit.add_argument("--method", choices=("gradient", "paper"), default="gradient",
                     help="exact-gradient learner (default) or the paper's learner")
    fit.add_argument("--cycles", type=int, default=None,
                     help="learning cycles (paper, default 100) or iterations per stage "
                          "(gradient, default 100)")
    fit.add_argument("--substeps", default="auto",
                     help="integration steps per frame: a number, or 'auto' (default): "
                          "try the paper's one step per frame and continuous physics, keep "
                          "the better (gradient method only)")
    fit.add_argument("--learning-rate", type=float, default=0.1,
                     help="paper method: η for springs (default 0.1)")
    fit.add_argument("--mass-learning-rate", type=float, default=0.1,
                     help="paper method: η_m for masses (default 0.1)")
    fit.add_argument("--rules", help="start from a rule base (a YAML file, or the name of a "
                                     "shipped one: liver, brain, kidney, …) …")
    fit.add_argument("--tissue", help="… and this tissue of it")
    fit.add_argument("--report", help="write an HTML report (and a .json twin): error curve, "
                                      "what the data determine, and with --rules the "
                                      "before/after words")
    fit.add_argument("--out", help="write the fitted model as YAML")
    fit.add_argument("--export", metavar="DIR",
                     help="write the fitted model's simulation of the first experiment next "
                          "to the measurement as ParaView files (VTU series + PVD, XDMF); "
                          "the report links them")
    fit.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    fit.add_argument("--quiet", action="store_true", help="no progress on stderr")
    fit.set_defaults(run=_fit)

    export = commands.add_parser(
        "export", help="model and trajectories -> ParaView files (VTU/PVD, XDMF)",
        description="Simulate a model (YAML) under an experiment's load and write simulated "
                    "and measured trajectories, errors, strains and spring parameters as a "
                    "VTU time series (open the .pvd) and an XDMF file, through meshio.")
    export.add_argument("model", metavar="MODEL.yaml")
    export.add_argument("experiment", nargs="?", metavar="EXPERIMENT.npz",
                        help="measured trajectories and load (default: the model at rest)")
    export.add_argument("--out", required=True, metavar="DIR", help="output folder")
    export.add_argument("--stem", default="neurofuzzy", help="file name stem")
    export.add_argument("--every", type=int, default=1, help="keep every k-th frame")
    export.add_argument("--formats", nargs="+", default=["vtu", "xdmf"],
                        choices=("vtu", "xdmf"))
    export.add_argument("--substeps", default="1", help="steps per frame of the simulation")
    export.set_defaults(run=_export)

    diagnose = commands.add_parser(
        "diagnose", help="find the physical effect the model lacks",
        description="Fit the model, find where simulation and measurement disagree, name the "
                    "missing effect, add it, refit, and repeat until none is left.")
    diagnose.add_argument("experiments", nargs="+", metavar="EXPERIMENT.npz")
    diagnose.add_argument("--tie", choices=("global", "groups", "none"), default="groups")
    diagnose.add_argument("--max-effects", type=int, default=3)
    diagnose.add_argument("--substeps", default="auto")
    diagnose.add_argument("--out", help="write the final model (with the effects) as YAML")
    diagnose.add_argument("--report", help="write an HTML report (and a .json twin)")
    diagnose.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    diagnose.add_argument("--quiet", action="store_true", help="no progress on stderr")
    diagnose.set_defaults(run=_diagnose)

    rules = commands.add_parser("rules", help="check and show fuzzy rule bases")
    rules_commands = rules.add_subparsers(dest="rules_command", metavar="ACTION")
    check = rules_commands.add_parser("check", help="validate a rule base and list what it "
                                                    "defines")
    check.add_argument("rules", metavar="R.yaml")
    check.set_defaults(run=_rules_check)
    show = rules_commands.add_parser("show", help="inferred start values of a tissue and "
                                                  "their labels")
    show.add_argument("rules", metavar="R.yaml")
    show.add_argument("--tissue", required=True)
    show.add_argument("--json", action="store_true")
    show.set_defaults(run=_rules_show)
    rules.set_defaults(run=lambda args: _usage(rules))

    simulate = commands.add_parser(
        "simulate", help="simulate a model under a load and write an experiment file",
        description="Simulate a fitted model (YAML) or the built-in cube ('cube') from rest "
                    "under constant node forces and write the DESIGN.md experiment file.")
    simulate.add_argument("model", metavar="MODEL.yaml|cube")
    simulate.add_argument("--out", required=True, metavar="EXPERIMENT.npz")
    simulate.add_argument("--force", nargs=4, action="append", metavar=("NODE", "FX", "FY", "FZ"),
                          help="constant force on a node (repeatable; default: the cube's "
                               "load on its top centre node)")
    simulate.add_argument("--dt", type=float, default=None, help="frame spacing (s)")
    simulate.add_argument("--frames", type=int, default=251, help="frames incl. frame 0")
    simulate.add_argument("--substeps", default="1", help="steps per frame, or 'auto'")
    simulate.add_argument("--noise", type=float, default=0.0, help="marker noise (std, m)")
    simulate.add_argument("--seed", type=int, default=0)
    simulate.set_defaults(run=_simulate)

    mesh = commands.add_parser(
        "mesh", help="mesh file + rule base -> model (YAML)",
        description="Build a spring network from a mesh file (a closed surface: STL, OBJ, PLY, "
                    "GLB -> voxel lattice or, with --tetra, tetrahedra; a volume mesh: VTU, "
                    "VTK, Gmsh .msh) and give it start values from a rule base's tissue(s).")
    mesh.add_argument("mesh", metavar="MESH")
    mesh.add_argument("--rules", required=True, help="rule base: a YAML file or a shipped name")
    mesh.add_argument("--tissue", help="tissue of the whole object (or of the regions not "
                                       "named by --region)")
    mesh.add_argument("--region", action="append", default=[], metavar="REGION=TISSUE",
                      help="tissue of a region of a volume mesh (repeatable)")
    mesh.add_argument("--pitch", type=float, help="voxel lattice spacing of a surface (in the "
                                                  "file's length unit; default extent / 10)")
    mesh.add_argument("--tetra", action="store_true",
                      help="tetrahedralise a surface (tetgen) instead of voxelising it")
    mesh.add_argument("--max-edge", type=float, help="with --tetra: target edge length")
    mesh.add_argument("--scale", type=float, default=1.0,
                      help="multiply coordinates by this to get metres (e.g. 0.001 for mm)")
    fixing = mesh.add_mutually_exclusive_group()
    fixing.add_argument("--fix-bottom", action="store_true",
                        help="hold the lowest nodes (z within a quarter of the shortest "
                             "spring of the minimum) in place")
    fixing.add_argument("--fix-below", type=float, metavar="Z",
                        help="hold the nodes with z <= Z (metres) in place")
    mesh.add_argument("--tie", choices=("global", "groups", "none"), default="groups")
    mesh.add_argument("--out", required=True, metavar="MODEL.yaml")
    mesh.set_defaults(run=_mesh)

    importer = commands.add_parser(
        "import", help="marker recording (CSV or C3D) -> experiment file",
        description="Attach the markers of an optical recording to the nodes of a model, "
                    "resample to the model's step and write the DESIGN.md experiment file "
                    "(nodes with markers observed; frames where a marker was not seen are "
                    "gaps, never interpolated across).")
    importer.add_argument("markers", metavar="MARKERS.csv|MARKERS.c3d")
    importer.add_argument("--topology", required=True, metavar="MODEL.yaml|EXPERIMENT.npz",
                          help="the object's nodes and springs: a model (its masses become the "
                               "experiment's known masses) or another experiment file")
    importer.add_argument("--map", metavar="MAP.csv",
                          help="marker,node pairs (default: each marker to its nearest node)")
    importer.add_argument("--forces", metavar="FORCES.csv",
                          help="time,node,fx,fy,fz in N, each row held until the node's next")
    importer.add_argument("--units", choices=("m", "cm", "mm"),
                          help="length unit of the marker file (CSV: required unless the file "
                               "has a '# units: mm' line; C3D: overrides POINT:UNITS)")
    importer.add_argument("--dt", type=float, default=None,
                          help="the model's step (s) to resample to (default: the topology "
                               "file's dt, else the capture's frame period)")
    importer.add_argument("--max-distance", type=float, default=None,
                          help="farthest a marker may lie from its node at the start (m; "
                               "default half the shortest spring)")
    importer.add_argument("--out", required=True, metavar="EXPERIMENT.npz")
    importer.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    importer.set_defaults(run=_import)
    return parser


# -- demo -----------------------------------------------------------------------------------
def _demo(args) -> int:
    from .demo import comparison_table, paper_experiments, plot_error_curves, words_and_diagnosis

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    progress = not args.quiet
    _say(progress, "neurofuzzy demo: the paper's cube (27 nodes, 86 springs, bottom fixed, "
                   "constant force on the top centre node, 250 steps)")
    runs = paper_experiments(cycles=args.cycles, progress=progress, gradient_for=(3,))
    table = comparison_table(runs)
    print(table)
    from .io import atomic_write

    plot_error_curves(runs, out / "error_per_cycle.png")
    summary = {"runs": [{"experiment": r.experiment, "learner": r.learner, "cycles": r.cycles,
                         "E": r.final_error, "stiffness_error": r.stiffness_error,
                         "damping_error": r.damping_error, "mass_error": r.mass_error,
                         "rms_initial": r.rms_initial, "rms_final": r.rms_final,
                         "seconds": r.seconds} for r in runs]}
    with atomic_write(out / "summary.json", "w") as handle:
        json.dump(summary, handle, indent=2, allow_nan=True)
    with atomic_write(out / "table.txt", "w") as handle:
        handle.write(table + "\n")
    print()
    for line in words_and_diagnosis(out, progress=progress):
        print(line)
    print(f"\nwrote {out}/: error_per_cycle.png (the paper's Figure 4), table.txt, "
          f"summary.json, report.html (+ .json), diagnosis.html (+ .json) "
          f"({time.perf_counter() - started:.1f} s)")
    return 0


# -- fit ------------------------------------------------------------------------------------
def _load_start(args, progress: bool):
    """Experiments named on the command line and a start model for them."""
    from .io import load_experiment
    from .learn.initial import estimate_start
    from .model import SpringMassModel, tie_index

    inputs = [Path(p) for p in args.experiments]
    protected = inputs + ([Path(args.rules)] if getattr(args, "rules", None) else [])
    for option in ("out", "report"):
        _refuse_overwrite(getattr(args, option, None), protected)
        if getattr(args, option, None) and option == "report":   # and the report's JSON twin
            _refuse_overwrite(str(Path(args.report).with_suffix(".json")), protected)
    experiments = [load_experiment(p) for p in inputs]
    first = experiments[0]
    for other in experiments[1:]:
        if other.mesh.n_nodes != first.mesh.n_nodes or not np.array_equal(
                other.mesh.springs, first.mesh.springs):
            raise InputError(f"describes another object than {first.source} (nodes or springs "
                             "differ); experiments fitted together must share one topology",
                             source=other.source, key="springs")
    masses = first.masses
    estimate_mass = masses is None
    if estimate_mass:
        _say(progress, f"neurofuzzy: note: {first.source} gives no 'masses'; estimating one "
                       "mass per node from the data")
        masses = np.ones(first.n_nodes)
    mesh = first.mesh
    if getattr(args, "rules", None):
        from .rules import initialize

        if not args.tissue:
            raise InputError("--rules needs --tissue NAME", key="--tissue")
        rule_base = _rule_base(args.rules)
        start, _ = initialize(rule_base, mesh, args.tissue, tie=args.tie)
        if first.masses is not None:
            start = start.replace(node_mass=first.masses)
        return inputs, experiments, start, {"used": True, "reason": f"rules {args.rules}, "
                                                                    f"tissue {args.tissue}"}
    start = SpringMassModel(mesh, node_mass=masses, spring_stiffness=1.0, spring_damping=1.0,
                            spring_tie=tie_index(mesh, args.tie))
    start, info = estimate_start(start, experiments, estimate_mass=estimate_mass)
    if estimate_mass and not info["used"]:
        raise InputError(f"gives no 'masses', and they cannot be estimated here ({info['reason']}"
                         "); give known masses (import with --topology MODEL.yaml) or start "
                         "from a rule base (--rules R.yaml --tissue NAME)", source=first.source,
                         key="masses")
    _say(progress, f"start values: {info['reason']}" if info["used"] else
         f"start values: defaults ({info['reason']})")
    return inputs, experiments, start, info


def _fit(args) -> int:
    from .io import save_model
    from .learn import GradientLearner, PaperLearner

    progress = not args.quiet and not args.json
    inputs, experiments, start, info = _load_start(args, progress)
    substeps = _substeps(args.substeps)
    if args.method == "paper":
        learner = PaperLearner(learning_rate=args.learning_rate,
                               mass_learning_rate=args.mass_learning_rate,
                               cycles=args.cycles or 100, learn_masses=args.learn_masses,
                               progress=progress)
    else:
        learner = GradientLearner(learn_masses=args.learn_masses, substeps=substeps,
                                  max_iterations=args.cycles or 100, progress=progress)
    learner.fit(start, experiments)
    if args.out:
        save_model(learner.model_, args.out)
    files = {"fitted model": args.out} if args.out else {}
    exported = {}
    if args.export:
        from .export import export_paraview

        exported = export_paraview(args.export, learner.model_, experiments[0],
                                   substeps=getattr(learner, "substeps_", 1),
                                   stem=Path(inputs[0]).stem)
        files.update({f"ParaView {kind}": path for kind, path in exported.items()
                      if kind in ("pvd", "xdmf")})
    if args.report:
        from .report import fit_report

        fit_report(_rule_base(args.rules) if args.rules else None, args.tissue, start,
                   learner, args.report, files=files)
    result = learner.to_dict()
    result.update(method=args.method, tie=args.tie, experiments=[str(p) for p in inputs],
                  start=info)
    if args.method == "gradient":
        result.update(substeps=learner.substeps_, extrapolated=learner.extrapolated_,
                      parameters=learner.parameter_names_,
                      **learner.identifiability_.to_dict())
    if args.json:
        print(json.dumps(_json_safe(result)))
    else:
        print(learner.model_.summary())
        print(f"RMS error: {result['rms_error_initial']:.4g} -> {result['rms_error']:.4g} "
              f"({result['cycles']} cycles, {result['seconds']:.1f} s)")
        _written(args.out, args.report, exported.get("pvd"), exported.get("xdmf"))
    return 0


def _export(args) -> int:
    from .export import export_paraview
    from .io import load_experiment, load_model

    model = load_model(args.model)
    experiment = load_experiment(args.experiment) if args.experiment else None
    written = export_paraview(args.out, model, experiment, every=args.every,
                              substeps=_substeps(args.substeps), stem=args.stem,
                              formats=args.formats)
    frames = len(written.get("vtu", [])) or 1
    _written(written.get("pvd"), written.get("xdmf"))
    print(f"{frames} frames; open the .pvd in ParaView to play the simulation")
    return 0


# -- rules ----------------------------------------------------------------------------------
def _rules_check(args) -> int:
    rule_base = _rule_base(args.rules)
    print(rule_base.summary())
    return 0


def _rules_show(args) -> int:
    rule_base = _rule_base(args.rules)
    values = rule_base.tissue(args.tissue)
    labels = rule_base.describe(values)
    if args.json:
        print(json.dumps(_json_safe({
            "tissue": args.tissue,
            "words": {k: str(v) for k, v in rule_base.tissues[args.tissue].items()},
            "values": values,
            "units": {k: rule_base.outputs[k].unit for k in values},
            "labels": {k: {"term": l.term, "degree": l.degree, "degrees": l.degrees}
                       for k, l in labels.items()}})))
    else:
        words = ", ".join(f"{k} is {v}" for k, v in rule_base.tissues[args.tissue].items())
        print(f"{args.tissue}: {words}")
        for name, label in labels.items():
            print(f"  {name} = {label.value:.4g} {rule_base.outputs[name].unit}   ({label})")
    return 0


def _usage(parser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_BAD_INPUT


# -- diagnose -------------------------------------------------------------------------------
def _diagnose(args) -> int:
    from .diagnose import diagnose
    from .io import save_model
    from .report import diagnosis_report

    progress = not args.quiet and not args.json
    inputs, experiments, start, _ = _load_start(args, progress)
    result = diagnose(start, experiments, max_effects=args.max_effects,
                      substeps=_substeps(args.substeps), progress=progress)
    if args.out:
        save_model(result.model_, args.out)
    if args.report:
        diagnosis_report(result, args.report)
    data = result.to_dict()
    data["experiments"] = [str(p) for p in inputs]
    if args.json:
        print(json.dumps(_json_safe(data)))
    else:
        print(f"effects: {', '.join(result.names)}")
        for finding in result.effects:
            where = (f" springs {finding.springs}" if finding.springs else "") + \
                (f" node {finding.nodes}" if finding.nodes else "")
            print(f"  {finding.name} (confidence {finding.confidence:.2f}, runner-up "
                  f"{finding.runner_up}){where}: {finding.parameters}")
        print(f"RMS error: {result.rms_before:.4g} -> {result.rms_after:.4g} "
              f"(marker noise {result.noise_rms:.3g})")
        _written(args.out, args.report)
    return 0


# -- simulate -------------------------------------------------------------------------------
def _simulate(args) -> int:
    from .datasets import CUBE, paper_cube_model, top_centre_node
    from .experiment import simulate_experiment
    from .io import load_model, save_experiment

    _refuse_overwrite(args.out, [Path(args.model)])
    model = paper_cube_model() if args.model == "cube" else load_model(args.model)
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
            loads[index] += vector
    else:
        loads[top_centre_node(model.mesh)] = CUBE["force"]
    experiment = simulate_experiment(model, dt=args.dt or CUBE["dt"], n_frames=args.frames,
                                     external_forces=loads, substeps=_substeps(args.substeps),
                                     noise=args.noise, seed=args.seed, source=args.out)
    save_experiment(experiment, args.out)
    print(f"wrote {args.out}: {experiment.n_frames} frames of {experiment.n_nodes} nodes")
    return 0


# -- mesh -----------------------------------------------------------------------------------
def _mesh(args) -> int:
    from dataclasses import replace

    from .io import save_model
    from .mesh_files import read_mesh
    from .rules import initialize

    source = Path(args.mesh)
    _refuse_overwrite(args.out, [source, Path(args.rules)])
    method = "tetra" if args.tetra else "voxel"
    read = read_mesh(source, pitch=args.pitch, max_edge=args.max_edge, method=method)
    mesh = read.mesh
    if not (np.isfinite(args.scale) and args.scale > 0):
        raise InputError(f"got {args.scale}; expected a positive factor", key="--scale")
    if args.scale != 1.0:
        mesh = replace(mesh, rest_positions=mesh.rest_positions * args.scale)
    if args.fix_bottom:
        z = mesh.rest_positions[:, 2]
        mesh = mesh.with_fixed(where=lambda p: z <= z.min() + 0.25 * mesh.rest_lengths.min())
    elif args.fix_below is not None:
        mesh = mesh.with_fixed(where=lambda p: p[:, 2] <= args.fix_below)
    tissue_of = {}
    for item in args.region:
        region, _, tissue = item.partition("=")
        if not region or not tissue:
            raise InputError(f"got {item!r}; expected REGION=TISSUE", key="--region")
        tissue_of[region] = tissue
    rule_base = _rule_base(args.rules)
    regions = {}
    if tissue_of:
        of = "tetrahedra" if read.tetrahedron_regions else "nodes"
        regions = {("tetrahedron_regions" if of == "tetrahedra" else "regions"):
                   read.tissue_regions(tissue_of, of=of)}
    elif read.regions and len(read.regions) > 1:
        print(f"neurofuzzy: note: {source} has regions {list(read.regions)}; give them "
              "tissues with --region REGION=TISSUE", file=sys.stderr)
    if not args.tissue and not tissue_of:
        raise InputError("give --tissue NAME (and --region REGION=TISSUE for regions)",
                         key="--tissue")
    model, _ = initialize(rule_base, mesh, args.tissue, tie=args.tie, **regions)
    save_model(model, args.out)
    print(model.summary())
    print(f"{len(mesh.fixed)} fixed nodes" + ("" if len(mesh.fixed) else
                                              " (none: use --fix-bottom or --fix-below)"))
    _written(args.out)
    return 0


# -- import ---------------------------------------------------------------------------------
def _import(args) -> int:
    from .io import load_experiment, load_model, save_experiment
    from .markers import markers_to_experiment, read_marker_map, read_markers

    inputs = [Path(p) for p in (args.markers, args.topology, args.map, args.forces) if p]
    _refuse_overwrite(args.out, inputs)
    topology = Path(args.topology)
    if topology.suffix.lower() == ".npz":
        reference = load_experiment(topology)
        mesh, masses, dt = reference.mesh, reference.masses, reference.dt
    elif topology.suffix.lower() in (".yaml", ".yml"):
        model = load_model(topology)
        mesh, masses, dt = model.mesh, model.node_mass, None
    else:
        raise InputError("expected a model (.yaml) or an experiment file (.npz)",
                         source=str(topology), key="--topology")
    markers = read_markers(args.markers, units=args.units)
    mapping = read_marker_map(args.map) if args.map else None
    experiment, summary = markers_to_experiment(
        markers, mesh, dt=args.dt or dt, mapping=mapping, max_distance=args.max_distance,
        forces=args.forces, masses=masses, source=args.out)
    if args.forces is None:
        print("neurofuzzy: note: no --forces; the experiment has no applied load",
              file=sys.stderr)
    save_experiment(experiment, args.out)
    summary.update(markers_file=str(args.markers), topology=str(topology), out=str(args.out))
    if args.json:
        print(json.dumps(_json_safe(summary)))
    else:
        unmatched = (f"; {len(summary['unmatched'])} marker(s) not in the map"
                     if summary["unmatched"] else "")
        print(f"wrote {args.out}: {summary['markers']} markers on {mesh.n_nodes} nodes, "
              f"{summary['frames']} frames of {summary['dt']:.4g} s (capture period "
              f"{summary['capture_period']:.4g} s), {100 * summary['gaps']:.1f} % gaps"
              f"{unmatched}")
        if summary["dropped_leading_frames"]:
            print(f"  dropped the first {summary['dropped_leading_frames']} capture frames: "
                  "not every marker was seen yet")
    return 0


# -- helpers --------------------------------------------------------------------------------
def _rule_base(value: str):
    """A rule base from a path, or by the name of a shipped one (``liver``)."""
    from .rules import load_rules, shipped

    path = Path(value)
    if not path.exists() and path.suffix == "" and "/" not in value:
        path = shipped(value)
    return load_rules(path)


def _substeps(value: str):
    if value == "auto":
        return "auto"
    try:
        number = int(value)
    except ValueError:
        number = 0
    if number < 1:
        raise InputError(f"got {value!r}; expected a positive integer or 'auto'", key="--substeps")
    return number


def _refuse_overwrite(out, inputs) -> None:
    if out is None:
        return
    target = Path(out).resolve()
    for path in inputs:
        if path.exists() and path.resolve() == target:
            raise InputError("--out names an input file; neurofuzzy never writes over its input",
                             source=str(out))


def _written(*paths) -> None:
    for path in paths:
        if path:
            print(f"wrote {path}")


def _say(enabled: bool, message: str) -> None:
    if enabled:
        print(message, file=sys.stderr, flush=True)


def _json_safe(value):
    if isinstance(value, dict):
        return {key: _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    return value


if __name__ == "__main__":
    sys.exit(main())
