import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.io import load_experiment, load_model, save_experiment, save_model


def _write(path, **arrays):
    np.savez(path, **arrays)
    return path


def _valid_arrays(experiment):
    return {"rest_positions": experiment.mesh.rest_positions,
            "springs": experiment.mesh.springs, "dt": experiment.dt,
            "positions": experiment.positions, "fixed": experiment.mesh.fixed,
            "external_forces": experiment.external_forces}


def test_experiment_round_trip(tmp_path, cube_experiment):
    path = save_experiment(cube_experiment, tmp_path / "cube.npz")
    loaded = load_experiment(path)
    assert np.array_equal(loaded.positions, cube_experiment.positions)
    assert np.array_equal(loaded.mesh.springs, cube_experiment.mesh.springs)
    assert np.array_equal(loaded.mesh.fixed, cube_experiment.mesh.fixed)
    assert loaded.mesh.group_names == ("edge", "diagonal")
    assert np.array_equal(loaded.node_mass, cube_experiment.node_mass)
    assert np.array_equal(loaded.truth["true_stiffness"], cube_experiment.truth["true_stiffness"])
    assert loaded.dt == cube_experiment.dt
    assert not list(tmp_path.glob(".*.tmp"))           # no temporary file left behind


def test_model_yaml_round_trip_is_exact(tmp_path, rng, cube_model):
    model = cube_model.with_springs(stiffness=rng.uniform(1, 100, 86) / 3.0,
                                    damping=rng.uniform(0, 1, 86) / 7.0).tied("groups")
    loaded = load_model(save_model(model, tmp_path / "m.yaml"))
    assert np.array_equal(loaded.node_mass, model.node_mass)
    for key in ("stiffness", "damping", "rest_length", "tie"):
        assert np.array_equal(getattr(loaded.springs, key), getattr(model.springs, key)), key
    assert np.array_equal(loaded.mesh.rest_positions, model.mesh.rest_positions)
    assert loaded.mesh.group_names == model.mesh.group_names



def test_a_model_file_keeps_the_record_of_its_fit(tmp_path, cube_model):
    from neurofuzzy.io.models import load_fit_record

    record = {"neurofuzzy_version": "0.1.0",
              "lack_of_fit": {"rms": 2.5e-5, "noise": 1.2e-5, "ratio": 2.08,
                              "verdict": "residual 2.1x the noise"}}
    path = save_model(cube_model, tmp_path / "m.yaml", fit=record)
    assert load_fit_record(path) == record
    assert np.array_equal(load_model(path).springs.stiffness, cube_model.springs.stiffness)
    assert load_fit_record(save_model(cube_model, tmp_path / "plain.yaml")) is None
    (tmp_path / "bad.yaml").write_text(path.read_text().replace("fit:\n", "fit: 3\nx:\n"))
    with pytest.raises(InputError, match=r"bad\.yaml.*fit"):
        load_model(tmp_path / "bad.yaml")

@pytest.mark.parametrize("change, message", [
    (lambda a: a.pop("positions"), r"cube\.npz: positions: required key is missing"),
    (lambda a: a.update(positions=np.zeros((5, 27, 2))),
     r"positions: got shape \(5, 27, 2\); expected \(n_frames, n_nodes, 3\)"),
    (lambda a: a.update(positions=a["positions"][:, :20]), r"positions: .*n_nodes = 27"),
    (lambda a: a["positions"].__setitem__((3, 13, 0), np.inf),
     r"positions: infinite value at frame 3, node 13; use NaN"),
    (lambda a: a["positions"].__setitem__((0, 13, 0), np.nan),
     r"positions: node 13 is marked observed but has no position at frame 0"),
    (lambda a: a["springs"].__setitem__((4, 1), 99),
     r"springs: node index 99 is out of range; the mesh has 27 nodes"),
    (lambda a: a.update(springs=a["springs"].astype(float)), r"springs: expected integer"),
    (lambda a: a.update(dt=-0.1), r"dt: got -0\.1; expected a positive number"),
    (lambda a: a.update(observed=np.ones(26, bool)), r"observed: .*expected bool of shape"),
    (lambda a: a.update(fixed=np.array([30])), r"fixed: node index 30 is out of range"),
    (lambda a: a.update(external_forces=np.zeros((27, 2))), r"external_forces: got shape"),
    (lambda a: a.update(masses=-np.ones(27)), r"masses: must be positive"),
    (lambda a: a.update(obsreved=np.ones(27, bool)), r"obsreved: unknown key; did you mean 'observed'"),
])
def test_bad_experiment_files_name_file_and_key(tmp_path, cube_experiment, change, message):
    arrays = {key: np.array(value) for key, value in _valid_arrays(cube_experiment).items()}
    change(arrays)
    path = _write(tmp_path / "cube.npz", **arrays)
    with pytest.raises(InputError, match=message):
        load_experiment(path)


def test_unobserved_nodes_may_hold_nan(tmp_path, cube_experiment):
    arrays = _valid_arrays(cube_experiment)
    arrays["positions"] = arrays["positions"].copy()
    arrays["positions"][:, 13] = np.nan
    observed = np.ones(27, bool)
    observed[13] = False
    experiment = load_experiment(_write(tmp_path / "c.npz", observed=observed, **arrays))
    assert not experiment.observed[13]
    assert np.allclose(experiment.initial_positions()[13], experiment.mesh.rest_positions[13])


def test_unreadable_files(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_experiment(tmp_path / "missing.npz")
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    with pytest.raises(InputError, match="junk.npz: not a readable .npz"):
        load_experiment(junk)
    bad_yaml = tmp_path / "m.yaml"
    bad_yaml.write_text("format: neurofuzzy-model/1\nnodes: [1, 2\n")
    with pytest.raises(InputError, match=r"m\.yaml:3: malformed YAML"):
        load_model(bad_yaml)


def test_failed_write_leaves_the_old_file(tmp_path, cube_model):
    path = save_model(cube_model, tmp_path / "m.yaml")
    before = path.read_text()

    from neurofuzzy.effects import Gravity

    # an effect whose option cannot be written as YAML
    broken = cube_model.with_effects(Gravity([0.0, 0.0, -9.81], unwritable=object()))
    with pytest.raises(Exception):
        save_model(broken, path)
    assert path.read_text() == before
    assert not list(tmp_path.glob(".*.tmp"))


def test_an_experiment_moved_by_a_plate_and_a_tool_round_trips(tmp_path):
    """The driven sets (one row per frame), the load cell and the tool of a recording in
    time are written to and read from the experiment file as they were; a file whose driven
    keys are incomplete names the missing key."""
    from neurofuzzy.experiment import Experiment
    from neurofuzzy.mesh import from_tetra, kuhn_block
    from neurofuzzy.paths import DrivenPath, ToolPath
    from neurofuzzy.simulation.contact import Sphere

    points, tetrahedra = kuhn_block((2, 2, 2), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    frames = 5
    top = np.flatnonzero(np.isclose(mesh.rest_positions[:, 2], 0.02))
    path = np.linspace(0, -1e-3, frames)[:, None] * (0, 0, 1)
    rng = np.random.default_rng(0)
    experiment = Experiment(
        mesh=mesh, dt=0.01, positions=mesh.rest_positions + np.zeros((frames, 1, 3)),
        driven=(DrivenPath(top[:4], path, "z", "stage"),), reaction=rng.normal(size=(5, 3)),
        tool=ToolPath(Sphere(0.003), np.array([0.01, 0.01, 0.023]) + path, name="probe"))
    back = load_experiment(save_experiment(experiment, tmp_path / "moved.npz"))
    (driven,), (given,) = back.driven, experiment.driven
    assert np.array_equal(driven.nodes, given.nodes) and driven.components == "z"
    assert driven.name == "stage" and np.array_equal(driven.displacement, path)
    assert np.array_equal(back.reaction, experiment.reaction)
    assert back.tool.name == "probe" and back.tool.tool.radius == 0.003
    assert np.array_equal(back.tool.positions, experiment.tool.positions)
    data = dict(np.load(tmp_path / "moved.npz"))
    del data["driven_names"]
    np.savez(tmp_path / "broken.npz", **data)
    with pytest.raises(InputError, match="driven_names") as caught:
        load_experiment(tmp_path / "broken.npz")
    assert "broken.npz" in str(caught.value)
