"""Time series kept out of a fit (``nf.fit(validate_on=...)``, ``fit --validate-on``): load
cases fitted on the others, or the frames after a time, predicted by the fitted model and
reported beside the fitted error."""

import json

import numpy as np
import pytest

from helpers import cli
from neurofuzzy.datasets import corner_node, paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.pipeline import fit

NOISE = 2e-5


@pytest.fixture(scope="module")
def cases():
    """The paper's cube pushed on top and pulled at a corner, 2e-5 m noise; the fit starts
    from a tied cube half as stiff."""
    truth = paper_cube_model()
    push = paper_cube_experiment(truth, noise=NOISE, seed=1, n_frames=40, source="push")
    pull = paper_cube_experiment(truth, noise=NOISE, seed=2, n_frames=40, source="pull",
                                 node=corner_node(truth.mesh), force=(0.15, 0.05, 0.0))
    return push, pull


def _start():
    model = paper_cube_model(tie="global")
    return model.with_springs(stiffness=0.5 * model.springs.stiffness)


def test_a_held_out_load_case_is_predicted_to_the_noise(cases):
    outcome = fit(list(cases), start=_start(), validate_on="pull")
    v = outcome.summary["validation"]
    assert v["experiments"] == ["pull"]
    assert [e.source for e in outcome.experiments] == ["push"]
    # the tied cube is the truth: the pull it never saw is predicted to the noise
    assert v["times_noise"] < 1.3
    assert v["fitted_rms_error"] == pytest.approx(outcome.learner.rms_error_)


def test_a_held_out_time_window_is_fitted_on_the_frames_before(cases):
    push = cases[0]
    outcome = fit(push, start=_start(), validate_on=0.5 * (push.n_frames - 1) * push.dt)
    v = outcome.summary["validation"]
    assert outcome.experiments[0].n_frames == 20 and v["from_time"] > 0
    assert np.isfinite(v["rms_error"]) and v["times_noise"] < 1.3


def test_the_prediction_error_is_measured_not_copied(cases):
    """The half-stiff start, never fitted, predicts the held-out pull many times worse than
    the noise; the truth predicts it to the noise."""
    from neurofuzzy.pipeline.validation import hold_out, validation

    split = hold_out(list(cases), ["pull"], ["push", "pull"])
    noise_rms = np.sqrt(3) * NOISE
    start = validation(_start(), split, substeps=1, fitted_rms=0.0, noise_rms=noise_rms)
    truth = validation(paper_cube_model(), split, substeps=1, fitted_rms=0.0,
                       noise_rms=noise_rms)
    assert start["times_noise"] > 3 and truth["times_noise"] < 1.1


@pytest.mark.parametrize("validate_on, message", [
    (["both"], "not one of the experiments"),
    ([0, 1], "leave one to fit"),
    (100.0, "give a time inside it"),
    (1, "a time window is a float"),
])
def test_bad_held_out_data_is_refused(cases, validate_on, message):
    with pytest.raises(InputError, match=message):
        fit(list(cases), start=_start(), validate_on=validate_on)


def test_fit_validate_on_from_the_command_line(cases, tmp_path):
    from neurofuzzy.io import save_experiment, save_model

    paths = [save_experiment(e, tmp_path / f"{e.source}.npz") for e in cases]
    save_model(_start(), tmp_path / "start.yaml")
    done = cli("fit", *paths, "--start", tmp_path / "start.yaml", "--validate-on",
               "pull.npz", "--json", "--quiet")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["validation"]["experiments"] == [str(paths[1])]
    done = cli("fit", paths[0], "--start", tmp_path / "start.yaml", "--validate-on", "0.01s",
               "--report", tmp_path / "fit.html")
    assert done.returncode == 0, done.stderr
    assert "held out (frames from 0.01 s)" in done.stdout
    assert "Held-out data" in (tmp_path / "fit.html").read_text()
    assert json.loads((tmp_path / "fit.json").read_text())["validation"]["from_time"] == 0.01
    done = cli("fit", paths[0], "--validate-on", "other.npz")
    assert done.returncode == 2 and "hold out some of the experiment files" in done.stderr
