"""Property-based fuzzing of every file loader: a mutated valid file either loads or raises
our own error (a NeurofuzzyError naming the file), never anything else.

Seeded and bounded (``derandomize=True``, a few dozen examples each) so the default suite
stays fast; ``-m slow`` runs many more examples.
"""

import io
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from neurofuzzy.errors import NeurofuzzyError
from neurofuzzy.io import load_experiment, load_model, save_experiment, save_model
from neurofuzzy.markers import read_forces, read_markers
from neurofuzzy.mesh import read_mesh
from neurofuzzy.rules import load_rules, shipped

FAST = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
MANY = settings(max_examples=400, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


@st.composite
def mutations(draw, data: bytes, max_edits: int = 4):
    """``data`` with a few bytes flipped, inserted, deleted, or a run duplicated/cut."""
    data = bytearray(data)
    for _ in range(draw(st.integers(1, max_edits))):
        kind = draw(st.sampled_from(["flip", "insert", "delete", "truncate", "duplicate",
                                     "token"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "flip" and data:
            data[at] = draw(st.integers(0, 255))
        elif kind == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        elif kind == "delete" and data:
            del data[at:at + draw(st.integers(1, 16))]
        elif kind == "truncate":
            del data[at:]
        elif kind == "duplicate" and data:
            data[at:at] = data[at:at + draw(st.integers(1, 64))]
        elif kind == "token":                       # YAML/CSV syntax where it hurts most
            data[at:at] = draw(st.sampled_from(
                [b"&a ", b"*a", b"!foo ", b"!!int ", b"[", b"]", b"{", b"}", b": ", b"- ",
                 b"\n  ", b"\t", b"'", b'"', b"#", b",", b".nan", b"-.inf", b"1e400",
                 b"<<: ", b"---\n", b"\x00", b"\xff", b"nan", b"-1", b"\r\n"]))
    return bytes(data)


def mutated_loads_or_refuses(load, path, original, data):
    """Write a mutation of ``original`` (drawn from ``data``) to ``path`` and load it."""
    path.write_bytes(data.draw(mutations(original)))
    loads_or_refuses(load, path)


def loads_or_refuses(load, path):
    """Call ``load(path)``; anything raised must be our error and name the file."""
    try:
        load(path)
    except NeurofuzzyError as error:
        assert str(path) in str(error) or path.name in str(error), str(error)


# -- rule files ---------------------------------------------------------------------------
RULES = (shipped("soft_tissue").read_bytes())


def _rules(tmp_path, content):
    path = tmp_path / "soft_tissue.yaml"
    path.write_bytes(content)
    return path


@FAST
@given(content=mutations(RULES))
def test_mutated_rule_files_load_or_raise_our_error(tmp_path, content):
    loads_or_refuses(load_rules, _rules(tmp_path, content))


@pytest.mark.slow
@MANY
@given(content=mutations(RULES, max_edits=8))
def test_mutated_rule_files_many(tmp_path, content):
    loads_or_refuses(load_rules, _rules(tmp_path, content))


# -- model files --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def model_text(tmp_path_factory, cube_model):
    path = save_model(cube_model, tmp_path_factory.mktemp("model") / "model.yaml")
    return path.read_bytes()


@FAST
@given(data=st.data())
def test_mutated_model_files_load_or_raise_our_error(tmp_path, model_text, data):
    mutated_loads_or_refuses(load_model, tmp_path / "model.yaml", model_text, data)


# -- experiment files ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def experiment_bytes(tmp_path_factory, cube_experiment):
    small = cube_experiment.first_frames(12)
    path = save_experiment(small, tmp_path_factory.mktemp("exp") / "e.npz")
    plain = io.BytesIO()                        # uncompressed members: headers are reachable
    with np.load(path) as archive:
        np.savez(plain, **{key: archive[key] for key in archive.files})
    return path.read_bytes(), plain.getvalue()


@FAST
@given(data=st.data())
def test_mutated_experiment_files_load_or_raise_our_error(tmp_path, experiment_bytes, data):
    source = experiment_bytes[data.draw(st.integers(0, 1))]
    mutated_loads_or_refuses(load_experiment, tmp_path / "e.npz", source, data)


@st.composite
def npy_headers(draw):
    """A ``.npy`` member (27 doubles) whose header dictionary is mutated: brackets and quotes
    left open or doubled, keys and values replaced, Python syntax where numpy's header parser
    (``tokenize`` and ``ast``) meets it."""
    text = bytearray(b"{'descr': '<f8', 'fortran_order': False, 'shape': (27,), }")
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["insert", "delete", "truncate"]))
        if kind == "insert":
            text[at:at] = draw(st.sampled_from(
                [b"{", b"}", b"(", b")", b"[", b"]", b"'", b'"', b"'" * 3, b",", b":", b"\\",
                 b"\n", b"#", b"-1", b"1e400", b"None", b"'|O'", b"'<U5'", b"lambda: 0",
                 b"'shape': (", b"'descr': ", b"True", b"\x00", b"\xff", b"9" * 30]))
        elif kind == "delete":
            del text[at:at + draw(st.integers(1, 8))]
        else:
            del text[at:]
    version = draw(st.sampled_from([1, 2]))
    prefix = 10 if version == 1 else 12          # magic, version, header length
    padded = (prefix + len(text) + 1 + 63) // 64 * 64 - prefix
    header = bytes(text) + b" " * (padded - len(text) - 1) + b"\n"
    length = len(header).to_bytes(2 if version == 1 else 4, "little")
    return b"\x93NUMPY" + bytes([version, 0]) + length + header + np.ones(27).tobytes()


@FAST
@given(header=npy_headers())
def test_experiment_files_with_a_mutated_npy_header_load_or_raise_our_error(
        tmp_path, cube_experiment, header):
    """A member whose ``.npy`` header is broken (an unclosed ``{``, issue 49) is refused
    naming the file and the member, never with a tokenizer's or parser's traceback."""
    path = save_experiment(cube_experiment.first_frames(12), tmp_path / "good.npz")
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files if name != "masses"}
    bad = tmp_path / "e.npz"
    with zipfile.ZipFile(bad, "w") as archive:
        for name, array in arrays.items():
            buffer = io.BytesIO()
            np.save(buffer, array)
            archive.writestr(name + ".npy", buffer.getvalue())
        archive.writestr("masses.npy", header)
    try:
        load_experiment(bad)
    except NeurofuzzyError as error:
        assert str(bad) in str(error), str(error)
        event("refused naming the member" if "masses" in str(error) else "refused")
    else:
        event("loaded")


ARRAYS = st.sampled_from([
    np.array([]), np.array(1.0), np.array("text"), np.zeros((27, 3), np.complex128),
    np.full((27, 3), np.nan), np.full(27, True), np.arange(-5, 5), np.zeros((2, 0, 3)),
    np.full((12, 27, 3), 1e200), np.zeros((86, 2), np.int8), np.array([[0, 0]]),
    np.zeros((3, 4), np.int64), np.ones((12, 27, 3), np.float32), np.array(["a", "b"]),
    np.array(-1.0), np.array(np.inf), np.zeros((27,), [("x", "f8")])])


@FAST
@given(key=st.sampled_from(["rest_positions", "springs", "dt", "positions", "fixed",
                            "external_forces", "observed", "masses", "spring_groups",
                            "group_names", "tetrahedra", "marker_positions", "marker_nodes",
                            "marker_weights", "marker_names", "true_stiffness"]),
       value=ARRAYS)
def test_experiment_arrays_of_any_type_or_shape_load_or_raise(tmp_path, cube_experiment, key,
                                                              value):
    path = save_experiment(cube_experiment.first_frames(12), tmp_path / "good.npz")
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    arrays[key] = value
    bad = tmp_path / "e.npz"
    with zipfile.ZipFile(bad, "w") as archive:
        for name, array in arrays.items():
            buffer = io.BytesIO()
            np.save(buffer, array)
            archive.writestr(name + ".npy", buffer.getvalue())
    loads_or_refuses(load_experiment, bad)


# -- marker recordings --------------------------------------------------------------------
CSV = (b"# units: mm\ntime,marker,x,y,z\n" + b"".join(
    f"{t * 0.001:.3f},M{m},{m * 10 + t * 0.1:.2f},{m:.1f},{t:.1f}\n".encode()
    for t in range(6) for m in range(3)))


@FAST
@given(content=mutations(CSV))
def test_mutated_marker_csv_loads_or_raises_our_error(tmp_path, content):
    path = tmp_path / "markers.csv"
    path.write_bytes(content)
    loads_or_refuses(read_markers, path)


@pytest.fixture(scope="module")
def c3d_bytes():
    c3d = pytest.importorskip("c3d")
    writer = c3d.Writer(point_rate=100.0)
    for t in range(5):
        points = np.zeros((3, 5), np.float32)
        points[:, 0] = np.arange(3) * 10.0 + t
        writer.add_frames([(points, np.zeros((0,), np.float32))])
    buffer = io.BytesIO()
    writer.set_point_labels(["A", "B", "C"])
    writer.write(buffer)
    return buffer.getvalue()


@FAST
@given(data=st.data())
def test_mutated_c3d_loads_or_raises_our_error(tmp_path, c3d_bytes, data):
    mutated_loads_or_refuses(lambda path: read_markers(path, units="mm"),
                             tmp_path / "markers.c3d", c3d_bytes, data)


# -- meshes -------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory):
    trimesh = pytest.importorskip("trimesh")
    meshio = pytest.importorskip("meshio")
    folder = tmp_path_factory.mktemp("meshes")
    box = trimesh.creation.box(extents=(0.02, 0.02, 0.02))
    files = {".stl": box.export(file_type="stl"), ".obj": box.export(file_type="obj").encode()}
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float) * 0.01
    cells = [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))]
    for suffix in (".vtu", ".msh", ".vtk"):
        path = folder / f"m{suffix}"
        kwargs = {"file_format": "gmsh22", "binary": False} if suffix == ".msh" else {}
        if suffix == ".vtu":
            kwargs = {"binary": False}
        meshio.write_points_cells(path, points, cells, **kwargs)
        files[suffix] = path.read_bytes()
    return files


@FAST
@given(data=st.data())
def test_mutated_mesh_files_load_or_raise_our_error(tmp_path, mesh_files, data):
    suffix = data.draw(st.sampled_from(sorted(mesh_files)))
    pitch = 0.005 if suffix in (".stl", ".obj") else None
    mutated_loads_or_refuses(lambda path: read_mesh(path, pitch=pitch),
                             tmp_path / f"mesh{suffix}", mesh_files[suffix], data)


# -- the surfaces of issue 28: point forces, element models, manifests, ν outputs ------------------
@pytest.fixture(scope="module")
def cube_mesh(cube_model):
    return cube_model.mesh


POINT_FORCES = (b"# length units: mm\n# force units: N\ntime,probe,x,y,z,fx,fy,fz,radius\n"
                b"0,a,20,10,10,0,0,0,0\n0.001,a,20,10,10,0,0,-0.2,4\n"
                b"0.002,b,10,10,20,0.1,0,0,0\n")


@FAST
@given(content=mutations(POINT_FORCES))
def test_mutated_point_force_csv_loads_or_raises_our_error(tmp_path, cube_mesh, content):
    path = tmp_path / "forces.csv"
    path.write_bytes(content)
    loads_or_refuses(lambda p: read_forces(p, mesh=cube_mesh, times=np.arange(6) * 5e-4), path)


@settings(FAST, max_examples=80)
@given(point=st.tuples(*[st.floats(0, 20, allow_nan=False)] * 3),
       force=st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3),
       unit=st.sampled_from(["mm", "mm", "mm", "cm", "m"]),
       newtons=st.sampled_from(["N", "mN", "kN"]),
       radius=st.one_of(st.none(), st.floats(0, 15, allow_nan=False)),
       start=st.floats(0, 0.01, allow_nan=False))
def test_a_point_force_is_refused_or_arrives_whole_on_free_nodes(tmp_path, cube_mesh, point,
                                                                 force, unit, newtons, radius,
                                                                 start):
    """Property: a probe's force either is refused naming the file, or every frame after it
    starts carries exactly the stated force (converted to N), none of it on fixed nodes only,
    and nothing before."""
    path = tmp_path / "probe.csv"
    column = "" if radius is None else ",radius"
    path.write_text(f"# length units: {unit}\n# force units: {newtons}\n"
                    f"time,x,y,z,fx,fy,fz{column}\n{start!r},{point[0]!r},{point[1]!r},"
                    f"{point[2]!r},{force[0]!r},{force[1]!r},{force[2]!r}"
                    + ("" if radius is None else f",{radius!r}") + "\n")
    times = np.arange(6) * 5e-4
    try:
        forces = read_forces(path, mesh=cube_mesh, times=times)
    except NeurofuzzyError as error:
        assert str(path) in str(error), str(error)
        event("refused")
        return
    event("loaded")
    total = np.array(force) * {"N": 1.0, "mN": 1e-3, "kN": 1e3}[newtons]
    acting = times >= start - 1e-6 * 5e-4
    assert np.allclose(forces.sum(axis=1)[acting], total, atol=1e-12 * max(1, abs(total).max()))
    assert np.all(forces[~acting] == 0)
    free = np.ones(cube_mesh.n_nodes, bool)
    free[cube_mesh.fixed] = False
    if np.any(total) and acting.any():
        assert np.abs(forces[acting][:, free]).sum() > 0


@pytest.fixture(scope="module")
def element_model_text(tmp_path_factory):
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    points, tetrahedra = kuhn_block((2, 1, 1), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=np.linspace(4e3, 6e3, 12),
                            poisson_ratio=0.45, viscosity=2.0, density=1050.0)
    return save_model(model, tmp_path_factory.mktemp("elements") / "m.yaml").read_bytes()


@FAST
@given(data=st.data())
def test_mutated_element_model_files_load_within_physics_or_raise_our_error(
        tmp_path, element_model_text, data):
    path = tmp_path / "model.yaml"
    path.write_bytes(data.draw(mutations(element_model_text)))
    try:
        model = load_model(path)
    except NeurofuzzyError as error:
        assert str(path) in str(error), str(error)
        return
    if model.elements is not None:                          # what loads is physically possible
        assert np.all((model.elements.poisson_ratio > 0) & (model.elements.poisson_ratio < 0.5))
        assert np.all(model.elements.youngs_modulus > 0) and np.all(model.elements.viscosity >= 0)
    assert np.all(model.node_mass > 0)


@pytest.fixture(scope="module")
def manifest_folder(tmp_path_factory, cube_experiment):
    folder = tmp_path_factory.mktemp("manifest")
    save_experiment(cube_experiment.first_frames(12), folder / "a.npz")
    return folder


MANIFEST = (b"# a cohort\nid,group,experiments,rules,tissue,tie,prior,method,cycles,substeps,dt\n"
            b"s1,healthy,a.npz,liver,liver,global,off,gradient,5,auto,\n"
            b"s2,fibrotic,a.npz;a.npz,liver,fibrotic_liver,groups,,paper,3,1,\n")


@FAST
@given(content=mutations(MANIFEST))
def test_mutated_manifests_load_or_raise_our_error(manifest_folder, content):
    from neurofuzzy.batch import read_manifest

    path = manifest_folder / "cohort.csv"
    path.write_bytes(content)
    try:
        specimens = read_manifest(path)
    except NeurofuzzyError as error:
        assert str(path) in str(error), str(error)
        return
    ids = [s.id.lower() for s in specimens]
    assert len(set(ids)) == len(ids) and not {"results.csv", "fit-many.json"} & set(ids)
    for specimen in specimens:
        dt = specimen.options.get("dt")
        assert dt is None or (np.isfinite(dt) and dt > 0)


NU_RULES = """\
extends: soft_tissue.yaml
defuzzification: {method}
outputs:
  poisson_ratio:
    quantity: poisson_ratio
    universe: [{low!r}, {high!r}]
    terms:
      compressible: {{trapmf: [{t[0]!r}, {t[0]!r}, {t[1]!r}, {t[2]!r}]}}
      slightly_compressible: {{trimf: [{t[3]!r}, {t[4]!r}, {t[5]!r}]}}
      nearly_incompressible: {{trapmf: [{t[6]!r}, {t[7]!r}, {t[8]!r}, {t[8]!r}]}}
tissues:
  sponge: {{compressibility: compressible}}
  cartilage: {{compressibility: slightly_compressible}}
  liver: {{compressibility: incompressible}}
  vague: {{compressibility: somewhat compressible}}
  measured: {{compressibility: 9.5}}
"""


@settings(FAST, max_examples=100)
@given(method=st.sampled_from(["centroid", "lom", "som", "mom", "bisector"]),
       bounds=st.tuples(st.sampled_from([0.0, 0.05, -0.1]), st.sampled_from([0.5, 0.48, 0.7])),
       fractions=st.lists(st.floats(0.0, 1.0), min_size=9, max_size=9))
def test_rule_files_with_a_poisson_output_refuse_or_give_nu_inside_0_to_half(
        tmp_path, method, bounds, fractions):
    """Property: a rule base with a Poisson's-ratio output (terms anywhere in a universe that
    may reach beyond 0 or 0.5, any defuzzification) either is refused naming the file, or
    every tissue's inferred ν lies strictly between 0 and 0.5 (the elements' bounds)."""
    low, high = bounds
    corners = [low + (high - low) * x for x in fractions]
    corners = sorted(corners[:3]) + sorted(corners[3:6]) + sorted(corners[6:])
    (tmp_path / "soft_tissue.yaml").write_bytes(RULES)
    path = tmp_path / "nu.yaml"
    path.write_text(NU_RULES.format(method=method, low=low, high=high, t=corners))
    try:
        rules = load_rules(path)
    except NeurofuzzyError as error:
        assert str(path) in str(error), str(error)
        event("refused")
        return
    event("loaded")
    assert len(rules.tissues) == 5
    for tissue in rules.tissues:
        try:
            nu = rules.tissue(tissue)["poisson_ratio"]
        except NeurofuzzyError as error:         # a tissue no rule fires for, named
            assert str(path) in str(error), str(error)
            event("a tissue refused at use")
            continue
        assert 0 < nu < 0.5, (tissue, nu)
