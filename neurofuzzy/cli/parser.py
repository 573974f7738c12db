"""The argument parser of the ``neurofuzzy`` command (the command shapes of the design notes)."""

from __future__ import annotations

import argparse

from . import batch, data, fitting, misc, studio, tools
from .common import usage
from .parser_import import FORMAT_DOC, add_import
from ..forces.laws import LAW_RECORDS, LAWS
from ..version import __version__

__all__ = ["build_parser"]


def _laws() -> str:
    """The material laws for ``--help``: each name with its record's summary."""
    return "; ".join(f"{law.name}: {law.summary}".replace("%", "%%") for law in LAW_RECORDS)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="neurofuzzy",
        description="Deformable-tissue models from words and measurements: spring-mass "
                    "simulation, the paper's recurrent learner and exact-gradient fitting.")
    parser.add_argument("--version", action="version", version=f"neurofuzzy {__version__}")
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
    demo.set_defaults(run=misc.demo)

    fit = commands.add_parser("fit", help="learn model parameters from experiment files",
                              description="Fit the parameters of a model (Young's "
                                          "modulus, Poisson's ratio and viscosity of "
                                          "tetrahedral elements, the default when the "
                                          "experiment has tetrahedra; or stiffness, damping "
                                          "and masses of a spring network) to the experiment "
                                          "files; start "
                                          "from a model file (--start), a rule base's tissue "
                                          "(--rules, --tissue) or the data alone.")
    fit.add_argument("experiments", nargs="+", metavar="EXPERIMENT.npz")
    _start_options(fit)
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
    fit.add_argument("--prior", default="default", metavar="off|auto|WEIGHT",
                     help="the rule base's words as a prior on every fitted value: 'auto' "
                          "(the default with --tie none and --rules) chooses its weight by "
                          "the discrepancy principle, a number fixes it (1 = Bayesian: the "
                          "fuzzy set's spread against the measured noise), 'off' (the default "
                          "otherwise) fits the data alone")
    fit.add_argument("--validate-on", metavar="STEPS|FILES|TIME",
                     help="keep data out of the fit and report its prediction error beside "
                          "the fitted error: a load-step file's steps (3 or 2,3); of time "
                          "series, some of the experiment files (b.npz or b.npz,c.npz: load "
                          "cases fitted on the others) or a time in seconds ('0.3s': every "
                          "recording fitted on its frames before it)")
    fit.add_argument("--reference-noise", action="store_true",
                     help="a load-step file: the reference scan is as noisy as the others; "
                          "estimate each marker's rest point from every scan (a noisy "
                          "reference otherwise puts its noise into every residual; it also "
                          "absorbs a wrong model's error, so use it once the model is right)")
    checks = fit.add_mutually_exclusive_group()
    checks.add_argument("--mesh-check", action="store_true",
                        help="the mesh check for any element model. By default an element "
                             "model of at most 64 parameters gets it: after the fit, how far "
                             "the values move on the mesh refined once (each tetrahedron in "
                             "eight), by one Gauss-Newton step there (about half a fit), "
                             "widens the 95 %% intervals: the discretisation error no "
                             "standard error sees, even when the fit is at the noise. With "
                             "this flag a fit of every element gets it too, by the whole "
                             "refit where the step cannot be trusted. A load-step file "
                             "gets it by default where the refined mesh has at most 12,000 "
                             "tetrahedra (one Levenberg-Marquardt step there), and it also "
                             "gives E and nu extrapolated to a fine mesh")
    checks.add_argument("--mesh-check-refit", action="store_true",
                        help="the mesh check by the whole refit on the refined mesh (about "
                             "16 times the work of the fit)")
    checks.add_argument("--no-mesh-check", action="store_true",
                        help="no mesh check: the intervals hold the noise alone (said so)")
    fit.add_argument("--learning-rate", type=float, default=0.1,
                     help="paper method: η for springs (default 0.1)")
    fit.add_argument("--mass-learning-rate", type=float, default=0.1,
                     help="paper method: η_m for masses (default 0.1)")
    fit.add_argument("--report", help="write an HTML report (and a .json twin): error curve, "
                                      "what the data determine, and with --rules the "
                                      "before/after words")
    fit.add_argument("--out", help="write the fitted model as YAML")
    fit.add_argument("--export", metavar="DIR",
                     help="write the fitted model's simulation of the first experiment next "
                          "to the measurement as ParaView files (VTU series + PVD, XDMF); "
                          "the report links them")
    fit.add_argument("--target", choices=("mujoco", "sofa", "ours"), default=None,
                     help="then fit E, ν, η as this simulator runs them (its element, backward "
                          "Euler at --dt) into --out; prints errors beside a naive export's; "
                          "sofa: its corotational TetrahedronFEMForceField and "
                          "EulerImplicitSolver; ours: our own implicit step on the model's "
                          "element ('simulate --integrator implicit --dt STEP')")
    fit.add_argument("--dt", type=float, default=None, metavar="STEP",
                     help="with --target: its step (s; default 0.016), whole frames")
    fit.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    fit.add_argument("--quiet", action="store_true", help="no progress on stderr")
    fit.set_defaults(run=fitting.fit)

    export = commands.add_parser(
        "export", help="model -> MuJoCo, SOFA, FEBio or ParaView files",
        description="Write a model (YAML) for a simulator: --to mujoco (MJCF .xml: node "
                    "bodies, a flex per region and material, spring tendons), sofa "
                    "(SofaPython3 scene .py), febio (.feb, format 4.0) or vtu (the default: "
                    "simulated and measured trajectories, errors, strains and spring "
                    "parameters as a VTU time series and an XDMF file for ParaView). Every "
                    "file carries the fitted values, their units, the lack of fit recorded by "
                    "'fit --out' and what the target could not express. An experiment sets "
                    "the time step and the load (SOFA, FEBio) and measures what the "
                    "simulators' textbook tetrahedron changes for the nodal volumetric form.")
    export.add_argument("model", metavar="MODEL.yaml")
    export.add_argument("experiment", nargs="?", metavar="EXPERIMENT.npz",
                        help="measured trajectories and load (default: none; vtu shows the "
                             "model at rest)")
    export.add_argument("--to", choices=("vtu", "mujoco", "sofa", "febio"), default="vtu",
                        help="the target (default vtu)")
    export.add_argument("--out", required=True, metavar="PATH",
                        help="the file to write (.xml, .py, .feb), or for vtu a folder")
    export.add_argument("--substeps", default=None,
                        help="steps per frame of the experiment: a number or 'auto' (the "
                             "default: the fewest stable ones)")
    export.add_argument("--max-materials", type=int, default=256, metavar="N",
                        help="most distinct element materials (MuJoCo flexes, FEBio parts) "
                             "before elements are binned (default 256)")
    export.add_argument("--stem", default=None, help="vtu: file name stem (default neurofuzzy)")
    export.add_argument("--every", type=int, default=None,
                        help="vtu: keep every k-th frame (default 1)")
    export.add_argument("--formats", nargs="+", default=None, choices=("vtu", "xdmf"),
                        help="vtu: which ParaView forms (default both)")
    export.set_defaults(run=data.export)

    diagnose = commands.add_parser(
        "diagnose", help="find the physical effect the model lacks",
        description="Fit the model, find where simulation and measurement disagree, name the "
                    "missing effect, add it, refit, and repeat until none is left.")
    diagnose.add_argument("experiments", nargs="+", metavar="EXPERIMENT.npz")
    _start_options(diagnose)
    diagnose.add_argument("--max-effects", type=int, default=3,
                          help="stop after this many effects (default 3)")
    diagnose.add_argument("--substeps", default="auto",
                          help="integration steps per frame: a number, or 'auto' (default), "
                               "as for fit")
    diagnose.add_argument("--no-mesh-check", action="store_true",
                          help="when the final element model still misses the data, do not "
                               "refit it on the mesh refined once to say how much of the "
                               "misfit is the mesh's")
    diagnose.add_argument("--max-time", type=float, metavar="SECONDS",
                          help="answer after about this many seconds with the best answer so "
                               "far, marked provisional (checked between fits)")
    diagnose.add_argument("--window", default="auto", metavar="FRAMES|auto|all",
                          help="diagnose a long recording on its first FRAMES frames of "
                               "motion, then fit the answer on all of them; 'auto' (default): "
                               "the first 60 of a recording with more than 120")
    diagnose.add_argument("--out", help="write the final model (with the effects) as YAML")
    diagnose.add_argument("--report", help="write an HTML report (and a .json twin)")
    diagnose.add_argument("--localise", action="store_true",
                          help="once an inclusion is a candidate, fit every element (or "
                               "spring) with the rule base as a prior: the regions found "
                               "sign the inclusion and are refitted beside it (none: it is "
                               "dropped), and say where the tissue differs from its "
                               "description (needs --rules and --tissue; costs one such fit)")
    diagnose.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    diagnose.add_argument("--quiet", action="store_true", help="no progress on stderr")
    diagnose.set_defaults(run=fitting.diagnose)

    many = commands.add_parser(
        "fit-many", help="fit many specimens as tasks on Dask and compare their groups",
        description="Fit every specimen of a manifest (CSV or YAML: id, group, experiments, "
                    "start or rules + tissue, options) as one independent task on Dask: a "
                    "local cluster of single-threaded processes by default, or an existing "
                    "cluster. Writes one folder per specimen and a table under --out as each "
                    "finishes; --resume keeps what is finished. Exit status 1 when some "
                    "specimens failed (their errors are recorded, the rest are written).")
    many.add_argument("manifest", metavar="MANIFEST", help="CSV or YAML, one row per specimen")
    many.add_argument("--out", required=True, metavar="DIR", help="results folder")
    many.add_argument("--report", metavar="COHORT.html",
                      help="write the cohort report (and a .json twin): materials, words and "
                           "distributions per group, the groups compared")
    many.add_argument("--scheduler", metavar="ADDRESS",
                      help="an existing Dask scheduler (tcp://HOST:PORT) whose workers can "
                           "read the input files (default: a local cluster)")
    many.add_argument("--workers", type=int, default=None, metavar="N",
                      help="processes of the local cluster (default: the cores)")
    many.add_argument("--resume", action="store_true",
                      help="keep the finished specimens in DIR whose inputs are unchanged; "
                           "fit the others")
    many.add_argument("--seed", type=int, default=0,
                      help="seed of the report's bootstrap (default 0)")
    many.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    many.add_argument("--quiet", action="store_true", help="no progress on stderr")
    many.set_defaults(run=batch.fit_many)

    rules = commands.add_parser("rules", help="check and show fuzzy rule bases")
    rules_commands = rules.add_subparsers(dest="rules_command", metavar="ACTION")
    check = rules_commands.add_parser("check", help="validate a rule base and list what it "
                                                    "defines")
    check.add_argument("rules", metavar="R.yaml")
    check.set_defaults(run=misc.rules_check)
    show = rules_commands.add_parser("show", help="inferred start values of a tissue and "
                                                  "their labels")
    show.add_argument("rules", metavar="R.yaml")
    show.add_argument("--tissue", required=True, help="the tissue of the rule base to show")
    show.add_argument("--json", action="store_true", help="print one JSON object on stdout "
                                                          "(values in SI units, labels, degrees)")
    show.set_defaults(run=misc.rules_show)
    rules.set_defaults(run=lambda args: usage(rules))

    studio_command = commands.add_parser(
        "studio", help="edit a rule base in the browser and see it as tissue",
        description="The rule studio: a local web page to edit a rule base's membership "
                    "functions, terms, rules and tissues, see a tissue's inferred values, "
                    "words and fired rules, poke a block of it, compare fit results, and save "
                    "the file back with its comments (needs pip install "
                    "'neurofuzzy[studio]').")
    studio_command.add_argument("rules", nargs="?", metavar="RULES.yaml",
                                help="rule file to open (or a shipped name: liver, brain, "
                                     "…); default: choose among the current folder's")
    studio_command.add_argument("--host", default=None,
                                help="address to listen on (default 127.0.0.1, localhost "
                                     "only); when given, every request needs the token in "
                                     "the printed URL")
    studio_command.add_argument("--port", type=int, default=0,
                                help="port (default: any free one)")
    studio_command.add_argument("--no-browser", action="store_true",
                                help="do not open a browser; print the URL")
    studio_command.set_defaults(run=studio.studio)

    simulate = commands.add_parser(
        "simulate", help="simulate a model under a load and write an experiment file",
        description="Simulate a fitted model (YAML) or the built-in cube ('cube') from rest "
                    "under constant node forces and write an experiment file (.npz; "
                    f"{FORMAT_DOC}).")
    simulate.add_argument("model", metavar="MODEL.yaml|cube")
    simulate.add_argument("--out", required=True, metavar="EXPERIMENT.npz",
                          help="the experiment file to write")
    simulate.add_argument("--force", nargs=4, action="append", metavar=("NODE", "FX", "FY", "FZ"),
                          help="constant force on a node, FX FY FZ in newtons (repeatable; "
                               "default: the cube's 0.2 N load on its top centre node)")
    simulate.add_argument("--dt", type=float, default=None,
                          help="frame spacing (s; default 0.0005, the built-in cube's)")
    simulate.add_argument("--frames", type=int, default=251,
                          help="frames incl. frame 0 (default 251)")
    simulate.add_argument("--substeps", default="1",
                          help="steps per frame, or 'auto': the fewest stable ones (default 1)")
    simulate.add_argument("--integrator", choices=("explicit", "implicit", "bdf2"),
                          default="explicit",
                          help="explicit: the paper's semi-implicit Euler, stable below the "
                               "model's stable step (default); implicit: backward Euler, one "
                               "Newton iteration a step, stable at any step, as a simulator "
                               "runs at 16 ms (MuJoCo's discrete integrator); bdf2: the "
                               "second-order backward differentiation formula, the same way")
    simulate.add_argument("--noise", type=float, default=0.0,
                          help="marker noise: standard deviation per coordinate (m; default 0)")
    simulate.add_argument("--seed", type=int, default=0,
                          help="seed of the marker noise (default 0)")
    simulate.set_defaults(run=data.simulate)

    mesh = commands.add_parser(
        "mesh", help="mesh file + rule base -> model (YAML)",
        description="Build a model of tetrahedral finite elements (or, with --elements "
                    "springs, a spring network) from a mesh file (a closed surface: STL, OBJ, "
                    "PLY, GLB -> voxel lattice or, with --tetra, tetrahedra; a volume mesh: "
                    "VTU, VTK, Gmsh .msh) and give it start values from a rule base's "
                    "tissue(s).")
    mesh.add_argument("mesh", metavar="MESH")
    mesh.add_argument("--rules", required=True, help="rule base: a YAML file or a shipped name")
    mesh.add_argument("--tissue", help="tissue of the whole object (or of the regions not "
                                       "named by --region)")
    mesh.add_argument("--region", action="append", default=[], metavar="REGION=TISSUE",
                      help="tissue of a region of a volume mesh (repeatable; default: "
                           "--tissue everywhere)")
    mesh.add_argument("--pitch", type=float, help="voxel lattice spacing of a surface (in the "
                                                  "file's length unit; default extent / 10)")
    mesh.add_argument("--tetra", action="store_true",
                      help="tetrahedralise a surface (tetgen) instead of voxelising it")
    mesh.add_argument("--max-edge", type=float, help="with --tetra: target edge length "
                                                     "(default 1.5 x extent / 10)")
    mesh.add_argument("--scale", type=float, default=1.0,
                      help="multiply coordinates by this to get metres (e.g. 0.001 for mm; "
                           "default 1)")
    fixing = mesh.add_mutually_exclusive_group()
    fixing.add_argument("--fix-bottom", action="store_true",
                        help="hold the lowest nodes (along --up, within a quarter of the "
                             "shortest spring of the minimum) in place")
    fixing.add_argument("--fix-below", type=float, metavar="Z",
                        help="hold the nodes with z <= Z (metres) in place")
    mesh.add_argument("--drive-top", action="store_true",
                      help="the highest nodes (along --up, within a quarter of the shortest "
                           "spring of the maximum) are a plate's face, moved by the stage in "
                           "a load-step test ('import --displacements PLATE.csv' drives them)")
    mesh.add_argument("--up", default="z", choices=tools.AXES,
                      help="the axis pointing up, for --fix-bottom and --drive-top (default "
                           "z): scans whose up is not +z")
    mesh.add_argument("--elements", choices=("tetra", "springs"), default="tetra",
                      help="tetra (default): linear tetrahedral finite elements whose "
                           "parameters are the tissue's Young's modulus, Poisson's ratio and "
                           "viscosity (a voxel lattice is split into six tetrahedra per cell); "
                           "springs: the paper's spring network on the mesh's edges")
    mesh.add_argument("--law", choices=LAWS, default=LAWS[0],
                      help="with --elements tetra: the elements' material law (default "
                           f"{LAWS[0]}). {_laws()}")
    mesh.add_argument("--tie", choices=("global", "groups", "none"), default="groups",
                      help="parameters shared by all items, per group (default) or none, "
                           "within each region; a fit with --start keeps it")
    mesh.add_argument("--out", required=True, metavar="MODEL.yaml",
                      help="the model file to write (the start of 'fit --start')")
    mesh.set_defaults(run=data.mesh)

    add_import(commands, run=data.import_markers)
    return parser


def _start_options(command) -> None:
    """Where a fit starts (:func:`neurofuzzy.pipeline.start_model`), shared by fit and diagnose."""
    command.add_argument("--start", metavar="MODEL.yaml",
                         help="start from a model file (written by 'neurofuzzy mesh' or a "
                              "previous fit), keeping its regions, tissues, masses and tie "
                              "groups")
    command.add_argument("--rules", help="start from a rule base (a YAML file, or the name of "
                                         "a shipped one: liver, brain, kidney, …) …")
    command.add_argument("--tissue", help="… and this tissue of it")
    command.add_argument("--elements", choices=("tetra", "springs"), default=None,
                         help="with --rules: tetrahedral elements (the default when the "
                              "experiment has tetrahedra) or the spring network on the mesh's "
                              "edges (the paper's learner always uses springs)")
    command.add_argument("--law", choices=LAWS, default=None,
                         help="the tetrahedral elements' material law, all with the same E "
                              "and ν at small strain (default: the start model's own, else "
                              f"{LAWS[0]}). {_laws()}")
    command.add_argument("--stiffening", type=float, metavar="C", default=None,
                         help="with --law yeoh: Yeoh's C20/C10 to start from (>= 0; default "
                              "the start model's own, else 1: 1.65 times as stiff as "
                              "neo-Hookean at 30 %% compression); with --law mooney-rivlin "
                              "its C01/C10 (default 1); fitted per region")
    command.add_argument("--relaxation", metavar="TERMS", default=None,
                         help="the tetrahedral elements relax (Prony series on top of their "
                              "law, FEBio's convention: E is the long-term modulus): a number "
                              "of terms to fit (1-3), or their start values as g:tau pairs, "
                              "e.g. 0.5:0.05 (default: the start model's own, else none)")
    command.add_argument("--tie", choices=("global", "groups", "none"), default=None,
                         help="share spring parameters: one value for all springs, one per "
                              "spring group, or one per spring, within each region (default: "
                              "the start model's own tying, else groups)")
