import re

import meshio
import numpy as np
import pytest
import trimesh

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.io import load_experiment, load_model, save_experiment, save_model
from neurofuzzy.mesh import from_surface_tetra, from_tetra, from_trimesh, lattice
from neurofuzzy.mesh import MeshFile, read_mesh
from neurofuzzy.forces import Springs
from neurofuzzy.model import Model


def _kuhn_block(shape):
    """A conforming block of unit Kuhn cubes; region 1 for x < shape[0]/2, else 2."""
    points, tetrahedra = kuhn_block(shape)
    centre_x = points[tetrahedra, 0].mean(axis=1)
    return points, tetrahedra, np.where(centre_x < shape[0] / 2, 1, 2)


def _names_file(path):
    return re.escape(str(path))


# -- surfaces -----------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply", ".glb"])
def test_surface_files_become_the_voxel_lattice(tmp_path, suffix):
    path = tmp_path / f"box{suffix}"
    trimesh.creation.box(extents=(2.0, 2.0, 2.0)).export(path)
    read = read_mesh(path, pitch=1.0)
    assert isinstance(read, MeshFile) and read.source == str(path) and read.regions == {}
    expected = lattice((3, 3, 3), 1.0, origin=(-1.0, -1.0, -1.0))
    assert read.mesh.n_nodes == 27 and read.mesh.n_springs == 86
    assert np.allclose(np.sort(read.mesh.rest_positions, axis=0),
                       np.sort(expected.rest_positions, axis=0))
    assert read.mesh.tetrahedra is None
    default = read_mesh(path)                       # pitch = largest extent / 10 = 0.2
    assert default.mesh.n_nodes == 11**3
    assert np.isclose(default.mesh.rest_lengths.min(), 0.2)


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
def test_surface_files_become_tetrahedra(tmp_path, suffix):
    pytest.importorskip("tetgen")
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    path = tmp_path / f"ball{suffix}"
    sphere.export(path)
    read = read_mesh(path, method="tetra", max_edge=0.3)
    mesh = read.mesh
    corners = mesh.rest_positions[mesh.tetrahedra]
    volume = np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])).sum() / 6
    assert volume == pytest.approx(sphere.volume, rel=1e-6)          # fills the polyhedron
    assert mesh.n_nodes >= len(sphere.vertices)                        # surface kept + inside
    assert np.linalg.norm(mesh.rest_positions, axis=1).max() <= 1 + 1e-6
    assert mesh.rest_lengths.min() > 0 and np.median(mesh.rest_lengths) < 0.3
    # the same as tetrahedralising the loaded surface (STL stores float32 coordinates)
    direct = from_surface_tetra(trimesh.load(path, force="mesh"), max_edge=0.3)
    assert np.array_equal(mesh.springs, direct.springs)


def test_voxel_reading_matches_from_trimesh(tmp_path):
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    path = tmp_path / "ball.stl"
    sphere.export(path)
    read = read_mesh(path, pitch=0.4).mesh
    direct = from_trimesh(trimesh.load(path, force="mesh"), pitch=0.4)
    assert np.array_equal(read.springs, direct.springs)
    assert np.array_equal(read.rest_positions, direct.rest_positions)


# -- volume meshes with regions -----------------------------------------------------------------
def test_gmsh_file_regions_carry_physical_names(tmp_path):
    points, tetrahedra, region = _kuhn_block((4, 2, 2))
    path = tmp_path / "block.msh"
    meshio.write(path, meshio.Mesh(points, [("tetra", tetrahedra)],
                                   cell_data={"gmsh:physical": [region],
                                              "gmsh:geometrical": [region]},
                                   field_data={"soft": np.array([1, 3]),
                                               "hard": np.array([2, 3])}),
                 file_format="gmsh22", binary=False)
    read = read_mesh(path)
    mesh = read.mesh
    assert mesh.n_nodes == 5 * 3 * 3 and mesh.n_tetrahedra == 6 * 16
    assert list(read.regions) == ["soft", "hard"]
    soft, hard = read.regions["soft"], read.regions["hard"]
    assert not np.any(soft & hard) and np.all(soft | hard)
    x = mesh.rest_positions[:, 0]
    assert np.array_equal(soft, x <= 2) and np.array_equal(hard, x > 2)  # interface → id 1
    assert mesh.group_names == ("soft", "hard", "interface")
    group = np.asarray(mesh.group_names)[mesh.spring_group]
    ends = x[mesh.springs]
    assert np.all(ends[group == "interface"] == 2)          # only springs in the plane x = 2
    assert np.sum(group == "interface") == 12 + 4           # 2x2 squares: edges + diagonals
    assert np.all(ends[group == "soft"] <= 2) and np.all(ends[group == "hard"] >= 2)
    assert np.all(ends[group == "soft"].min(axis=1) < 2)


def test_vtu_file_regions_from_cell_data(tmp_path):
    points, tetrahedra, region = _kuhn_block((2, 1, 1))
    path = tmp_path / "block.vtu"
    meshio.write(path, meshio.Mesh(points, [("tetra", tetrahedra)],
                                   cell_data={"Region": [region.astype(float)]}))
    read = read_mesh(path)
    assert list(read.regions) == ["region1", "region2"]
    assert read.regions["region1"].sum() == 8 and read.regions["region2"].sum() == 4
    assert read.mesh.group_names == ("region1", "region2", "interface")
    with pytest.raises(ValueError, match="read-only"):
        read.regions["region1"][0] = False
    tissues = read.tissue_regions({"region1": "fat", "region2": "fat"})
    assert list(tissues) == ["fat"] and tissues["fat"].all()
    with pytest.raises(InputError, match=_names_file(path) + ".*no region 'region3'"):
        read.tissue_regions({"region3": "fat"})


def test_vtk_file_without_region_data_is_one_group(tmp_path):
    points, tetrahedra, _ = _kuhn_block((2, 2, 2))
    path = tmp_path / "block.vtk"
    meshio.write(path, meshio.Mesh(points, [("tetra", tetrahedra)]))
    read = read_mesh(path)
    assert read.regions == {} and read.mesh.group_names == ("edge",)
    direct = from_tetra(points, tetrahedra)
    assert np.array_equal(read.mesh.springs, direct.springs)
    assert np.array_equal(read.mesh.tetrahedra, direct.tetrahedra)


# -- bad files: InputError naming the file ------------------------------------------------------
def _write_block(path, **options):
    points, tetrahedra, region = _kuhn_block((3, 3, 3))
    meshio.write(path, meshio.Mesh(points, [("tetra", tetrahedra)],
                                   cell_data={"gmsh:physical": [region],
                                              "gmsh:geometrical": [region]}), **options)
    return path


def _cut_in_half(path):
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])
    return path


def test_open_surface_is_refused(tmp_path):
    box = trimesh.creation.box()
    path = tmp_path / "open.stl"
    trimesh.Trimesh(box.vertices, box.faces[:-1]).export(path)
    for method in ("voxel", "tetra"):
        with pytest.raises(InputError, match=_names_file(path) + ".*not watertight"):
            read_mesh(path, method=method)


@pytest.mark.parametrize("name, options", [
    ("cut.vtu", {}), ("cut_binary.vtu", {"binary": True}),
    ("cut.msh", {"file_format": "gmsh22", "binary": False}),
    ("cut_binary.msh", {"file_format": "gmsh22", "binary": True}),
    ("cut.vtk", {"binary": False})])
def test_truncated_volume_files_are_refused(tmp_path, name, options):
    path = _cut_in_half(_write_block(tmp_path / name, **options))
    with pytest.raises(InputError, match=_names_file(path)):
        read_mesh(path)


def test_truncated_binary_stl_is_refused(tmp_path):
    path = tmp_path / "cut.stl"
    trimesh.creation.icosphere().export(path)
    _cut_in_half(path)
    with pytest.raises(InputError, match=_names_file(path) + ": truncated binary STL"):
        read_mesh(path)


def test_surface_only_volume_file_is_refused(tmp_path):
    box = trimesh.creation.box()
    path = tmp_path / "skin.vtu"
    meshio.write(path, meshio.Mesh(box.vertices, [("triangle", box.faces)]))
    with pytest.raises(InputError, match=_names_file(path) + r": has no tetrahedra \(found "
                       r"triangle\); neurofuzzy needs a volume mesh"):
        read_mesh(path)


def test_unknown_missing_and_mismatched_options_are_refused(tmp_path):
    path = tmp_path / "points.xyz"
    path.write_text("0 0 0\n")
    with pytest.raises(InputError, match=_names_file(path) + r": unknown mesh file type "
                       r"'\.xyz'; supported are surfaces \.stl .* volume meshes \.vtu"):
        read_mesh(path)
    with pytest.raises(InputError, match=_names_file(tmp_path / "nope.stl") + ": no such file"):
        read_mesh(tmp_path / "nope.stl")
    block = _write_block(tmp_path / "block.msh", file_format="gmsh22")
    with pytest.raises(InputError, match=_names_file(block) + ": pitch: a volume mesh is used"):
        read_mesh(block, pitch=0.1)
    surface = tmp_path / "box.stl"
    trimesh.creation.box().export(surface)
    with pytest.raises(InputError, match=_names_file(surface) + ": max_edge: does not apply"):
        read_mesh(surface, max_edge=0.1)
    with pytest.raises(InputError, match=_names_file(surface) + ": method: got 'tetgen'"):
        read_mesh(surface, method="tetgen")


# -- tetrahedra survive model and experiment files ----------------------------------------------
def _tet_model():
    points, tetrahedra, region = _kuhn_block((2, 1, 1))
    mesh = from_tetra(points * 0.01, tetrahedra, cell_region=region).with_fixed(
        where=lambda p: p[:, 2] == 0)
    rng = np.random.default_rng(3)
    return Model(mesh, rng.uniform(1e-3, 2e-3, mesh.n_nodes) / 3,
                 (Springs(stiffness=rng.uniform(50, 100, mesh.n_springs) / 7,
                          damping=np.full(mesh.n_springs, 0.01)),)).tied("groups")


def test_tetrahedra_survive_model_files_exactly(tmp_path):
    model = _tet_model()
    loaded = load_model(save_model(model, tmp_path / "tet.yaml"))
    assert np.array_equal(loaded.mesh.tetrahedra, model.mesh.tetrahedra)
    assert loaded.mesh.group_names == model.mesh.group_names
    assert np.array_equal(loaded.springs.stiffness, model.springs.stiffness)
    lattice_model = Model(lattice((2, 2, 2)), np.ones(8),
                          (Springs(stiffness=np.ones(16), damping=np.zeros(16)),))
    path = save_model(lattice_model, tmp_path / "lattice.yaml")
    assert "tetrahedra" not in path.read_text() and load_model(path).mesh.tetrahedra is None
    text = (tmp_path / "tet.yaml").read_text()
    (tmp_path / "bad.yaml").write_text(text.replace("tetrahedra:\n- [", "tetrahedra:\n- [99, "))
    with pytest.raises(InputError, match=r"bad\.yaml:\d+: tetrahedra: expected a rectangular"):
        load_model(tmp_path / "bad.yaml")


def test_tetrahedra_survive_experiment_files(tmp_path):
    model = _tet_model()
    load = np.zeros((model.mesh.n_nodes, 3))
    load[model.mesh.rest_positions[:, 2] > 0, 2] = -1e-3
    experiment = simulate_experiment(model, dt=1e-3, n_frames=5, external_forces=load)
    path = save_experiment(experiment, tmp_path / "tet.npz")
    loaded = load_experiment(path)
    assert np.array_equal(loaded.mesh.tetrahedra, model.mesh.tetrahedra)
    assert load_experiment(save_experiment(simulate_experiment(
        Model(lattice((2, 2, 2)), np.ones(8),
              (Springs(stiffness=np.ones(16), damping=np.zeros(16)),)), dt=1e-3, n_frames=3),
        tmp_path / "lattice.npz")).mesh.tetrahedra is None
    with np.load(path) as archive:
        arrays = dict(archive)
    for bad, message in [(arrays["tetrahedra"] + 0.5, "tetrahedra: expected integer node"),
                         (arrays["tetrahedra"][:, :3], r"tetrahedra: got shape \(12, 3\)"),
                         (arrays["tetrahedra"] + 100, "tetrahedra: node index 1.. is out of")]:
        np.savez(tmp_path / "bad.npz", **{**arrays, "tetrahedra": bad})
        with pytest.raises(InputError, match=r"bad\.npz: " + message):
            load_experiment(tmp_path / "bad.npz")


def test_mesh_command_gives_gmsh_regions_their_tissues(tmp_path, capsys):
    from neurofuzzy.cli import main

    points, tetrahedra, region = _kuhn_block((4, 2, 2))
    path = tmp_path / "block.msh"
    meshio.write(path, meshio.Mesh(points * 0.01, [("tetra", tetrahedra)],
                                   cell_data={"gmsh:physical": [region],
                                              "gmsh:geometrical": [region]},
                                   field_data={"soft": np.array([1, 3]),
                                               "hard": np.array([2, 3])}),
                 file_format="gmsh22", binary=False)
    out = tmp_path / "block.yaml"
    assert main(["mesh", str(path), "--elements", "springs", "--rules", "liver",
                 "--region", "soft=liver", "--region", "hard=tumour", "--fix-below", "0.001",
                 "--out", str(out)]) == 0
    model = load_model(out)
    names = np.asarray(model.mesh.group_names)[model.mesh.spring_group]
    soft = np.median(model.springs.stiffness[names == "soft"] / model.mesh.rest_lengths[
        names == "soft"])
    hard = np.median(model.springs.stiffness[names == "hard"] / model.mesh.rest_lengths[
        names == "hard"])
    assert hard > 5 * soft                     # tumour ("stony") vs liver ("firm")
    assert len(model.mesh.fixed) == 5 * 3 and model.mesh.tetrahedra is not None
    # the regions are tied separately
    assert len(np.unique(model.springs.tie[names == "soft"])) < len(np.unique(model.springs.tie))
    assert main(["mesh", str(path), "--rules", "liver", "--region", "sfot=liver",
                 "--out", str(tmp_path / "x.yaml")]) == 2
    assert "no region 'sfot'" in capsys.readouterr().err
