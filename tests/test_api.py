"""The public API as users call it: ``import neurofuzzy as nf`` and the whole pipeline."""

import inspect
import subprocess
import sys
import types

import numpy as np
import pytest

import neurofuzzy as nf


def test_exported_names_survive_any_import_order():
    """Submodules imported first must not shadow a lazily exported function (the bug:
    ``neurofuzzy.experiment`` imported the module ``neurofuzzy.simulate`` over the function)."""
    code = ("import neurofuzzy.experiment, neurofuzzy.simulation, neurofuzzy.diagnosis\n"
            "import neurofuzzy.cli.parser, neurofuzzy.learn, neurofuzzy.report\n"
            "import neurofuzzy.export.mujoco, neurofuzzy.export.paraview\n"
            "from neurofuzzy.export import export_paraview\n"
            "import neurofuzzy as nf\nimport types\n"
            "bad = [n for n in nf.__all__ if isinstance(getattr(nf, n), types.ModuleType)]\n"
            "assert not bad, bad\nassert callable(nf.simulate) and callable(nf.diagnose)\n"
            "assert nf.export.__module__ == 'neurofuzzy.export'\n"
            "print(nf.simulate.__module__)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "neurofuzzy.simulation.integration"      # the function


def test_every_exported_name_resolves_and_is_documented():
    for name in nf.__all__:
        value = getattr(nf, name)
        assert not isinstance(value, types.ModuleType), name
        assert name in nf.__doc__, f"{name} is exported but not in the package docstring"
    assert set(dir(nf)) >= set(nf.__all__)
    from neurofuzzy.learn.prior import FuzzyPrior

    assert nf.FuzzyPrior is FuzzyPrior          # docs/tutorials/prior.md names it
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        nf.simulat


@pytest.mark.slow
def test_the_pipeline_through_nf(tmp_path):
    """mesh → model → data → start → fit → words → diagnosis → reports → files, all via nf.*"""
    mesh = nf.lattice((3, 3, 3), spacing=0.01).with_fixed(where=nf.bottom_layer)
    assert nf.surface_nodes(mesh).sum() == 26
    rules = nf.load_rules(nf.shipped_rules("liver"))
    truth = nf.initialize(rules, mesh, "fibrotic_liver").tied("global")
    load = np.zeros((27, 3))
    load[22] = (0.0, 0.0, -0.05)
    assert nf.stability_limit(truth).max_step > 5e-4
    trajectory = nf.simulate(truth, dt=5e-4, n_frames=120, external_forces=load)
    assert isinstance(trajectory, nf.Trajectory) and trajectory.n_frames == 120
    data = nf.simulate_experiment(truth, dt=5e-4, n_frames=120, external_forces=load)
    assert np.allclose(data.positions, trajectory.positions)
    smooth = nf.reference_experiment(truth, dt=5e-4, n_frames=120, external_forces=load)
    assert np.abs(nf.reference_simulate(truth, dt=5e-4, n_frames=120, external_forces=load)
                  .positions - smooth.positions).max() == 0.0
    nf.check_experiments(truth, [data, smooth])
    assert nf.simulate_like(truth, data).shape == data.positions.shape
    path = nf.save_experiment(data, tmp_path / "data.npz")
    data = nf.load_experiment(path)
    assert isinstance(data, nf.Experiment)

    start = nf.start_model([data], rules="liver", tissue="liver", tie="global")
    assert isinstance(start, nf.StartModel) and start.how == "rules"
    estimated = nf.estimate_start(start.model, [data])
    assert estimated.used and estimated.how == "equation error"
    learner = nf.GradientLearner().fit(start.model, data)
    assert learner.rms_error_ < 1e-9 < nf.rms_error(start.model, data)
    found, true = (nf.materials(learner.model_, rules)["liver"],
                   nf.materials(truth, rules)["fibrotic_liver"])
    assert found["youngs_modulus"] == pytest.approx(true["youngs_modulus"], rel=1e-6)
    assert found["labels"] == true["labels"] and found["tissue"] == "liver"
    assert nf.material_values(rules, learner.model_) == pytest.approx(
        nf.material_values(rules, truth), rel=1e-6)
    paper = nf.PaperLearner(cycles=3, learning_rate=0.1).fit(start.model, data)
    assert paper.history_.shape == (3,)

    model_file = nf.save_model(learner.model_, tmp_path / "fitted.yaml")
    assert isinstance(nf.load_model(model_file), nf.Model)
    outcome = nf.fit(data, rules="liver", tissue="liver", tie="global",
                     options=nf.FitOptions(mesh_check=False))
    assert outcome.rms_error == pytest.approx(learner.rms_error_, rel=1e-6, abs=1e-12)
    report = nf.fit_report(outcome, tmp_path / "report.html")
    assert "fibrotic" not in report.read_text() and "liver" in report.read_text()
    files = nf.export_paraview(tmp_path / "pv", learner.model_, data, every=40)
    assert files["pvd"].exists()

    hidden = truth.with_effects(nf.Gravity([0.0, 0.0, -9.81]))
    result = nf.diagnose(truth, nf.simulate_experiment(hidden, dt=5e-4, n_frames=120,
                                                       external_forces=load),
                         max_effects=1, substeps=1)
    assert isinstance(result, nf.Diagnosis) and result.names == ["gravity"]
    assert nf.diagnosis_report(result, tmp_path / "diagnosis.html").exists()



def test_force_terms_and_effects_are_reachable():
    model = nf.Model.uniform(nf.lattice((2, 2, 2)), stiffness=1.0, damping=0.1, total_mass=1.0)
    assert model.force_terms == (model.springs,) and nf.Model is nf.Model
    assert isinstance(model.springs, nf.Springs) and issubclass(nf.Springs, nf.ForceTerm)
    assert issubclass(nf.Tetrahedra, nf.ForceTerm) and model.elements is None
    for cls in (nf.Gravity, nf.NodeDrag, nf.StiffInclusion, nf.SoftInclusion,
                nf.NonlinearStiffening, nf.UnmodeledLoad):
        assert issubclass(cls, nf.Effect) and nf.EFFECTS[cls.name] is cls
    for error in (nf.InputError, nf.UnstableTimeStepError):
        assert issubclass(error, nf.NeurofuzzyError)


@pytest.mark.parametrize("cls", [nf.GradientLearner, nf.PaperLearner])
def test_learners_follow_the_estimator_convention(cls):
    learner = cls(learn_masses=True)
    params = learner.get_params()
    assert params["learn_masses"] is True
    assert set(params) == {name for name, p in inspect.signature(cls.__init__).parameters.items()
                           if p.kind == p.KEYWORD_ONLY}
    assert repr(learner) == f"{cls.__name__}(learn_masses=True)"
    assert learner.set_params(learn_masses=False) is learner and not learner.learn_masses
    with pytest.raises(nf.InputError, match="did you mean 'learn_masses'"):
        learner.set_params(learn_mass=True)
    assert not any(name.endswith("_") and not name.startswith("_") for name in vars(learner))


def test_meshes_and_markers_through_nf(tmp_path):
    import trimesh

    box = trimesh.creation.box(extents=(0.02, 0.02, 0.02))
    voxels = nf.from_trimesh(box, 0.01)
    assert (voxels.n_nodes, voxels.n_springs) == (27, 86)
    box.export(tmp_path / "box.stl")
    read = nf.read_mesh(tmp_path / "box.stl", pitch=0.01)
    assert isinstance(read, nf.MeshFile) and read.mesh.n_springs == 86
    points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    tetra = nf.from_tetra(points, [[0, 1, 2, 3]])
    assert tetra.n_springs == 6 and tetra.n_tetrahedra == 1
    assert isinstance(nf.Mesh(points, [[0, 1], [1, 2]]), nf.Mesh)
    pytest.importorskip("tetgen")
    assert nf.from_surface_tetra(box, max_edge=0.01).n_tetrahedra > 0

    mesh = voxels.with_fixed(where=nf.bottom_layer)
    model = nf.Model.uniform(mesh, stiffness=50.0, damping=0.02, total_mass=0.008)
    load = np.zeros((27, 3))
    load[22] = (0.0, 0.0, -0.1)
    data = nf.simulate_experiment(model, dt=1e-3, n_frames=20, external_forces=load)
    rows = [f"{t * 1e-3:.4f},m{i},{x * 1e3:.6f},{y * 1e3:.6f},{z * 1e3:.6f}"
            for t in range(20) for i, (x, y, z) in enumerate(data.positions[t])]
    (tmp_path / "markers.csv").write_text("# units: mm\ntime,marker,x,y,z\n" + "\n".join(rows))
    imported = nf.markers_to_experiment(nf.read_markers(tmp_path / "markers.csv"), mesh)
    observation = imported.experiment.observation        # markers embedded where they are
    assert np.allclose(observation.frames(data.positions), observation.values, atol=1e-9)
    assert imported.summary["markers"] == 27 and imported.summary["attach"] == "embed"


def test_every_subpackage_is_installed():
    """pyproject lists the packages explicitly (the rule files are mapped in as
    neurofuzzy.shipped_rules); a new subpackage missing there would be absent from a
    non-editable install."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = {".".join(path.parent.relative_to(root).parts)
             for path in (root / "neurofuzzy").rglob("__init__.py")}
    assert found <= listed, sorted(found - listed)
