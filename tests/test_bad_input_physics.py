"""The bad-input corpus, second round (issue 28): inputs that are well formed but physically
absurd. Each goes through the command line in-process and must exit 2 with one line naming
the file and line (or the option), with the fix, leaving nothing behind (``refused``); a value
that is possible but unusual is a warning on stderr and the command goes on."""

import re

import numpy as np
import pytest
from test_bad_input import refused

from neurofuzzy.cli import main
from neurofuzzy.errors import InputError
from neurofuzzy.rules import load_rules, shipped

SOFT = shipped("soft_tissue").read_text()
E_OUTPUT = "  youngs_modulus:\n    quantity: youngs_modulus\n"
EXTRA_E = ("  {name}:\n    quantity: youngs_modulus\n"
           "    universe: {{min: 100, max: 300000, scale: log, unit: Pa}}\n"
           "    terms: {{soft: {{trimf: [400, 1500, 4000]}}}}\n")


def _line_of(text, needle):
    return text[:text.index(needle)].count("\n") + 1


def _soft(old, new):
    assert old in SOFT
    return SOFT.replace(old, new)


# -- rule files: physical limits per quantity --------------------------------------------------
RULE_FILES = [
    ("poisson universe to 0.7", _soft("universe: [0, 0.5]", "universe: [0, 0.7]"),
     "universe: [0, 0.7]", "poisson_ratio: the universe [0, 0.7] goes beyond what Poisson's "
                           "ratio can be (0 to 0.5"),
    ("negative Young's modulus", _soft("universe: {min: 100, max: 300000, scale: log, unit: Pa}",
                                       "universe: [-1000, 300000]"),
     "universe: [-1000", "youngs_modulus: the universe [-1000, 300000] goes beyond what Young's "
                         "modulus can be (positive values"),
    ("lom reaches nu = 0.5", _soft("defuzzification: centroid", "defuzzification: lom"),
     "defuzzification: lom", "defuzzification lom can give Poisson's ratio = 0.5 exactly"),
    ("som reaches nu = 0", _soft("defuzzification: centroid", "defuzzification: som"),
     "defuzzification: som", "defuzzification som can give Poisson's ratio = 0 exactly"),
    ("a term beyond 0.5", _soft("[0.42, 0.47, 0.5, 0.5]", "[0.42, 0.47, 0.5, 0.6]"),
     "[0.42, 0.47, 0.5, 0.6]", "Poisson's ratio at 0.6 is impossible"),
    ("kPa read as Pa", _soft("max: 300000, scale: log, unit: Pa}", "max: 300000, scale: log, "
                                                                   "unit: kPa}"),
     "unit: kPa", "unit 'kPa' is not the unit of Young's modulus (Pa); write the universe and "
                  "the terms in Pa (1 kPa = 1000 Pa)"),
    ("density in g/cm3", _soft("universe: [850, 1200]", "universe: [0.85, 1.2]")
     .replace("[850, 850, 910, 1000]", "[0.85, 0.85, 0.91, 1]")
     .replace("[980, 1045, 1100]", "[0.98, 1.045, 1.1]")
     .replace("[1060, 1120, 1200, 1200]", "[1.06, 1.12, 1.2, 1.2]"),
     "universe: [0.85", "were the values written in g/cm^3?"),
    ("deprecated name beside the current one",
     _soft("  viscosity:\n    quantity: viscosity", EXTRA_E.format(name="stiffness")
           + "  viscosity:\n    quantity: viscosity"),
     "  stiffness:", "output 'stiffness' stands for youngs_modulus (its old name), and output "
                     "'youngs_modulus' (line"),
    ("two outputs of one quantity",
     _soft("  viscosity:\n    quantity: viscosity", EXTRA_E.format(name="E")
           + "  viscosity:\n    quantity: viscosity"),
     "  E:", "outputs 'youngs_modulus' (line"),
    ("unknown quantity", _soft("    quantity: density", "    quantity: densty"),
     "quantity: densty", "density: unknown quantity 'densty'; did you mean 'density'?"),
]


@pytest.mark.parametrize("text, at, words", [case[1:] for case in RULE_FILES],
                         ids=[case[0] for case in RULE_FILES])
def test_rule_files_beyond_physics_are_refused_with_one_root_error(tmp_path, capsys, text, at,
                                                                   words):
    path = tmp_path / "r.yaml"
    path.write_text(text)
    line = _line_of(text, at)
    message = refused(capsys, ["rules", "check", path], names=[f"{path}:{line}:", words],
                      folder=tmp_path, seconds=5)
    assert message.count("neurofuzzy: error") == 1


def test_a_broken_definition_is_reported_once_not_at_every_use(tmp_path):
    """An input whose universe is impossible is used by rules and every tissue: only its
    definition is reported; likewise a broken term."""
    for old, new, line in (("  consistency:                 # how hard it feels when pressed "
                            "(palpation), 0 = fluid, 10 = bone\n    universe: [0, 10]",
                            "  consistency:\n    universe: [10, 0]", "universe: [10, 0]"),
                           ("firm:  {trimf: [2, 4.5, 7]}", "firm:  {trimf: [7, 4.5, 2]}",
                            "firm:  {trimf: [7"),
                           ("[0.42, 0.47, 0.5, 0.5]", "[0.42, 0.47, 0.5, 0.9]", "0.5, 0.9]")):
        text = _soft(old, new)
        path = tmp_path / "r.yaml"
        path.write_text(text)
        with pytest.raises(InputError) as caught:
            load_rules(path)
        lines = str(caught.value).splitlines()
        assert lines == [lines[0]] and lines[0].startswith(f"{path}:{_line_of(text, line)}:"), \
            lines


def test_the_shipped_rule_bases_are_within_physics():
    for name in ("soft_tissue", "liver", "brain", "kidney", "muscle", "fat"):
        rules = load_rules(shipped(name))
        for tissue in rules.tissues:
            values = rules.tissue(tissue)
            assert 0 < values["poisson_ratio"] < 0.5 and values["youngs_modulus"] > 0


def test_an_impossible_inferred_value_names_the_file_the_tissue_and_its_line(tmp_path):
    """The safety net behind the file checks: a rule base whose tissue infers an impossible
    value (here by changing the defuzzification after loading) is refused at use, naming
    FILE:LINE of the tissue and the quantity in words."""
    rules = load_rules(shipped("liver"))
    rules.defuzzification = "lom"
    line = _line_of(shipped("liver").read_text(), "  liver: ")
    with pytest.raises(InputError, match=re.escape(f"{shipped('liver')}:{line}: tissue 'liver': "
                                                   "its words give Poisson's ratio = 0.5")):
        rules.tissue("liver")


# -- the body and its recording ------------------------------------------------------------------
@pytest.fixture(scope="module")
def block(tmp_path_factory):
    """A 4 x 4 x 3 cm block of liver (1 cm cells, bottom held) meshed by the command, pushed
    by a 0.05 N probe on its top centre from 20 ms on; 57 surface markers at 1 kHz (mm) and
    the probe's force file (points in mm)."""
    import trimesh

    import neurofuzzy as nf
    from neurofuzzy.io import load_model
    from neurofuzzy.mesh import patch_loads, surface_nodes

    folder = tmp_path_factory.mktemp("block")
    box = trimesh.creation.box(extents=(0.04, 0.04, 0.03))
    box.apply_translation((0.02, 0.02, 0.015))
    box.export(folder / "block.stl")
    box.apply_scale(1000.0)
    box.export(folder / "block_mm.stl")
    assert main(["mesh", str(folder / "block.stl"), "--pitch", "0.01", "--fix-bottom",
                 "--rules", "liver", "--tissue", "liver", "--out",
                 str(folder / "block.yaml")]) == 0
    model = load_model(folder / "block.yaml")
    mesh = model.mesh
    loads = np.zeros((121, mesh.n_nodes, 3))
    loads[20:] = patch_loads(mesh, (0.02, 0.02, 0.03), 0.008, (0, 0, -0.05))
    motion = nf.simulate(model, dt=1e-3, n_frames=121, external_forces=loads,
                         substeps="auto").positions
    nodes = np.flatnonzero(surface_nodes(mesh) & mesh.free)
    rows = [(t, k, 1e3 * motion[t, node]) for t in range(121) for k, node in enumerate(nodes)]

    def markers(name, *, time=1e-3, head="# units: mm\n"):
        (folder / name).write_text(head + "time,marker,x,y,z\n" + "".join(
            f"{t * time:.6g},M{k},{x:.5f},{y:.5f},{z:.5f}\n" for t, k, (x, y, z) in rows))
        return folder / name

    markers("markers.csv")
    markers("markers_ms.csv", time=1.0)
    top = int(np.argmin(np.linalg.norm(mesh.rest_positions - (0.02, 0.02, 0.03), axis=1)))
    return {"folder": folder, "model": folder / "block.yaml", "mesh": mesh, "top": top,
            "markers": folder / "markers.csv", "markers_ms": folder / "markers_ms.csv",
            "write_markers": markers}


def _probe(block, text, name="probe.csv"):
    path = block["folder"] / name
    path.write_text(text)
    return path


PROBE = "# length units: mm\ntime,x,y,z,fx,fy,fz\n0,20,20,30,0,0,0\n0.02,20,20,30,0,0,-0.05\n"


def test_a_millimetre_mesh_without_scale_is_refused_with_the_factor(block, tmp_path, capsys):
    refused(capsys, ["mesh", block["folder"] / "block_mm.stl", "--rules", "liver", "--tissue",
                     "liver", "--fix-bottom", "--out", tmp_path / "m.yaml"],
            names=["block_mm.stl", "the mesh spans 40 m, which a body of liver cannot",
                   "did you mean --scale 0.001"], folder=tmp_path)
    assert main(["mesh", str(block["folder"] / "block_mm.stl"), "--scale", "0.001", "--pitch",
                 "10", "--rules", "liver", "--tissue", "liver", "--fix-bottom", "--out",
                 str(tmp_path / "m.yaml")]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("case", ["markers in ms", "unit twice", "forces in ms",
                                  "point in m labelled mm", "radius and node forces",
                                  "radius beyond the body", "radius twice",
                                  "spread and node forces", "forces of another mesh",
                                  "node force on a fixed node", "force unit of a length",
                                  "unknown unit statement"])
def test_recordings_and_loads_that_cannot_be_right_are_refused(block, tmp_path, capsys, case):
    top, fixed = block["top"], int(block["mesh"].fixed[0])
    markers, args = block["markers"], []
    node_file = f"time,node,fx,fy,fz\n0.02,{top},0,0,-0.05\n"
    probe, names = {
        "markers in ms": (PROBE, ["markers_ms.csv", "frames 1 s apart", "milliseconds",
                                  "'# time units: ms'"]),
        "unit twice": (PROBE, ["markers.csv:1:", "the length unit is given twice, differently: "
                                                "'# units: mm' (line 1) and m (--units)"]),
        "forces in ms": (PROBE.replace("0.02,", "20,"), ["probe.csv:4:", "after the recording "
                                                         "ends", "milliseconds"]),
        "point in m labelled mm": (PROBE.replace("20,20,30", "0.02,0.02,0.03"),
                                   ["probe.csv:4:", "lies on fixed nodes only", "with "
                                    "'# length units: m' it would touch the surface"]),
        "radius and node forces": (node_file, ["probe.csv", "--probe-radius", "names nodes"]),
        "radius beyond the body": (PROBE, ["--probe-radius", "a probe's contact radius of "
                                           "0.5 m on a body 0.04 m across cannot be right"]),
        "radius twice": (PROBE.replace("fz\n", "fz,radius\n").replace("0\n", "0,5\n")
                         .replace("-0.05\n", "-0.05,5\n"), ["probe.csv", "radius column",
                                                            "give it once"]),
        "spread and node forces": (node_file, ["probe.csv", "--force-spread", "names nodes"]),
        "forces of another mesh": ("# mesh: 64 nodes 0123456789abcdef\n" + node_file,
                                   ["probe.csv:1:", "made for another mesh", "at points"]),
        "node force on a fixed node": (node_file.replace(f",{top},", f",{fixed},"),
                                       ["probe.csv:2:", f"node {fixed} is fixed"]),
        "force unit of a length": ("# units: mm\n" + PROBE, ["probe.csv:1:", "'# units: mm' is "
                                                             "ambiguous in a force file"]),
        "unknown unit statement": (PROBE.replace("length units", "lenght units"),
                                   ["probe.csv:1:", "did you mean '# length units:'?"]),
    }[case]
    args = {"markers in ms": [], "unit twice": ["--units", "m"],
            "radius and node forces": ["--probe-radius", "0.005"],
            "radius beyond the body": ["--probe-radius", "0.5"],
            "radius twice": ["--probe-radius", "0.005"],
            "spread and node forces": ["--force-spread", "3"]}.get(case, [])
    if case == "markers in ms":
        markers = block["markers_ms"]
    forces = _probe(block, probe)
    refused(capsys, ["import", markers, "--topology", block["model"], "--forces", forces,
                     "--out", tmp_path / "t.npz", *args], names=names, folder=tmp_path)


def test_stated_units_are_honoured(block, tmp_path, capsys):
    """'# force units: mN' and '# time units: ms' are read, never ignored: the same load as
    newtons and seconds; a node file made for this mesh is read without a warning."""
    from neurofuzzy.io import load_experiment
    from neurofuzzy.markers import write_node_forces

    loads = {}
    files = {"N, s": PROBE,
             "mN, ms": PROBE.replace("mm\n", "mm\n# force units: mN\n# time units: ms\n")
             .replace("0.02,20", "20,20").replace("-0.05", "-50")}
    for label, text in files.items():
        out = tmp_path / f"{len(loads)}.npz"
        assert main(["import", str(block["markers"]), "--topology", str(block["model"]),
                     "--forces", str(_probe(block, text)), "--out", str(out)]) == 0
        loads[label] = load_experiment(out).external_forces
    assert np.allclose(loads["N, s"], loads["mN, ms"])
    assert np.allclose(loads["N, s"].sum(axis=1)[-1], [0, 0, -0.05])
    assert np.abs(loads["N, s"][:20]).max() == 0 and np.abs(loads["N, s"][20]).max() > 0
    nodes = write_node_forces(block["folder"] / "nodes.csv", [(0.02, block["top"], 0, 0, -0.05)],
                              block["mesh"])
    capsys.readouterr()
    assert main(["import", str(block["markers"]), "--topology", str(block["model"]),
                 "--forces", str(nodes), "--out", str(tmp_path / "n.npz")]) == 0
    assert "warning" not in capsys.readouterr().err
    nodes.write_text("\n".join(nodes.read_text().splitlines()[1:]) + "\n")     # no '# mesh:'
    assert main(["import", str(block["markers"]), "--topology", str(block["model"]),
                 "--forces", str(nodes), "--out", str(tmp_path / "m.npz")]) == 0
    err = capsys.readouterr().err
    assert "neurofuzzy: warning: " in err and "no '# mesh:' line" in err and "at points" in err


def test_unusual_but_possible_values_are_warned_about_and_the_command_goes_on(block, tmp_path,
                                                                              capsys):
    """A probe pressing near the held bottom edge loads fixed nodes with part of its force:
    a warning names the line and the share, and the experiment is written."""
    edge = _probe(block, PROBE.replace("fz\n", "fz,radius\n").replace("20,20,30", "0,20,4")
                  .replace("0\n", "0,8\n").replace("-0.05\n", "-0.05,8\n"), "edge.csv")
    out = tmp_path / "t.npz"
    assert main(["import", str(block["markers"]), "--topology", str(block["model"]),
                 "--forces", str(edge), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert re.search(r"neurofuzzy: warning: .*edge.csv:4: \d+ % of this force falls on fixed "
                     r"nodes", err), err
    assert out.exists()


# -- fits: the start against the data -----------------------------------------------------------
@pytest.fixture(scope="module")
def imported(block, tmp_path_factory):
    """The block's recording imported as an experiment, and one whose dt says seconds where
    the recording had milliseconds."""
    from test_bad_input import npz

    folder = tmp_path_factory.mktemp("imported")
    good = folder / "trial.npz"
    assert main(["import", str(block["markers"]), "--topology", str(block["model"]),
                 "--forces", str(_probe(block, PROBE, "probe_ok.csv")), "--out",
                 str(good)]) == 0
    with np.load(good) as archive:
        arrays = {key: archive[key] for key in archive.files}
    arrays["dt"] = np.array(1.0)
    return {"good": good, "seconds": npz(folder, arrays, name="seconds.npz")}


@pytest.mark.parametrize("args, names", [
    (["SECONDS", "--rules", "liver", "--tissue", "liver"],
     ["seconds.npz", "frames 1 s apart", "milliseconds", "--substeps N"]),
    (["SECONDS", "--start", "MODEL"], ["seconds.npz", "frames 1 s apart"]),
    (["GOOD", "--start", "MODEL", "--rules", "liver", "--tissue", "livr"],
     ["liver.yaml", "no tissue 'livr' (--tissue); did you mean 'liver'?"]),
    (["GOOD", "--tissue", "liver"], ["--tissue", "give the rule base too (--rules R)"]),
    (["GOOD", "--rules", "liver", "--tissue", "fat"], ["liver.yaml", "no tissue 'fat'"]),
])
def test_fits_whose_start_cannot_match_the_data_are_refused(block, imported, tmp_path, capsys,
                                                             args, names):
    args = [{"SECONDS": imported["seconds"], "GOOD": imported["good"],
             "MODEL": block["model"]}.get(a, a) for a in args]
    refused(capsys, ["fit", *args, "--quiet", "--out", tmp_path / "f.yaml"], names=names,
            folder=tmp_path)


def test_a_model_of_another_object_names_the_model_file(block, files_cube, tmp_path, capsys):
    """The experiment and the start model disagree: the message names both files; a model
    of the same numbering but ten times the size is another body."""
    from neurofuzzy.io import load_model, save_model

    refused(capsys, ["diagnose", files_cube["npz"], "--start", block["model"], "--quiet"],
            names=["cube.npz", "has 27 nodes; the model", "block.yaml has 100"],
            folder=tmp_path)
    cube = load_model(files_cube["model"])
    big = save_model(_scaled(cube, 10), tmp_path / "big.yaml")
    refused(capsys, ["fit", files_cube["npz"], "--start", big, "--quiet"],
            names=["cube.npz", "big.yaml spans 0.2 m", "10 times apart"], folder=tmp_path)


@pytest.fixture(scope="module")
def files_cube(tmp_path_factory, cube_model, cube_experiment):
    from neurofuzzy.io import save_experiment, save_model

    folder = tmp_path_factory.mktemp("cube")
    return {"npz": save_experiment(cube_experiment.first_frames(40), folder / "cube.npz"),
            "model": save_model(cube_model, folder / "cube.yaml")}


# -- regions of a volume mesh --------------------------------------------------------------------
@pytest.fixture(scope="module")
def organ(tmp_path_factory):
    """A 4 x 4 x 2 cm block (Gmsh) whose top-centre cells are a region 'tumour'."""
    from helpers import write_gmsh

    from neurofuzzy.datasets import kuhn_block

    folder = tmp_path_factory.mktemp("organ")
    points, tetrahedra = kuhn_block((4, 4, 2), 0.01)
    centre = points[tetrahedra].mean(axis=1)
    tumour = (np.abs(centre[:, 0] - 0.02) < 0.01) & (np.abs(centre[:, 1] - 0.02) < 0.01) & (
        centre[:, 2] > 0.01)
    return write_gmsh(folder / "organ.msh", points, tetrahedra, np.where(tumour, 2, 1),
                      {1: "organ", 2: "tumour"})


@pytest.mark.parametrize("regions, names", [
    (["organ=liver", "tumour=tumour", "tumour=liver"],
     ["--region", "region 'tumour' is given twice (tumour=tumour and tumour=liver)"]),
    (["organ=liver"], ["organ.msh", "--region", "region 'tumour' of the mesh has no tissue: "
                                                "give --region tumour=TISSUE"]),
    (["organ=liver", "tumor=tumour"], ["organ.msh", "--region", "no region 'tumor'; did you "
                                                                "mean 'tumour'?"]),
    (["organ=liver", "tumour=tumor"], ["liver.yaml", "no tissue 'tumor' (--region "
                                                     "tumour=tumor); did you mean 'tumour'?"]),
])
def test_regions_without_one_tissue_each_are_refused(organ, tmp_path, capsys, regions, names):
    args = [a for region in regions for a in ("--region", region)]
    refused(capsys, ["mesh", organ, "--rules", "liver", *args, "--out", tmp_path / "m.yaml"],
            names=names, folder=tmp_path)


def test_regions_of_a_surface_are_refused(block, tmp_path, capsys):
    refused(capsys, ["mesh", block["folder"] / "block.stl", "--rules", "liver", "--region",
                     "organ=liver", "--out", tmp_path / "m.yaml"],
            names=["block.stl", "--region", "has no regions, so no region 'organ' "
                                              "(organ=liver)"], folder=tmp_path)


# -- model files --------------------------------------------------------------------------------
def test_an_element_model_file_beyond_physics_names_line_element_and_tissue(block, tmp_path,
                                                                            capsys):
    import yaml

    data = yaml.safe_load(block["model"].read_text())
    data["elements"]["poisson_ratio"][3] = 0.5
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data, default_flow_style=None, width=100, sort_keys=False))
    line = _line_of(bad.read_text(), "  poisson_ratio: [")
    refused(capsys, ["simulate", bad, "--frames", "3", "--out", tmp_path / "x.npz"],
            names=[f"bad.yaml:{line}: elements.poisson_ratio: element 3 (region 'liver', "
                   "tissue 'liver') has Poisson's ratio 0.5; it must lie in (0, 0.5)"],
            folder=tmp_path)


@pytest.mark.parametrize("key", ["stiffness", "damping"])
def test_per_spring_lists_shorter_than_the_springs_are_refused_beside_elements(
        block, tmp_path, capsys, key):
    """An element model's idle springs (stiffness and damping 0) are no term, but lists one
    shorter than the springs are a file that disagrees with itself (issue 49)."""
    import yaml

    data = yaml.safe_load(block["model"].read_text())
    assert "elements" in data and not any(data["springs"][key])
    count = len(data["springs"]["nodes"])
    data["springs"][key] = data["springs"][key][:-1]
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data, default_flow_style=None, width=100, sort_keys=False))
    line = _line_of(bad.read_text(), f"  {key}: [")
    refused(capsys, ["simulate", bad, "--frames", "3", "--out", tmp_path / "x.npz"],
            names=[f"bad.yaml:{line}: springs.{key}: got shape ({count - 1},); expected "
                   f"(n_springs,) = ({count},)"], folder=tmp_path)


@pytest.mark.parametrize("args, names", [
    (["simulate", "MODEL", "--noise", "0.5", "--frames", "3"],
     ["--noise", "a marker noise of 0.5 m on a body 0.04 m across cannot be right"]),
    (["import", "MARKERS", "--topology", "MODEL", "--max-distance", "5"],
     ["--max-distance", "5 m on a body 0.04 m across"]),
    (["mesh", "STL", "--rules", "liver", "--tissue", "liver", "--fix-below", "0.5"],
     ["--fix-below", "at or above the top of the mesh"]),
])
def test_lengths_given_as_options_are_checked_against_the_body(block, tmp_path, capsys, args,
                                                               names):
    args = [{"MODEL": block["model"], "MARKERS": block["markers"],
             "STL": block["folder"] / "block.stl"}.get(a, a) for a in args]
    refused(capsys, [*args, "--out", tmp_path / "out.x"], names=names, folder=tmp_path)


def test_markers_in_one_corner_of_a_mesh_in_another_unit_are_refused(block, tmp_path, capsys):
    """A mesh 60 times too large (2.4 m: possible, so only warned about) holds the markers of
    the real 4 cm block in one corner: the import is refused, naming both scales."""
    from neurofuzzy.io import load_model, save_model

    model = load_model(block["model"])
    big = save_model(_scaled(model, 60), tmp_path / "big.yaml")
    refused(capsys, ["import", block["markers"], "--topology", big, "--out", tmp_path / "t.npz"],
            names=["markers.csv", "the markers span", "of the mesh", "big.yaml",
                   "sit in one corner of it"], folder=tmp_path)


def _scaled(model, factor):
    """``model`` on its mesh scaled by ``factor`` (the springs at the new mesh's rest lengths)."""
    from dataclasses import replace

    from neurofuzzy.forces import Springs

    terms = tuple(term.replace(rest_length=None) if isinstance(term, Springs) else term
                  for term in model.terms)
    return model.replace(mesh=replace(model.mesh, rest_positions=factor
                                      * model.mesh.rest_positions), terms=terms)
