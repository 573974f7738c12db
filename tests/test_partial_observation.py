"""Partial observation: only surface markers, and markers with gaps (occlusions, dropped frames).

The paper's cube seen from its 26 surface nodes only (the centre node 13 has no marker), as an
optical system would see it; both learners must still recover the constants.
"""

import numpy as np
import pytest

from neurofuzzy.datasets import CUBE, paper_cube_experiment, paper_cube_model
from neurofuzzy.diagnosis import diagnose
from neurofuzzy.errors import InputError
from neurofuzzy.experiment import rms_error
from neurofuzzy.learn import GradientLearner, PaperLearner
from neurofuzzy.learn import Parameterization, Sensitivity
from neurofuzzy.simulation import simulate

CENTRE = 13


def _surface_only(experiment):
    observed = np.ones(experiment.n_nodes, bool)
    observed[CENTRE] = False
    positions = np.where(observed[None, :, None], experiment.positions, np.nan)
    return experiment.replace(observed=observed, positions=positions)


def _with_gaps(experiment, fraction, seed=3):
    """Drop a fraction of (frame, node) measurements after frame 0, and two whole frames."""
    rng = np.random.default_rng(seed)
    gaps = rng.random(experiment.positions.shape[:2]) < fraction
    gaps[0] = False
    gaps[[40, 41]] = True                      # dropped frames
    return experiment.replace(positions=np.where(gaps[:, :, None], np.nan, experiment.positions))


def test_the_surface_of_the_cube_is_26_nodes(cube_experiment):
    surface = _surface_only(cube_experiment)
    assert surface.observed.sum() == 26
    assert surface.measured().shape == (251, 27)
    assert not surface.complete


def test_gradient_learner_fits_the_cube_from_its_26_surface_nodes(cube_experiment):
    data = _surface_only(cube_experiment)
    start = paper_cube_model(stiffness={"edge": 70.0, "diagonal": 35.0}, damping=0.03,
                             tie="groups")
    learner = GradientLearner().fit(start, data)
    fitted = learner.model_
    for values in (fitted.group_values(fitted.springs.stiffness),):
        assert values["edge"] == pytest.approx(CUBE["stiffness"], rel=1e-6)
        assert values["diagonal"] == pytest.approx(CUBE["stiffness"], rel=1e-6)
    damping = fitted.group_values(fitted.springs.damping)
    assert damping["edge"] == pytest.approx(CUBE["damping"], rel=1e-6)
    # windows need every free node measured: the surface-only fit runs on the whole trajectory
    assert learner.rms_error_ < 1e-9 * CUBE["edge_length"]


def test_paper_learner_fits_the_cube_from_its_surface_with_gaps(cube_experiment):
    data = _with_gaps(_surface_only(cube_experiment), 0.1)
    start = paper_cube_model(stiffness=1.3 * CUBE["stiffness"], damping=1.3 * CUBE["damping"],
                             tie="global")
    learner = PaperLearner(learning_rate=0.1, cycles=60).fit(start, data)
    assert learner.model_.springs.stiffness[0] == pytest.approx(CUBE["stiffness"], rel=5e-3)
    assert learner.rms_error_ < 0.01 * learner.rms_error_initial_


def test_gaps_carry_no_residual_and_are_not_interpolated(cube_model, cube_experiment):
    data = _with_gaps(cube_experiment, 0.2)
    seen = data.tracked_frames()
    assert 0.7 < seen[1:, data.tracked()].mean() < 0.85
    # the true model explains every measured value exactly: the gaps add nothing
    assert rms_error(cube_model, data) < 1e-15
    # the same RMS as the complete data at a wrong model, over the measured values only
    wrong = cube_model.with_springs(stiffness=1.2 * cube_model.springs.stiffness)
    simulated = simulate(wrong, dt=data.dt, n_frames=data.n_frames,
                         external_forces=data.external_forces).positions
    diff = (simulated - cube_experiment.positions)[1:][seen[1:]]
    assert rms_error(wrong, data) == pytest.approx(np.sqrt(np.mean(np.sum(diff**2, -1))),
                                                   rel=1e-12)


def test_adjoint_gradient_with_gaps_matches_central_differences(rng, cube_experiment):
    data = _with_gaps(_surface_only(cube_experiment), 0.15)
    start = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 40.0}, damping=0.03,
                             tie="groups")
    parameters = Parameterization(start, learn_masses=True)
    sensitivity = Sensitivity(parameters, CUBE["edge_length"])
    theta = parameters.initial()
    loss, gradient, run = sensitivity.gradient(theta, data)
    assert np.isfinite(loss) and run.n_measured == 3 * int(data.tracked_frames()[1:].sum())
    forward = sensitivity.run(theta, data, tangents=True)
    jacobian = forward.jacobian.reshape(-1, theta.size)
    assert np.allclose(jacobian.T @ forward.residuals.ravel(), gradient, rtol=1e-9,
                       atol=1e-12 * np.abs(gradient).max())
    direction = rng.normal(size=theta.size)
    step = 1e-5
    numeric = (sensitivity.gradient(theta + step * direction, data)[0]
               - sensitivity.gradient(theta - step * direction, data)[0]) / (2 * step)
    assert gradient @ direction == pytest.approx(numeric, rel=1e-6)


def test_gradient_learner_with_gaps_recovers_the_constants(cube_experiment):
    data = _with_gaps(cube_experiment, 0.1)
    start = paper_cube_model(stiffness=65.0, damping=0.03, tie="global")
    learner = GradientLearner().fit(start, data)
    assert learner.model_.springs.stiffness[0] == pytest.approx(CUBE["stiffness"], rel=1e-6)
    assert learner.model_.springs.damping[0] == pytest.approx(CUBE["damping"], rel=1e-6)


@pytest.mark.slow
def test_diagnosis_uses_nodes_without_gaps(cube_model):
    from neurofuzzy.effects import Gravity

    truth = cube_model.with_effects(Gravity([0.0, 0.0, -9.81]))
    data = _surface_only(paper_cube_experiment(truth))
    rng = np.random.default_rng(0)
    gappy = rng.choice(np.flatnonzero(data.tracked()), size=4, replace=False)
    positions = data.positions.copy()
    positions[100:110, gappy] = np.nan
    data = data.replace(positions=positions)
    found = diagnose(cube_model.tied("groups"), data, max_effects=1)
    assert [finding.name for finding in found.effects] == ["gravity"]

    everywhere = data.positions.copy()
    everywhere[7, data.observed] = np.nan
    everywhere[7, cube_model.mesh.fixed] = data.positions[7, cube_model.mesh.fixed]
    with pytest.raises(InputError, match="measured at every frame"):
        diagnose(cube_model.tied("groups"), data.replace(positions=everywhere))


def test_an_observed_node_needs_its_initial_position(cube_experiment):
    positions = cube_experiment.positions.copy()
    positions[0, 5] = np.nan
    with pytest.raises(InputError, match="node 5 is marked observed but has no position at "
                                         "frame 0"):
        cube_experiment.replace(positions=positions)


def test_without_complete_data_the_stages_fit_growing_beginnings(cube_experiment, capsys):
    """No measured state to restart windows from: fit the first 25, 50, 100, 200 frames, then
    all; from a start 4x off the constants are recovered, as from the whole run alone."""
    data = _surface_only(cube_experiment)
    start = paper_cube_model(stiffness=200.0, damping=0.08, tie="global")
    staged = GradientLearner(progress=True).fit(start, data)
    err = capsys.readouterr().err
    assert "1/5 first 25 frames" in err and "5/5 window 251 frames" in err
    whole = GradientLearner(windows=()).fit(start, data)
    for learner in (staged, whole):
        assert learner.model_.springs.stiffness[0] == pytest.approx(CUBE["stiffness"], rel=1e-9)
        assert learner.model_.springs.damping[0] == pytest.approx(CUBE["damping"], rel=1e-9)
