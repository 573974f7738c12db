"""Lack of fit: every fit says how far its model stays from the data against the marker noise,
fits the markers' rest positions instead of copying one noisy frame, and widens its standard
errors when the residuals are correlated (a model that misses something)."""

import json

import numpy as np
import pytest
from helpers import assert_gradient_exact, cli
from test_markers_embedded import as_recording, element_block, interior_points, record

from neurofuzzy.effects import Gravity
from neurofuzzy.learn import GradientLearner, Parameterization, Sensitivity
from neurofuzzy.learn.identifiability import analyse
from neurofuzzy.learn.lack_of_fit import EXPLAINED
from neurofuzzy.formatting import length_text
from neurofuzzy.markers import markers_to_experiment
from neurofuzzy.observation import remove_offsets

import numpy_reference as reference

NOISE = 5e-6


def markers_from_frame_zero(truth, frames=40, noise=NOISE, seed=1, n_markers=24):
    """Markers between nodes, the load from frame 0 (their rest positions are the noisy
    frame 0), as ``import`` makes them."""
    data, steps = record(truth, frames=frames)
    nodes, weights = interior_points(truth.mesh, n_markers, seed=seed)
    experiment = markers_to_experiment(as_recording(nodes, weights, data, noise=noise,
                                                    seed=seed),
                                       truth.mesh, forces=data.forces_per_frame()).experiment
    return experiment, steps


def test_remove_offsets_takes_out_each_rows_mean_over_its_measured_frames():
    rng = np.random.default_rng(0)
    residuals = rng.normal(size=(6, 4, 3))
    seen = rng.random((6, 4)) > 0.3
    residuals[~seen] = 0.0
    jacobian = rng.normal(size=(6, 4, 3, 2))
    projected = remove_offsets(residuals, seen, jacobian)
    assert np.allclose(projected[~seen], 0.0) and np.allclose(jacobian[~seen], 0.0)
    for row in range(4):
        frames = seen[:, row]
        if frames.any():
            assert np.allclose(projected[frames, row].sum(axis=0), 0.0)
            assert np.allclose(jacobian[frames, row].sum(axis=0), 0.0)
            assert np.allclose(projected[frames, row], residuals[frames, row]
                               - residuals[frames, row].mean(axis=0))


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_gradients_with_fitted_offsets_are_exact(backend):
    truth = element_block()
    experiment, steps = markers_from_frame_zero(truth, frames=20, n_markers=8)
    start = truth.with_elements(youngs_modulus=np.full(truth.mesh.n_tetrahedra, 8000.0),
                                poisson_ratio=np.full(truth.mesh.n_tetrahedra, 0.35))
    parameters = Parameterization(start)
    sensitivity = reference.sensitivity(parameters, 0.01, backend=backend, offsets=True)
    _, _, run = assert_gradient_exact(sensitivity, parameters.initial(), experiment, steps)
    assert np.allclose(run.residuals.sum(axis=0), 0.0, atol=1e-12)      # every row centred


def test_the_exact_model_reaches_the_noise_when_the_load_starts_at_frame_zero():
    """Copying the rest positions from frame 0 adds that frame's noise to every later one
    (a floor of √2 × the noise); fitting them reaches the noise."""
    truth = element_block((2, 2, 2))
    experiment, steps = markers_from_frame_zero(truth, frames=60, n_markers=40)
    fitted = GradientLearner(substeps=steps).fit(truth, experiment)
    copied = GradientLearner(substeps=steps, offsets=False).fit(truth, experiment)
    assert fitted.offsets_ and not copied.offsets_
    assert 0.9 < fitted.lack_of_fit_.ratio < 1.1
    assert copied.lack_of_fit_.ratio > 1.3
    assert fitted.lack_of_fit_.explained and not copied.lack_of_fit_.explained
    assert fitted.model_.elements.youngs_modulus[0] == pytest.approx(6000.0, rel=0.02)


def test_a_model_that_misses_an_effect_says_so_with_where_and_when():
    """Data with gravity, fitted without it: the verdict says the model class misses
    something and the standard errors widen with the correlated residuals."""
    truth = element_block((2, 2, 2))
    heavy = truth.with_effects(Gravity((0.0, 0.0, -9.81)))
    experiment, steps = markers_from_frame_zero(heavy, frames=60, n_markers=40)
    fitted = GradientLearner(substeps=steps).fit(truth, experiment)
    verdict = fitted.lack_of_fit_
    assert not verdict.explained and verdict.ratio > 3 * EXPLAINED
    assert "misses something" in verdict.verdict and "diagnose" in verdict.verdict
    assert verdict.where["markers"] < verdict.where["of"] and verdict.when["to"] > 0
    record_ = fitted.to_dict()["lack_of_fit"]
    assert record_["ratio"] == pytest.approx(verdict.ratio) and record_["units"].startswith("m")
    # the same fit with the effect explains the data
    with_gravity = GradientLearner(substeps=steps).fit(heavy, experiment)
    assert with_gravity.lack_of_fit_.explained


def test_standard_errors_widen_with_correlated_residuals():
    truth = element_block((2, 2, 2))
    heavy = truth.with_effects(Gravity((0.0, 0.0, -9.81)))
    experiment, steps = markers_from_frame_zero(heavy, frames=60, n_markers=40)
    exact, _ = markers_from_frame_zero(truth, frames=60, n_markers=40)
    for data, wider in ((experiment, True), (exact, False)):
        learner = GradientLearner(substeps=steps).fit(truth, data)
        parameters = Parameterization(learner.model_)
        sensitivity = Sensitivity(parameters, truth.length_unit,
                                  offsets=True)
        run = sensitivity.run(parameters.initial(), data, substeps=steps, tangents=True)
        plain = analyse(parameters, parameters.initial(), run.jacobian.reshape(-1, 3),
                        run.residuals.ravel()).std_errors
        robust = learner.std_errors_
        assert learner.identifiability_.robust
        if wider:
            assert np.all(robust > 2 * plain)
        else:
            assert np.all(robust < 1.6 * plain) and np.all(robust >= plain * (1 - 1e-9))


def test_noise_free_data_are_explained_exactly_or_say_the_model_misses():
    truth = element_block()
    data, steps = record(truth, frames=30)
    exact = GradientLearner(substeps=steps).fit(truth, data)
    assert exact.lack_of_fit_.explained and "exactly" in exact.lack_of_fit_.verdict
    heavy = truth.with_effects(Gravity((0.0, 0.0, -9.81)))
    missed = GradientLearner(substeps=steps).fit(truth, record(heavy, frames=30)[0])
    assert not missed.lack_of_fit_.explained
    assert "no measurable noise" in missed.lack_of_fit_.verdict


def test_length_text_chooses_a_unit_people_read():
    assert length_text(4.12e-5) == "41.2 µm"
    assert length_text(1.234e-3) == "1.23 mm"
    assert length_text(0.045) == "4.5 cm"
    assert length_text(2.0) == "2 m"


def test_fit_prints_saves_and_reports_its_lack_of_fit(tmp_path):
    """The command line: the verdict in the text output, the JSON and the fitted model file."""
    from neurofuzzy.io.models import load_fit_record

    data = tmp_path / "pull.npz"
    assert cli("simulate", "cube", "--force", "26", "0.1", "0", "0", "--noise", "2e-5",
               "--out", str(data)).returncode == 0
    done = cli("fit", str(data), "--tie", "groups", "--out", str(tmp_path / "fitted.yaml"))
    assert done.returncode == 0, done.stderr
    assert "lack of fit: explained to the noise" in done.stdout
    assert "RMS error per marker:" in done.stdout and "µm" in done.stdout
    record_ = load_fit_record(tmp_path / "fitted.yaml")
    assert record_["lack_of_fit"]["explained"] and record_["neurofuzzy_version"]
    as_json = json.loads(cli("fit", str(data), "--tie", "groups", "--json").stdout)
    assert set(as_json["lack_of_fit"]) >= {"rms", "noise", "ratio", "verdict", "units"}
    assert as_json["lack_of_fit"]["rms"] == pytest.approx(as_json["rms_error"])
