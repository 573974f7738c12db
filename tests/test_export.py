"""ParaView export: VTU frames + PVD collection, XDMF time series, all-or-nothing writing."""

import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest

from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.export import export_paraview
from neurofuzzy.experiment import simulate_like

meshio = pytest.importorskip("meshio")

N_FRAMES = 20
UNOBSERVED = 13                      # the cube's centre node


@pytest.fixture(scope="module")
def truth():
    return paper_cube_model()


@pytest.fixture(scope="module")
def model():
    """A softer model than the one that made the data, so simulation and measurement differ."""
    return paper_cube_model(stiffness={"edge": 40.0, "diagonal": 45.0})


@pytest.fixture(scope="module")
def experiment(truth):
    experiment = paper_cube_experiment(truth, n_frames=N_FRAMES)
    observed = np.ones(experiment.n_nodes, dtype=bool)
    observed[UNOBSERVED] = False
    positions = experiment.positions.copy()
    positions[:, UNOBSERVED] = np.nan
    return experiment.replace(positions=positions, observed=observed)


def _pvd(path):
    rows = ET.parse(path).getroot().find("Collection").findall("DataSet")
    return [row.get("file") for row in rows], np.array([float(row.get("timestep"))
                                                        for row in rows])


def test_vtu_frames_hold_the_simulation_and_the_model(tmp_path, model, experiment):
    written = export_paraview(tmp_path, model, experiment, formats=("vtu",))
    simulated = simulate_like(model, experiment)
    rest = model.mesh.rest_positions
    assert set(written) == {"pvd", "vtu"}
    assert len(written["vtu"]) == N_FRAMES
    for t in (0, 7, N_FRAMES - 1):
        mesh = meshio.read(written["vtu"][t])
        np.testing.assert_allclose(mesh.points, simulated[t])
        np.testing.assert_array_equal(mesh.cells_dict["line"], model.mesh.springs)
        np.testing.assert_allclose(mesh.cell_data["stiffness"][0], model.springs.stiffness)
        np.testing.assert_allclose(mesh.cell_data["damping"][0], model.springs.damping)
        np.testing.assert_array_equal(mesh.cell_data["spring_group"][0], model.mesh.spring_group)
        a, b = model.mesh.springs.T
        length = np.linalg.norm(simulated[t, b] - simulated[t, a], axis=1)
        np.testing.assert_allclose(mesh.cell_data["strain"][0],
                                   length / model.springs.rest_length - 1, atol=1e-12)
        data = mesh.point_data
        np.testing.assert_allclose(data["displacement_simulated"], simulated[t] - rest,
                                   atol=1e-15)
        measured = data["measured"]
        assert np.isnan(measured[UNOBSERVED]).all()
        assert np.isnan(data["error"][UNOBSERVED])
        assert data["observed"][UNOBSERVED] == 0
        seen = np.arange(model.n_nodes) != UNOBSERVED
        np.testing.assert_allclose(measured[seen], experiment.positions[t, seen])
        np.testing.assert_allclose(data["error"][seen],
                                   np.linalg.norm(simulated[t, seen] - measured[seen], axis=1))
        assert np.all(data["observed"][seen] == 1)
        np.testing.assert_array_equal(np.flatnonzero(data["fixed"]), model.mesh.fixed)
        np.testing.assert_allclose(data["mass"], model.node_mass)
        np.testing.assert_allclose(data["external_force"], experiment.forces_per_frame()[t])
    # the springs between measured nodes have a measured strain; those touching node 13 none
    touching = (model.mesh.springs == UNOBSERVED).any(axis=1)
    strain_measured = meshio.read(written["vtu"][5]).cell_data["strain_measured"][0]
    assert np.isnan(strain_measured[touching]).all()
    assert np.isfinite(strain_measured[~touching]).all()
    assert np.abs(meshio.read(written["vtu"][-1]).point_data["error"][seen]).max() > 0


def test_a_gap_is_unmeasured_at_its_frame_only(tmp_path, model, experiment):
    positions = experiment.positions.copy()
    positions[6, 4] = np.nan                    # node 4's marker occluded at frame 6
    try:
        gappy = experiment.replace(positions=positions)
    except InputError:
        pytest.skip("this Experiment does not accept gaps in observed nodes")
    written = export_paraview(tmp_path, model, gappy, formats=("vtu",))
    at_gap, after = (meshio.read(written["vtu"][t]).point_data for t in (6, 7))
    assert at_gap["observed"][4] == 0 and np.isnan(at_gap["measured"][4]).all()
    assert np.isnan(at_gap["error"][4]) and np.isnan(at_gap["displacement_measured"][4]).all()
    assert after["observed"][4] == 1
    np.testing.assert_allclose(after["measured"][4], positions[7, 4])


def test_pvd_lists_every_frame_with_its_time(tmp_path, model, experiment):
    written = export_paraview(tmp_path, model, experiment, formats=("vtu",), stem="cube",
                              every=3)
    files, times = _pvd(written["pvd"])
    frames = np.arange(0, N_FRAMES, 3)
    assert files == [f"cube_{t:04d}.vtu" for t in frames]
    assert files == [path.name for path in written["vtu"]]
    assert all((tmp_path / name).is_file() for name in files)
    np.testing.assert_array_equal(times, frames * experiment.dt)
    assert written["pvd"] == tmp_path / "cube.pvd"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(files + ["cube.pvd"])


def test_xdmf_time_series_reads_back(tmp_path, model, experiment):
    written = export_paraview(tmp_path, model, experiment, formats=("xdmf",))
    assert set(written) == {"xdmf"} and written["xdmf"] == tmp_path / "neurofuzzy.xdmf"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["neurofuzzy.xdmf"]   # no .h5
    simulated = simulate_like(model, experiment)
    with meshio.xdmf.TimeSeriesReader(written["xdmf"]) as reader:
        points, cells = reader.read_points_cells()
        np.testing.assert_allclose(points, model.mesh.rest_positions)
        np.testing.assert_array_equal(cells[0].data, model.mesh.springs)
        assert reader.num_steps == N_FRAMES
        for k in (0, 11):
            t, point_data, cell_data = reader.read_data(k)
            assert t == k * experiment.dt
            np.testing.assert_allclose(point_data["displacement_simulated"],
                                       simulated[k] - model.mesh.rest_positions, atol=1e-15)
            assert np.isnan(point_data["measured"][UNOBSERVED]).all()
            np.testing.assert_allclose(cell_data["stiffness"][0], model.springs.stiffness)


def test_model_alone_is_one_frame_at_rest(tmp_path, model):
    written = export_paraview(tmp_path, model)
    assert len(written["vtu"]) == 1
    mesh = meshio.read(written["vtu"][0])
    np.testing.assert_allclose(mesh.points, model.mesh.rest_positions)
    assert np.isnan(mesh.point_data["measured"]).all()
    np.testing.assert_allclose(mesh.cell_data["strain"][0], 0.0, atol=1e-12)
    assert _pvd(written["pvd"])[1].tolist() == [0.0]


def test_a_failing_write_leaves_nothing_behind(tmp_path, model, experiment, monkeypatch):
    (tmp_path / "notes.txt").write_text("mine")
    earlier = export_paraview(tmp_path, model, experiment, every=4)
    before = {path.name: path.read_bytes() for path in tmp_path.iterdir()}
    real_write, calls = meshio.write, []

    def failing_write(*args, **kwargs):
        calls.append(args[0])
        if len(calls) == 3:
            raise OSError("disk full")
        return real_write(*args, **kwargs)

    monkeypatch.setattr(meshio, "write", failing_write)
    with pytest.raises(OSError, match="disk full"):
        export_paraview(tmp_path, model, experiment)
    assert len(calls) == 3
    after = {path.name: path.read_bytes() for path in tmp_path.iterdir()}
    assert after == before                      # nothing new, nothing changed, no temp dir
    assert set(earlier) == {"pvd", "vtu", "xdmf"}

    fresh = tmp_path / "fresh"
    calls.clear()
    with pytest.raises(OSError):
        export_paraview(fresh, model, experiment)
    assert not fresh.exists()                   # the directory this call made is gone too


def test_a_new_export_replaces_the_earlier_series_only(tmp_path, model, experiment):
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "other_0001.vtu").write_text("someone else's")
    export_paraview(tmp_path, model, experiment)                       # 20 frames
    written = export_paraview(tmp_path, model, experiment, every=5)    # frames 0, 5, 10, 15
    names = sorted(path.name for path in tmp_path.iterdir())
    assert names == sorted(["notes.txt", "other_0001.vtu", "neurofuzzy.pvd", "neurofuzzy.xdmf"]
                           + [path.name for path in written["vtu"]])
    assert (tmp_path / "notes.txt").read_text() == "mine"
    with meshio.xdmf.TimeSeriesReader(written["xdmf"]) as reader:
        assert reader.num_steps == 4


def test_given_simulation_is_checked(tmp_path, model, experiment):
    with pytest.raises(InputError, match=r"got shape \(19, 27, 3\); expected \(n_frames, "
                                         r"n_nodes, 3\) = \(20, 27, 3\)"):
        export_paraview(tmp_path, model, experiment, simulated=np.zeros((19, 27, 3)))
    with pytest.raises(InputError, match=r"got shape \(5, 26, 3\)"):
        export_paraview(tmp_path, model, simulated=np.zeros((5, 26, 3)), dt=0.1)
    with pytest.raises(InputError, match="no time step"):
        export_paraview(tmp_path, model, simulated=np.zeros((5, 27, 3)))
    bad = simulate_like(model, experiment)
    bad[4, 2, 0] = np.nan
    with pytest.raises(InputError, match="frame 4"):
        export_paraview(tmp_path, model, experiment, simulated=bad)
    assert list(tmp_path.iterdir()) == []


def test_given_simulation_without_experiment_uses_dt(tmp_path, model):
    positions = np.repeat(model.mesh.rest_positions[None], 3, axis=0)
    positions[2] += 0.001
    written = export_paraview(tmp_path, model, simulated=positions, dt=0.25, formats="vtu")
    np.testing.assert_array_equal(_pvd(written["pvd"])[1], [0.0, 0.25, 0.5])
    np.testing.assert_allclose(meshio.read(written["vtu"][2]).points, positions[2])


def test_options_are_checked(tmp_path, model, experiment):
    with pytest.raises(InputError, match="unknown format 'vtk'; did you mean 'vtu'"):
        export_paraview(tmp_path, model, experiment, formats=("vtk",))
    with pytest.raises(InputError, match="every"):
        export_paraview(tmp_path, model, experiment, every=0)
    with pytest.raises(InputError, match="stem"):
        export_paraview(tmp_path, model, experiment, stem="../escape")
    with pytest.raises(InputError, match="dt"):
        export_paraview(tmp_path, model, experiment, dt=2 * experiment.dt)
    other = paper_cube_model().replace(mesh=paper_cube_model().mesh.with_fixed([0]))
    with pytest.raises(InputError, match="fixed"):
        export_paraview(tmp_path, other, experiment)
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(InputError, match="not a directory"):
        export_paraview(target, model, experiment)
    assert sorted(path.name for path in tmp_path.iterdir()) == ["file"]


def test_tetrahedra_join_the_vtu_files(tmp_path, model):
    mesh = replace(model.mesh)
    tets = np.array([[0, 1, 3, 9], [1, 3, 4, 10]])
    object.__setattr__(mesh, "tetrahedra", tets)      # until Mesh grows the attribute
    written = export_paraview(tmp_path, model.replace(mesh=mesh))
    vtu = meshio.read(written["vtu"][0])
    np.testing.assert_array_equal(vtu.cells_dict["tetra"], tets)
    np.testing.assert_allclose(vtu.cell_data["stiffness"][0], model.springs.stiffness)
    assert np.isnan(vtu.cell_data["stiffness"][1]).all()
    assert (vtu.cell_data["spring_group"][1] == -1).all()
    with meshio.xdmf.TimeSeriesReader(written["xdmf"]) as reader:
        _, cells = reader.read_points_cells()
        assert [block.type for block in cells] == ["line"]
