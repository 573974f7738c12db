"""The ``import`` command's arguments (the command shapes of the design notes): marker
recordings in time, scans at load steps with the plate that drove them, or an indenter's
path."""

from __future__ import annotations

from .tools import AXES

#: where the experiment file (.npz) is documented in the repository
FORMAT_DOC = "the format: docs/formats.md, section 'Experiment files'"

__all__ = ["add_import", "FORMAT_DOC"]


def add_import(commands, *, run) -> None:
    """Add ``import`` to the subparsers ``commands``; ``run`` carries it out."""
    importer = commands.add_parser(
        "import", help="marker recording (CSV or C3D) -> experiment file",
        description="Attach the markers of an optical recording to the nodes of a model, "
                    "resample to the model's step and write an experiment file (.npz; "
                    f"{FORMAT_DOC}; nodes with markers observed; frames where a marker "
                    "was not seen are gaps, never interpolated across).")
    importer.add_argument("markers", metavar="MARKERS.csv|MARKERS.c3d", nargs="?",
                          help="the marker recording (a load-step import may do without: "
                               "the plate file's load cell alone)")
    importer.add_argument("--topology", required=True, metavar="MODEL.yaml|EXPERIMENT.npz",
                          help="the object's nodes and springs: a model (its masses become the "
                               "experiment's known masses) or another experiment file")
    importer.add_argument("--map", metavar="MAP.csv",
                          help="marker,node pairs: each marker follows its node (--attach "
                               "node); default: no map, markers embedded in the mesh unless "
                               "--attach node, which takes each marker's nearest node")
    importer.add_argument("--forces", metavar="FORCES.csv",
                          help="time,node,fx,fy,fz in N, each row held until the node's next; "
                               "or time,x,y,z,fx,fy,fz[,radius]: a probe's force at a point "
                               "(unit in a '# length units: mm' line), a uniform traction "
                               "within the contact radius, else given to the nearest surface "
                               "node")
    importer.add_argument("--attach", choices=("auto", "embed", "node"), default="auto",
                          help="embed: each marker in the tetrahedron that contains it, "
                               "observed by barycentric interpolation (lattices are split into "
                               "tetrahedra for this); node: each marker follows its nearest "
                               "node (or --map), its frame-0 offset removed; auto (default): "
                               "node with --map or a time,node,... file, else embed")
    importer.add_argument("--probe-radius", type=float, default=None, metavar="R",
                          help="contact radius of the probes of a point-force CSV without a "
                               "radius column (m): the force becomes a uniform traction on the "
                               "surface within R of the point")
    importer.add_argument("--force-spread", type=int, default=None, metavar="K",
                          help="share each point force among the K nearest surface nodes "
                               "(inverse-distance weights; default 1)")
    importer.add_argument("--units", choices=("m", "cm", "mm"),
                          help="length unit of the marker file (required unless the file "
                               "states it: a CSV's '# units: mm' line, a C3D's POINT:UNITS; "
                               "if both, they must agree)")
    importer.add_argument("--dt", type=float, default=None,
                          help="the model's step (s) to resample to (default: the topology "
                               "file's dt, else the capture's frame period)")
    importer.add_argument("--max-distance", type=float, default=None,
                          help="farthest a marker may lie from its node (--attach node) or "
                               "outside the mesh (embed) at the start (m; default half the "
                               "shortest spring)")
    importer.add_argument("--displacements", metavar="PLATE.csv",
                          help="a load-step file's plate (MARKERS.csv with a 'step' column: "
                               "scans at load steps, step 0 the reference): step,dx,dy,dz"
                               "[,fx,fy,fz], the top plate's displacement per step and, where "
                               "a load cell was read, its force ('# length units:' and "
                               "'# force units:' lines); writes a load-step file")
    importer.add_argument("--up", default="z", choices=AXES,
                          help="with --displacements: the axis the plate moves along, "
                               "pointing away from the fixed bottom (default z; a negative "
                               "one as --up=-z)")
    importer.add_argument("--drive-markers", metavar="NAMES",
                          help="a load-step file's measured boundary: the node under each of "
                               "these markers (A,B,...) moved along that marker's scans, the "
                               "markers no longer fitted; with --displacements beside the "
                               "plate, without it the whole driven boundary")
    importer.add_argument("--plate", choices=("bonded", "sliding"), default="bonded",
                          help="with --displacements: the plate holds the top face in every "
                               "direction (bonded, the default) or only along --up "
                               "(frictionless, sliding)")
    importer.add_argument("--tool", metavar="KIND:R=RADIUS",
                          help="a load-step file's indenter, rigid and frictionless: "
                               "sphere:R=5mm or punch:R=2mm (a flat punch whose face is "
                               "normal to --up), or surface:FILE,units=mm, a closed triangle "
                               "surface (STL, OBJ, PLY, OFF: an instrument's tip) whose "
                               "origin is the point --tool-path places; with --tool-path")
    importer.add_argument("--tool-path", metavar="PATH.csv",
                          help="with --tool: step,x,y,z[,qw,qx,qy,qz][,fx,fy,fz], the tool's "
                               "reference "
                               "point (a sphere's centre, a punch's face centre, a surface's "
                               "origin) at the "
                               "reference scan (step 0, clear of the body) and at each step, "
                               "and where a load cell was read the force the tool exerts on "
                               "the body ('# length units:' and '# force units:' lines); or a "
                               "C3D recording of markers fixed to the tool (with "
                               "--tool-frames and --tool-tip); the body is held by the model's "
                               "fixed nodes")
    importer.add_argument("--tool-force", metavar="FORCE.csv",
                          help="with --tool: the tool's load cell in a file of its own, "
                               "step,fx,fy,fz (or time,fx,fy,fz for a recording in time) with a "
                               "'# force units:' line: the force the tool exerts on the body, "
                               "where the path comes from elsewhere (a tracker's C3D, a robot's "
                               "log)")
    importer.add_argument("--tool-frames", metavar="F0,F1,...",
                          help="with --tool-path TOOL.c3d (a tracked rigid body: the markers "
                               "fixed to the tool): the recording's frame (0 its first) at the "
                               "reference scan and at each load step")
    importer.add_argument("--tool-tip", metavar="X,Y,Zmm",
                          help="with --tool-path TOOL.c3d: the tool's reference point at the "
                               "reference scan's frame, in the recording's coordinates, with "
                               "its unit (10,10,25mm); the cluster's rigid motion from there "
                               "moves and turns the tool")
    importer.add_argument("--tool-markers", metavar="A,B,C",
                          help="with --tool-path TOOL.c3d: the labels of the tool's markers "
                               "(default: every point of the file)")
    importer.add_argument("--out", required=True, metavar="EXPERIMENT.npz",
                          help="the experiment file to write")
    importer.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    importer.set_defaults(run=run)
