"""SOFA scenes and FEBio files, checked against the simulators' own definitions (neither can be
installed here, so neither file is run): every SOFA component, data field and plugin against
SOFA's sources, every FEBio element, attribute and type name against FEBio's 4.0 reader; and
the model and the load read back from both. Plus ``neurofuzzy export`` on the command line."""

import runpy
import sys
import types
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import neurofuzzy as nf
from neurofuzzy.cli import main
from neurofuzzy.datasets import kuhn_block, paper_cube_experiment, paper_cube_model

# -- what the simulators define -------------------------------------------------------------
#: SOFA (sofa-framework/sofa, v24.12+): component -> (module, data fields), the fields as the
#: components' ``initData`` names (and aliases) in Sofa/Component/**.
SOFA = {
    "RequiredPlugin": ("", {"name", "pluginName"}),
    "DefaultAnimationLoop": ("", {"name"}),
    "EulerImplicitSolver": ("Sofa.Component.ODESolver.Backward",
                            {"name", "rayleighStiffness", "rayleighMass", "vdamping",
                             "firstOrder"}),
    "CGLinearSolver": ("Sofa.Component.LinearSolver.Iterative",
                       {"name", "iterations", "tolerance", "threshold", "warmStart"}),
    "TetrahedronSetTopologyContainer": ("Sofa.Component.Topology.Container.Dynamic",
                                        {"name", "position", "tetrahedra"}),
    "TetrahedronSetGeometryAlgorithms": ("Sofa.Component.Topology.Container.Dynamic",
                                         {"name", "template"}),
    "EdgeSetTopologyContainer": ("Sofa.Component.Topology.Container.Dynamic",
                                 {"name", "position", "edges"}),
    "EdgeSetGeometryAlgorithms": ("Sofa.Component.Topology.Container.Dynamic",
                                  {"name", "template"}),
    "MechanicalObject": ("Sofa.Component.StateContainer",
                         {"name", "template", "position", "velocity", "rest_position"}),
    "DiagonalMass": ("Sofa.Component.Mass", {"name", "vertexMass", "massDensity", "totalMass"}),
    "FixedProjectiveConstraint": ("Sofa.Component.Constraint.Projective",
                                  {"name", "indices", "fixAll"}),
    "TetrahedronFEMForceField": ("Sofa.Component.SolidMechanics.FEM.Elastic",
                                 {"name", "method", "youngModulus", "poissonRatio"}),
    "SpringForceField": ("Sofa.Component.SolidMechanics.Spring",
                         {"name", "spring", "stiffness", "damping", "indices1", "indices2",
                          "lengths"}),
    "ConstantForceField": ("Sofa.Component.MechanicalLoad",
                           {"name", "indices", "forces", "totalForce"}),
}

#: the parameters of FEBio's Yeoh material (FEYeoh, FEUncoupledMaterial); its Mooney-Rivlin
#: material's (FEMooneyRivlin: c1, c2 and FEUncoupledMaterial's) are among them
YEOH = {"c1", "c2", "c3", "c4", "c5", "c6", "k", "pressure_model"}
#: FEBio 4.0's reader (febiosoftware/FEBio, FEBioXML/*Section*.cpp, the classes' ADD_PARAMETER
#: names): element -> (required attributes, allowed attributes, allowed children).
FEBIO = {
    "febio_spec": ({"version"}, set(), {"Module", "Control", "Globals", "Material", "Mesh",
                                        "MeshDomains", "MeshData", "Boundary", "Loads",
                                        "Discrete", "LoadData", "Output", "Initial", "Step"}),
    "Module": ({"type"}, set(), set()),
    "Control": (set(), set(), {"analysis", "time_steps", "step_size", "plot_zero_state",
                               "solver", "time_stepper", "plot_level", "output_level"}),
    "solver": ({"type"}, set(), set()),
    "Material": (set(), set(), {"material"}),
    # FEBio's viscoelastic solid: FEViscoElasticMaterial's parameters g0..g6, t1..t6 and its
    # "elastic" property; FEYeoh's c1..c6 and FEUncoupledMaterial's k and pressure_model
    "material": ({"id", "name", "type"}, set(), {"density", "E", "v", "solid", "g1", "t1", "g2",
                                                 "t2", "g3", "t3", "elastic", *YEOH}),
    "solid": ({"type"}, set(), {"density", "E", "v", "kappa", "mu", "g1", "t1", "g2", "t2",
                                "g3", "t3", "elastic", *YEOH}),
    "elastic": ({"type"}, set(), {"E", "v", *YEOH}),
    "Mesh": (set(), set(), {"Nodes", "Elements", "NodeSet", "Surface", "ElementSet",
                            "DiscreteSet"}),
    "Nodes": (set(), {"name"}, {"node"}),
    "node": ({"id"}, set(), set()),
    "Elements": ({"type", "name"}, set(), {"elem"}),
    "elem": ({"id"}, set(), set()),
    "NodeSet": ({"name"}, set(), set()),
    "DiscreteSet": ({"name"}, set(), {"delem"}),
    "MeshDomains": (set(), set(), {"SolidDomain", "ShellDomain"}),
    "SolidDomain": ({"name", "mat"}, {"type", "elem_type"}, set()),
    "Boundary": (set(), set(), {"bc"}),
    "bc": ({"type", "node_set"}, {"name"}, {"x_dof", "y_dof", "z_dof"}),
    "Loads": (set(), set(), {"nodal_load", "surface_load", "body_load"}),
    "nodal_load": ({"type", "node_set"}, {"name"}, {"value", "shell_bottom"}),
    "value": (set(), {"lc", "type"}, set()),
    "body_load": ({"type"}, {"name", "elem_set"}, {"force"}),
    "Discrete": (set(), set(), {"discrete_material", "discrete"}),
    "discrete_material": ({"id", "type"}, {"name"}, {"E"}),
    "discrete": ({"dmat", "discrete_set"}, {"type"}, set()),
    "LoadData": (set(), set(), {"load_controller"}),
    "load_controller": ({"id", "type"}, {"name"}, {"interpolate", "extend", "points"}),
    "points": (set(), set(), {"pt"}),
    "Output": (set(), set(), {"plotfile", "logfile"}),
    "plotfile": ({"type"}, set(), {"var"}),
    "var": ({"type"}, set(), set()),
}
#: registered type names (REGISTER_FECORE_CLASS) and enumerations the file may use
FEBIO_TYPES = {
    "Module": {"solid"}, "solver": {"solid"}, "Elements": {"tet4"},
    "material": {"isotropic elastic", "solid mixture", "neo-Hookean", "viscoelastic", "Yeoh",
                 "Mooney-Rivlin"},
    "solid": {"isotropic elastic", "neo-Hookean", "Newtonian viscous solid", "viscoelastic",
              "Yeoh", "Mooney-Rivlin"},
    "elastic": {"isotropic elastic", "neo-Hookean", "Yeoh", "Mooney-Rivlin"},
    "bc": {"zero displacement"}, "nodal_load": {"nodal_force"}, "body_load": {"body force"},
    "discrete_material": {"linear spring"}, "load_controller": {"loadcurve"},
    "plotfile": {"febio"},
}
FEBIO_ENUMS = {"analysis": {"STATIC", "DYNAMIC"}, "interpolate": {"LINEAR", "STEP", "SMOOTH"},
               "extend": {"CONSTANT", "EXTRAPOLATE", "REPEAT", "REPEAT OFFSET"}}


# -- models ---------------------------------------------------------------------------------
def two_regions():
    points, tetrahedra = kuhn_block((3, 3, 2), 0.01)
    mesh = nf.from_tetra(points, tetrahedra).with_fixed(where=nf.bottom_layer)
    model = nf.Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.3, viscosity=2.0,
                               density=1050.0)
    inside = points[tetrahedra].mean(axis=1)[:, 0] > 0.015
    node_region = np.zeros(mesh.n_nodes, int)
    node_region[np.unique(tetrahedra[inside])] = 1
    elements = model.elements.replace(region=inside.astype(int),
                                      youngs_modulus=np.where(inside, 24000.0, 6000.0),
                                      poisson_ratio=np.where(inside, 0.45, 0.3),
                                      viscosity=np.where(inside, 12.0, 2.0))
    return model.replace(region_names=("liver", "tumour"), region_tissues=("liver", "tumour"),
                         node_region=node_region, terms=(elements,))


def pressed(model, n_frames=30):
    """A probe on two top nodes whose force ramps up and is held (one load curve)."""
    top = np.flatnonzero(np.isclose(model.mesh.rest_positions[:, 2],
                                    model.mesh.rest_positions[:, 2].max()))[:2]
    ramp = np.clip(np.arange(n_frames) / 10.0, 0.0, 1.0)
    forces = np.zeros((n_frames, model.n_nodes, 3))
    forces[:, top] = ramp[:, None, None] * np.array([0.002, 0.0, -0.02])
    return nf.simulate_experiment(model, dt=1e-3, n_frames=n_frames, external_forces=forces,
                                  substeps="auto", source="probe.npz")


MODELS = {"elements, two regions": two_regions, "springs": paper_cube_model}


def experiment_of(name, model):
    return pressed(model) if name != "springs" else paper_cube_experiment(model, n_frames=30)


# -- SOFA -----------------------------------------------------------------------------------
class _Data:
    def __init__(self, value):
        self.value = value


class _Object:
    def __init__(self, kind, fields):
        self.kind, self.fields = kind, fields
        for key, value in fields.items():
            setattr(self, key, _Data(value))


class _Node:
    """Stands in for a SofaPython3 node: records what the scene creates."""

    def __init__(self, name):
        self.name, self.objects, self.children = name, [], []
        self.time = _Data(0.0)

    def addObject(self, kind, **fields):
        made = _Object(kind, fields) if isinstance(kind, str) else kind
        self.objects.append(made)
        return made

    def addChild(self, name):
        self.children.append(_Node(name))
        return self.children[-1]


def run_scene(path, monkeypatch):
    core = types.ModuleType("Sofa.Core")
    core.Controller = type("Controller", (), {"__init__": lambda self, *a, **k: None})
    sofa = types.ModuleType("Sofa")
    sofa.Core = core
    monkeypatch.setitem(sys.modules, "Sofa", sofa)
    monkeypatch.setitem(sys.modules, "Sofa.Core", core)
    root = _Node("root")
    runpy.run_path(str(path))["createScene"](root)
    return root


@pytest.mark.parametrize("name", MODELS)
def test_the_sofa_scene_uses_sofa_components_as_sofa_defines_them(tmp_path, monkeypatch, name):
    model = MODELS[name]()
    data = experiment_of(name, model)
    exported = nf.export(model, to="sofa", path=tmp_path / "tissue.py", experiment=data)
    root = run_scene(exported.path, monkeypatch)
    objects = root.objects + [o for child in root.children for o in child.objects]
    made = {o.kind: o for o in objects if isinstance(o, _Object)}
    for kind, component in made.items():
        assert kind in SOFA, kind
        assert set(component.fields) <= SOFA[kind][1], (kind, set(component.fields))
    plugins = set(made["RequiredPlugin"].fields["pluginName"])
    assert {SOFA[kind][0] for kind in made if SOFA[kind][0]} <= plugins
    dofs = made["MechanicalObject"].fields
    assert np.array_equal(dofs["position"], model.mesh.rest_positions)
    assert np.array_equal(made["DiagonalMass"].fields["vertexMass"], model.node_mass)
    assert made["FixedProjectiveConstraint"].fields["indices"] == model.mesh.fixed.tolist()
    if model.elements is not None:
        fem = made["TetrahedronFEMForceField"].fields
        assert np.array_equal(made["TetrahedronSetTopologyContainer"].fields["tetrahedra"],
                              model.mesh.tetrahedra)
        assert np.array_equal(fem["youngModulus"], model.elements.youngs_modulus)
        assert np.array_equal(fem["poissonRatio"], model.elements.poisson_ratio)
        assert any("merged into their volume-weighted mean" in n for n in exported.notes)
        scene = runpy.run_path(str(exported.path))
        assert scene["REGION_NAMES"] == ["liver", "tumour"]
        assert scene["ELEMENT_REGION"] == model.elements.region.tolist()
    else:
        rows = np.array(made["SpringForceField"].fields["spring"].split(), float).reshape(-1, 5)
        assert np.array_equal(rows[:, :2].astype(int), model.mesh.springs)
        assert np.array_equal(rows[:, 2], model.springs.stiffness)
        assert np.array_equal(rows[:, 3], model.springs.damping)
        assert np.array_equal(rows[:, 4], model.springs.rest_length)
    # the controller holds frame t's load from t to t + 1
    load = made["ConstantForceField"]
    curve = next(o for o in root.objects if not isinstance(o, _Object))
    nodes = np.array(load.fields["indices"])
    assert set(nodes) == set(np.flatnonzero(np.any(data.forces_per_frame() != 0, axis=(0, 2))))
    for frame in (0, 3, 17, data.n_frames - 2):
        root.time.value = (frame + 0.3) * data.dt
        curve.onAnimateBeginEvent(None)
        assert np.array_equal(load.forces.value, data.forces_per_frame()[frame, nodes])


# -- FEBio ----------------------------------------------------------------------------------
def check_febio_structure(root):
    """Every element, attribute and type name is one FEBio 4.0's reader accepts."""
    assert root.tag == "febio_spec" and root.get("version") == "4.0"
    for element in root.iter():
        if element.tag not in FEBIO:
            continue
        required, optional, children = FEBIO[element.tag]
        assert required <= set(element.attrib), (element.tag, element.attrib)
        assert set(element.attrib) <= required | optional, (element.tag, element.attrib)
        for child in element:
            assert child.tag in children, (element.tag, child.tag)
        if element.tag in FEBIO_TYPES:
            assert element.get("type") in FEBIO_TYPES[element.tag], (element.tag,
                                                                      element.get("type"))
        if element.tag in FEBIO_ENUMS:
            assert element.text in FEBIO_ENUMS[element.tag], element.text
    # ids: sequential materials and load curves, increasing nodes and elements
    assert [int(m.get("id")) for m in root.iter("material")] == list(
        range(1, len(root.findall("./Material/material")) + 1))
    assert [int(c.get("id")) for c in root.iter("load_controller")] == list(
        range(1, len(root.findall("./LoadData/load_controller")) + 1))
    for tag in ("node", "elem"):
        ids = [int(e.get("id")) for e in root.iter(tag)]
        assert ids == sorted(ids) and len(set(ids)) == len(ids)
    # references: domains to parts and materials, sets, load curves, discrete materials
    parts = {e.get("name") for e in root.iter("Elements")}
    materials = {m.get("name") for m in root.findall("./Material/material")}
    sets = {s.get("name") for s in root.iter("NodeSet")}
    for domain in root.iter("SolidDomain"):
        assert domain.get("name") in parts and domain.get("mat") in materials
    for reference in root.findall(".//*[@node_set]"):
        assert reference.get("node_set") in sets
    curves = len(root.findall("./LoadData/load_controller"))
    for value in root.iter("value"):
        assert 1 <= int(value.get("lc")) <= curves
    discrete_sets = {s.get("name") for s in root.iter("DiscreteSet")}
    for discrete in root.iter("discrete"):
        assert discrete.get("discrete_set") in discrete_sets
        assert 1 <= int(discrete.get("dmat")) <= len(root.findall(".//discrete_material"))


def numbers(text):
    return np.array(text.split(","), float)


def febio_load(root, times, n_nodes):
    """The nodal force FEBio applies at each time (STEP curves: the next point's value)."""
    curves = []
    for controller in root.findall("./LoadData/load_controller"):
        assert controller.findtext("interpolate") == "STEP"
        points = np.array([numbers(pt.text) for pt in controller.iter("pt")])
        index = np.searchsorted(points[:, 0], times - 1e-12)       # first point at or after
        curves.append(points[np.minimum(index, len(points) - 1), 1])
    node_of_set = {s.get("name"): [int(i) - 1 for i in s.text.split(",")]
                   for s in root.iter("NodeSet")}
    force = np.zeros((len(times), n_nodes, 3))
    for load in root.iter("nodal_load"):
        value = load.find("value")
        for node in node_of_set[load.get("node_set")]:
            force[:, node] += curves[int(value.get("lc")) - 1][:, None] * numbers(value.text)
    return force


@pytest.mark.parametrize("name", MODELS)
def test_the_febio_file_follows_febio_4_and_holds_the_model_and_its_load(tmp_path, name):
    model = MODELS[name]()
    data = experiment_of(name, model)
    exported = nf.export(model, to="febio", path=tmp_path / "tissue.feb", experiment=data)
    root = ET.parse(exported.path).getroot()
    check_febio_structure(root)
    nodes = np.array([numbers(n.text) for n in root.iter("node")])
    assert np.array_equal(nodes, model.mesh.rest_positions)
    fixed = root.find("./Mesh/NodeSet[@name='fixed']").text
    assert [int(i) - 1 for i in fixed.split(",")] == model.mesh.fixed.tolist()
    assert root.findtext("./Control/time_steps") == str(data.n_frames - 1)
    assert float(root.findtext("./Control/step_size")) == data.dt
    # frame t's force acts on the step that ends at (t + 1) dt
    times = (np.arange(data.n_frames - 1) + 1) * data.dt
    applied = febio_load(root, times, model.n_nodes)
    assert np.allclose(applied, data.forces_per_frame()[:-1], rtol=0, atol=1e-15)
    if model.elements is not None:
        assert root.findtext("./Control/analysis") == "DYNAMIC"
        check_febio_materials(root, model)
    else:
        assert root.findtext("./Control/analysis") == "STATIC"
        stiffness = {int(m.get("id")): float(m.findtext("E"))
                     for m in root.iter("discrete_material")}
        springs = {s.get("name"): [tuple(int(i) - 1 for i in d.text.split(","))
                                   for d in s.iter("delem")] for s in root.iter("DiscreteSet")}
        found = {}
        for discrete in root.iter("discrete"):
            for pair in springs[discrete.get("discrete_set")]:
                found[pair] = stiffness[int(discrete.get("dmat"))]
        assert found == {tuple(pair): k for pair, k in zip(model.mesh.springs.tolist(),
                                                            model.springs.stiffness)}
        assert any("discrete springs have none" in note for note in exported.notes)


def check_febio_materials(root, model):
    """One part and material per region, St. Venant–Kirchhoff E and ν, the viscosity as a
    Newtonian viscous solid, and densities that give the node masses."""
    from neurofuzzy.forces import tetrahedron_geometry

    volume = tetrahedron_geometry(model.mesh).volume
    materials = {m.get("name"): m for m in root.findall("./Material/material")}
    assert set(materials) == set(model.region_names)
    lumped = np.zeros(model.n_nodes)
    for part in root.iter("Elements"):
        elements = np.array([[int(i) - 1 for i in e.text.split(",")] for e in part.iter("elem")])
        region = model.region_names.index(part.get("name"))
        rows = {tuple(t) for t in model.mesh.tetrahedra[model.elements.region == region].tolist()}
        assert {tuple(t) for t in elements.tolist()} == rows
        material = materials[part.get("name")]
        assert material.get("type") == "solid mixture"
        elastic, viscous = material.findall("solid")
        E, nu = float(elastic.findtext("E")), float(elastic.findtext("v"))
        chosen = model.elements.region == region
        assert E == model.elements.youngs_modulus[chosen][0]
        assert nu == model.elements.poisson_ratio[chosen][0]
        beta = model.elements.viscosity[chosen][0] / E
        assert float(viscous.findtext("mu")) == pytest.approx(beta * E / (2 * (1 + nu)))
        assert float(viscous.findtext("kappa")) == pytest.approx(beta * E / (3 * (1 - 2 * nu)))
        density = float(material.findtext("density"))
        np.add.at(lumped, model.mesh.tetrahedra[chosen].ravel(),
                  np.repeat(density * volume[chosen] / 4, 4))
    assert np.allclose(lumped, model.node_mass, rtol=1e-10, atol=0)


# -- the command line -----------------------------------------------------------------------
def test_export_on_the_command_line_carries_the_fit_record(tmp_path, capsys):
    """All four targets from a model file with a fit record, and one without."""
    model = two_regions()
    data = pressed(model)
    nf.save_experiment(data, tmp_path / "probe.npz")
    record = {"neurofuzzy_version": nf.__version__, "learner": "GradientLearner",
              "lack_of_fit": {"rms": 5.1e-5, "noise": 3.4e-5, "ratio": 1.5,
                              "verdict": "residual 1.5x the noise: this model class misses "
                                         "something"}}
    nf.save_model(model, tmp_path / "fitted.yaml", fit=record)
    for to, suffix in (("mujoco", ".xml"), ("sofa", ".py"), ("febio", ".feb")):
        out = tmp_path / f"tissue{suffix}"
        assert main(["export", str(tmp_path / "fitted.yaml"), str(tmp_path / "probe.npz"),
                     "--to", to, "--out", str(out)]) == 0
        printed = capsys.readouterr().out
        assert f"wrote {out}" in printed
        text = out.read_text()
        assert "residual 1.5x the noise: this model class misses something" in text
        assert "region tumour:" in text and "Young's modulus E = 24000 Pa" in text
        assert f"neurofuzzy {nf.__version__}" in text
    assert main(["export", str(tmp_path / "fitted.yaml"), str(tmp_path / "probe.npz"),
                 "--out", str(tmp_path / "pv"), "--every", "10"]) == 0      # --to vtu
    capsys.readouterr()
    for name in ("neurofuzzy.pvd", "neurofuzzy.xdmf"):
        assert "residual 1.5x the noise" in (tmp_path / "pv" / name).read_text()
    import meshio

    with meshio.xdmf.TimeSeriesReader(tmp_path / "pv" / "neurofuzzy.xdmf") as reader:
        points, _ = reader.read_points_cells()
        assert reader.num_steps == 3 and np.allclose(points, model.mesh.rest_positions)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fitted.yaml", "probe.npz", "pv", "tissue.feb", "tissue.py", "tissue.xml"]
    nf.save_model(model, tmp_path / "plain.yaml")
    assert main(["export", str(tmp_path / "plain.yaml"), "--to", "febio",
                 "--out", str(tmp_path / "plain.feb")]) == 0
    assert "holds no fit record" in capsys.readouterr().out
    assert "lack of fit: not recorded" in (tmp_path / "plain.feb").read_text()


@pytest.mark.parametrize("args, names", [
    (["--to", "mujoco", "--out", "OUT/tissue.feb"], ["tissue.feb", "--out", ".xml file"]),
    (["--to", "sofa", "--every", "2", "--out", "OUT/t.py"], ["--every", "--to vtu only"]),
    (["--to", "febio", "--max-materials", "0", "--out", "OUT/t.feb"], ["--max-materials"]),
    (["--to", "mujoco", "--out", "OUT/folder.xml"], ["folder.xml", "names a folder"]),
    (["--to", "mujoco", "--out", "MODEL"], ["never writes over its input"]),
])
def test_export_refuses_bad_options_in_one_line(tmp_path, capsys, args, names):
    from test_bad_input import refused

    model = tmp_path / "model.xml"                   # a model file may have any name
    nf.save_model(paper_cube_model(), model)
    (tmp_path / "folder.xml").mkdir()
    args = [str(model) if a == "MODEL" else a.replace("OUT", str(tmp_path)) for a in args]
    refused(capsys, ["export", model, *args], names=names, folder=tmp_path)


def test_exports_carry_the_elements_law(tmp_path):
    """FEBio writes its own neo-Hookean solid for neo-Hookean elements (a region holding two
    laws becomes two materials, never mixed); SOFA and MuJoCo, which have no such element in
    what we write, say so in the file's notes with the difference measured."""
    model = two_regions()
    model = model.with_elements(law=(model.elements.region == 1).astype(int))
    data = pressed(model)
    root = ET.parse(nf.export(model, to="febio", path=tmp_path / "t.feb",
                              experiment=data).path).getroot()
    check_febio_structure(root)
    kinds = {m.get("name"): m.find("solid").get("type")
             for m in root.findall("./Material/material")}
    assert kinds == {"liver": "isotropic elastic", "tumour": "neo-Hookean"}
    mixed = model.with_elements(law=np.arange(model.mesh.n_tetrahedra) % 2)
    root = ET.parse(nf.export(mixed, to="febio", path=tmp_path / "m.feb").path).getroot()
    kinds = {m.get("name"): m.find("solid").get("type")
             for m in root.findall("./Material/material")}
    assert kinds["liver_neo-hookean"] == "neo-Hookean"
    assert kinds["liver_st-venant-kirchhoff"] == "isotropic elastic"
    for target, suffix in (("sofa", ".py"), ("mujoco", ".xml")):
        notes = nf.export(model, to=target, path=tmp_path / f"t{suffix}", experiment=data).notes
        law = [note for note in notes if "material law" in note]
        assert len(law) == 1 and "differ by" in law[0] and "neo-hookean" in law[0], notes


def _febio_solids(model, path, experiment):
    """The ``solid`` of every material of ``model``'s FEBio file (checked against the
    reader's structure), by material name."""
    root = ET.parse(nf.export(model, to="febio", path=path, experiment=experiment).path).getroot()
    check_febio_structure(root)
    return {m.get("name"): m.find("solid") for m in root.findall("./Material/material")}


def test_exports_carry_the_elements_relaxation(tmp_path):
    """FEBio wraps a relaxing region's law in its viscoelastic solid (g1, t1, the law as its
    elastic part; the same convention as ours); SOFA and MuJoCo, which have no such element,
    say so in the notes with the difference measured."""
    model = two_regions()
    relaxing = model.with_elements(relaxation_moduli=(model.elements.region == 1) * 0.5,
                                   relaxation_times=np.full(model.mesh.n_tetrahedra, 0.05),
                                   law=(model.elements.region == 1).astype(int))
    data = pressed(relaxing)
    solids = _febio_solids(relaxing, tmp_path / "r.feb", data)
    tumour = solids["tumour"]
    assert tumour.get("type") == "viscoelastic"
    assert float(tumour.find("g1").text) == 0.5 and float(tumour.find("t1").text) == 0.05
    assert tumour.find("elastic").get("type") == "neo-Hookean"
    assert float(tumour.find("elastic/E").text) == float(
        relaxing.elements.youngs_modulus[relaxing.elements.region == 1][0])
    assert solids["liver"].get("type") == "viscoelastic"          # g = 0: no relaxation
    assert float(solids["liver"].find("g1").text) == 0.0
    for target, suffix in (("sofa", ".py"), ("mujoco", ".xml")):
        notes = nf.export(relaxing, to=target, path=tmp_path / f"r{suffix}",
                          experiment=data).notes
        relax = [note for note in notes if "relax" in note]
        assert len(relax) == 1 and "differ by" in relax[0], notes


def test_exports_carry_mooney_rivlin_elements(tmp_path):
    """FEBio writes its Mooney-Rivlin solid for Mooney–Rivlin elements: c1 = C10, c2 = C01 =
    r C10 with C10 + C01 = mu/2, k and pressure_model as Yeoh's (FEMooneyRivlin)."""
    model = two_regions()
    mooney = model.with_elements(law=np.where(model.elements.region == 1, 3, 0),
                                 stiffening=0.5)
    tumour = _febio_solids(mooney, tmp_path / "m.feb", pressed(mooney))["tumour"]
    assert tumour.get("type") == "Mooney-Rivlin"
    E = float(mooney.elements.youngs_modulus[mooney.elements.region == 1][0])
    nu = float(mooney.elements.poisson_ratio[mooney.elements.region == 1][0])
    mu = E / (2 * (1 + nu))
    assert float(tumour.find("c1").text) == pytest.approx(mu / 3, rel=1e-12)
    assert float(tumour.find("c2").text) == pytest.approx(mu / 6, rel=1e-12)
    assert float(tumour.find("k").text) == pytest.approx(E / (3 * (1 - 2 * nu)), rel=1e-12)
    assert tumour.find("pressure_model").text == "2"


def test_exports_carry_yeoh_elements(tmp_path):
    """FEBio writes its Yeoh solid for Yeoh elements (c1 = C10 = mu/2, c2 = C20, the bulk
    modulus k with Abaqus' volumetric energy, ours); SOFA and MuJoCo say in their notes that
    the law is dropped, with the difference measured."""
    model = two_regions()
    yeoh = model.with_elements(law=np.where(model.elements.region == 1, 2, 0),
                               stiffening=1.5)
    data = pressed(yeoh)
    solids = _febio_solids(yeoh, tmp_path / "y.feb", data)
    tumour = solids["tumour"]
    assert tumour.get("type") == "Yeoh" and solids["liver"].get("type") == "isotropic elastic"
    E = float(yeoh.elements.youngs_modulus[yeoh.elements.region == 1][0])
    nu = float(yeoh.elements.poisson_ratio[yeoh.elements.region == 1][0])
    c10 = float(tumour.find("c1").text)
    assert c10 == pytest.approx(E / (4 * (1 + nu)), rel=1e-12)
    assert float(tumour.find("c2").text) == pytest.approx(1.5 * c10, rel=1e-12)
    assert float(tumour.find("k").text) == pytest.approx(E / (3 * (1 - 2 * nu)), rel=1e-12)
    assert tumour.find("pressure_model").text == "2"
    for target, suffix in (("sofa", ".py"), ("mujoco", ".xml")):
        notes = nf.export(yeoh, to=target, path=tmp_path / f"y{suffix}", experiment=data).notes
        law = [note for note in notes if "material law" in note]
        assert len(law) == 1 and "yeoh" in law[0] and "differ by" in law[0], notes
