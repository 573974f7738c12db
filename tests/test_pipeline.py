"""The one fit pipeline (:func:`neurofuzzy.fit`): the same start, prior, learner, outcome check
and summary for Python, ``neurofuzzy fit`` and every specimen of ``fit-many``; a fit that ends
worse than a model that never moves is a failure in all three."""

import json

import numpy as np
import pytest
from helpers import cli

import neurofuzzy as nf
from neurofuzzy.batch import fit_specimen, read_manifest
from neurofuzzy.datasets import CUBE, paper_cube_model
from neurofuzzy.io import save_experiment, save_model


@pytest.fixture(scope="module")
def short(cube_experiment):
    return cube_experiment.first_frames(40)


@pytest.fixture
def soft_start(tmp_path, short):
    """An experiment file and a start model a thousand times too soft: one iteration cannot
    bring it anywhere near the data, so the fit ends worse than a model that never moves."""
    save_experiment(short, tmp_path / "cube.npz")
    save_model(paper_cube_model(stiffness=0.05, damping=2e-5), tmp_path / "soft.yaml")
    return tmp_path


def test_a_fit_returns_the_checked_outcome_and_the_summary_of_the_command(short, tmp_path):
    outcome = nf.fit(short, tie="global", names=["cube.npz"])
    assert isinstance(outcome, nf.FitOutcome)
    assert np.allclose(outcome.model.springs.stiffness, CUBE["stiffness"], rtol=1e-3)
    assert outcome.summary["tie"] == "global" and outcome.summary["experiments"] == ["cube.npz"]
    assert outcome.summary["start"]["how"] == outcome.start.how
    assert outcome.record["lack_of_fit"] == outcome.lack_of_fit.to_dict()
    path = save_experiment(short, tmp_path / "cube.npz")
    done = cli("fit", path, "--tie", "global", "--json")
    assert done.returncode == 0, done.stderr
    command = json.loads(done.stdout)
    assert set(command) == set(outcome.summary)
    assert command["stiffness"] == pytest.approx(outcome.summary["stiffness"], rel=1e-9)


def test_a_fit_worse_than_no_motion_fails_in_python_the_command_and_fit_many(soft_start):
    folder = soft_start
    with pytest.raises(nf.FitFailedError, match="worse than a model that never moves"):
        nf.fit(folder / "cube.npz", start=folder / "soft.yaml", tie="global", substeps=1,
               cycles=1)
    done = cli("fit", folder / "cube.npz", "--start", folder / "soft.yaml", "--tie", "global",
               "--substeps", "1", "--cycles", "1", "--quiet")
    assert done.returncode == 2 and "the fit failed" in done.stderr
    (folder / "cohort.csv").write_text("id,group,experiments,start,tie,substeps,cycles\n"
                                       "soft,g,cube.npz,soft.yaml,global,1,1\n")
    [specimen] = read_manifest(folder / "cohort.csv")
    record = fit_specimen(specimen)                 # what fit-many runs for every specimen
    assert record["status"] == "failed" and record["kind"] == "fit"
    assert "worse than a model that never moves" in record["error"]
    assert "fit" not in record and "files" not in record


@pytest.mark.parametrize("final", [np.nan, 1.0])
def test_a_failed_fit_says_its_rms_per_marker_in_metres(short, final):
    from neurofuzzy.pipeline.outcome import check_outcome

    model = paper_cube_model()
    with pytest.raises(nf.FitFailedError) as failed:
        check_outcome("fit", [short], model, model, 2e-4, final, 1)
    message = str(failed.value)
    assert "RMS error per marker 0.0002 m -> " in message
    assert ("diverges" in message) == (not np.isfinite(final))
    assert np.isfinite(final) == ("-> 1 m, worse than a model that never moves" in message)


def test_the_paper_method_fits_the_spring_network(short, tmp_path):
    outcome = nf.fit(short, tie="global", method="paper", cycles=2)
    assert outcome.model.elements is None and outcome.summary["method"] == "paper"
    # what only the gradient learner estimates is absent, not an error, and the report says so
    assert outcome.identifiability is None and outcome.intervals == {}
    assert outcome.prior_weight is None and outcome.regions is None
    assert outcome.history.shape == (2,) and outcome.n_cycles == 2
    report = nf.fit_report(outcome, tmp_path / "paper.html").read_text()
    assert "does not estimate standard errors" in report


def test_the_fit_report_draws_the_outcome_it_is_handed(short, tmp_path):
    """The report reads the outcome (its model, history, lack of fit, identifiability), not a
    learner: a summary-level change to the outcome shows in the report's JSON twin."""
    outcome = nf.fit(short, tie="global", options=nf.FitOptions(mesh_check=False))
    assert outcome.identifiability is not None and outcome.n_cycles == len(outcome.history)
    nf.fit_report(outcome, tmp_path / "fit.html")
    twin = json.loads((tmp_path / "fit.json").read_text())
    assert twin["rms_error"] == pytest.approx(outcome.rms_error, rel=1e-9, abs=1e-15)
    assert twin["cycles"] == outcome.n_cycles
    assert twin["lack_of_fit"]["verdict"] == outcome.lack_of_fit.verdict
    assert twin["std_errors"] == pytest.approx(
        list(outcome.identifiability.to_dict()["std_errors"]), nan_ok=True)


def test_a_path_or_an_experiment_is_taken_and_anything_else_refused():
    with pytest.raises(nf.InputError, match="expected an Experiment"):
        nf.fit([3.0])
    with pytest.raises(nf.InputError, match="no experiments"):
        nf.fit([])


def test_how_a_fit_learns_is_one_options_value_and_its_shorthands_override_it(soft_start):
    """``options`` carries the learner's options; a shorthand keyword overrides its field;
    ``checked=False`` returns a fit that ends worse than a model that never moves (a
    diagnosis's refit is scored by its error) where the checked fit refuses it."""
    folder = soft_start
    options = nf.FitOptions(substeps=1, cycles=1)
    with pytest.raises(nf.FitFailedError, match="worse than a model that never moves"):
        nf.fit(folder / "cube.npz", start=folder / "soft.yaml", tie="global", options=options)
    kept = nf.fit(folder / "cube.npz", start=folder / "soft.yaml", tie="global",
                  options=options.replace(checked=False))
    assert kept.rms_error > nf.pipeline.measured_motion(kept.experiments)
    assert kept.learner.max_iterations == 1 and kept.substeps == 1
    overridden = nf.fit(folder / "cube.npz", start=folder / "soft.yaml", tie="global",
                        options=options.replace(checked=False), cycles=3, mesh_check=False)
    assert overridden.learner.max_iterations == 3 and overridden.learner.mesh_check is False


@pytest.mark.parametrize("options, match", [
    ({"method": "gradiant"}, "did you mean 'gradient'"),
    ({"cycles": 0}, "expected a positive integer"),
    ({"cycles": True}, "expected a positive integer"),
    ({"method": "paper", "windows": ()}, "windows: options of the gradient method"),
    ({"method": "paper", "mesh_check": "refit"}, "the mesh check needs elements"),
])
def test_options_a_fit_cannot_use_are_refused_when_made(options, match):
    with pytest.raises(nf.InputError, match=match):
        nf.FitOptions(**options)


def test_the_diagnosis_s_options_reach_the_learner():
    learner = nf.FitOptions(windows=(), tolerance=1e-6, abandon_above=1e-3, fitted_at=2,
                            mesh_check=False).learner()
    assert (learner.windows, learner.tolerance, learner.abandon_above, learner.fitted_at) == \
        ((), 1e-6, 1e-3, 2)
    default = nf.FitOptions().learner()
    assert default.windows is None and default.tolerance == 1e-10
    with pytest.raises(nf.InputError, match="takes no prior"):
        nf.FitOptions(method="paper").learner(prior=object())


def test_a_recording_a_stage_moved_is_routed_to_its_own_fit(short, tmp_path):
    """``nf.fit`` of a recording whose body a stage moved (driven sets) takes the implicit
    fit's route (the command's); what that fit does not take is refused before any work."""
    from neurofuzzy.mesh import from_tetra, kuhn_block
    from neurofuzzy.paths import DrivenPath
    from neurofuzzy.pipeline.lab import lab_kind

    points, tetrahedra = kuhn_block((1, 1, 1), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    top = np.flatnonzero(np.isclose(points[:, 2], 0.01))
    plate = DrivenPath(top, np.linspace(0.0, -1e-3, 5)[:, None] * np.array([0.0, 0.0, 1.0]))
    moved = nf.Experiment(mesh=mesh, dt=0.002, positions=np.repeat(points[None], 5, axis=0),
                          driven=(plate,))
    assert lab_kind(moved) == lab_kind(save_experiment(moved, tmp_path / "moved.npz")) \
        == "moving boundaries"
    assert lab_kind([tmp_path / "moved.npz"]) == "moving boundaries"
    assert lab_kind([short, save_experiment(short, tmp_path / "cube.npz")]) is None
    with pytest.raises(nf.InputError, match="^learn_masses: is an option of the learners'"):
        nf.fit(moved, rules="liver", tissue="liver", learn_masses=True)
    with pytest.raises(nf.InputError, match="^substeps: "):
        nf.fit(moved, rules="liver", tissue="liver", substeps=0)
    with pytest.raises(nf.InputError, match="^validate_on: holds no data out"):
        nf.fit(moved, rules="liver", tissue="liver", validate_on=0.004)
    # its diagnosis from data too: the time series' options refused by name, before any work
    with pytest.raises(nf.InputError, match="^localise, max_time: are options of the diag"):
        nf.diagnose_data(moved, rules="liver", tissue="liver", localise=True, max_time=9.0)
    with pytest.raises(nf.InputError, match="^substeps: "):
        nf.diagnose_data(moved, rules="liver", tissue="liver", substeps=0)
