"""Property-based fuzzing of every file loader: a mutated valid file either loads or raises
our own error (a NeurofuzzyError naming the file), never anything else.

Seeded and bounded (``derandomize=True``, a few dozen examples each) so the default suite
stays fast; ``-m slow`` runs many more examples.
"""

import io
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from neurofuzzy.errors import NeurofuzzyError
from neurofuzzy.io import load_experiment, load_model, save_experiment, save_model
from neurofuzzy.markers import read_markers
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
