import numpy as np
import pytest

from neurofuzzy.datasets import (CUBE, paper_cube_experiment, paper_cube_model, point_load,
                                 top_centre_node)
from neurofuzzy.learn import GradientLearner, auto_substeps
from neurofuzzy.learn import Parameterization, Sensitivity
from neurofuzzy.validation.integrators import reference_experiment


def _perturbed(rng):
    truth = paper_cube_model()
    return truth.with_springs(stiffness=truth.springs.stiffness * rng.uniform(0.7, 1.4, 86),
                              damping=truth.springs.damping * rng.uniform(0.7, 1.4, 86)
                              ).replace(node_mass=truth.node_mass * rng.uniform(0.8, 1.2, 27))


@pytest.mark.parametrize("substeps, starts", [(1, (0,)), (3, (0, 90, 180))])
def test_adjoint_gradient_matches_central_differences(rng, cube_experiment, substeps, starts):
    """Directional derivatives along random directions through all 190 parameters."""
    parameters = Parameterization(_perturbed(rng), learn_masses=True)
    sensitivity = Sensitivity(parameters, CUBE["edge_length"])
    theta = parameters.initial()
    loss, gradient, _ = sensitivity.gradient(theta, cube_experiment, substeps=substeps,
                                             starts=starts)
    assert loss > 0
    step = 1e-5
    for direction in rng.normal(size=(3, theta.size)):
        direction /= np.linalg.norm(direction)
        plus = sensitivity.gradient(theta + step * direction, cube_experiment,
                                    substeps=substeps, starts=starts)[0]
        minus = sensitivity.gradient(theta - step * direction, cube_experiment,
                                     substeps=substeps, starts=starts)[0]
        numeric = (plus - minus) / (2 * step)
        assert abs(gradient @ direction - numeric) < 1e-6 * abs(numeric)


@pytest.mark.slow      # the fast suite checks random directions through all parameters
def test_adjoint_gradient_matches_central_differences_per_parameter(cube_experiment):
    start = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 40.0}, damping=0.03,
                             total_mass=0.01, tie="groups")
    parameters = Parameterization(start, learn_masses=True)
    sensitivity = Sensitivity(parameters, CUBE["edge_length"])
    theta = parameters.initial()
    _, gradient, _ = sensitivity.gradient(theta, cube_experiment)
    numeric = np.zeros_like(theta)
    for i in range(theta.size):
        e = np.zeros_like(theta)
        e[i] = 1e-5
        numeric[i] = (sensitivity.gradient(theta + e, cube_experiment)[0]
                      - sensitivity.gradient(theta - e, cube_experiment)[0]) / 2e-5
    assert np.linalg.norm(gradient - numeric) < 1e-6 * np.linalg.norm(gradient)


def test_forward_jacobian_agrees_with_the_adjoint(rng, cube_experiment):
    parameters = Parameterization(_perturbed(rng), learn_masses=True)
    sensitivity = Sensitivity(parameters, CUBE["edge_length"])
    theta = parameters.initial()
    run = sensitivity.run(theta, cube_experiment, substeps=2, starts=(0, 100), tangents=True)
    _, gradient, _ = sensitivity.gradient(theta, cube_experiment, substeps=2, starts=(0, 100))
    jacobian = run.jacobian.reshape(-1, theta.size)
    assert np.allclose(jacobian.T @ run.residuals.ravel(), gradient, rtol=1e-10,
                       atol=1e-12 * np.abs(gradient).max())


@pytest.mark.slow
def test_every_identifiable_spring_and_mass_from_one_load_case(rng, cube_experiment):
    start = _perturbed(rng)
    learner = GradientLearner(learn_masses=True).fit(start, cube_experiment)
    truth = paper_cube_model()
    fitted = learner.model_
    reported = learner.identifiability_.unidentifiable
    unidentifiable = {s for entry in reported for s in entry["springs"]}
    both_fixed = set(np.flatnonzero(~truth.mesh.free[truth.mesh.springs].any(axis=1)))
    assert both_fixed <= unidentifiable
    # they keep their start values instead of wandering off
    both = sorted(both_fixed)
    assert np.allclose(fitted.springs.stiffness[both], start.springs.stiffness[both], rtol=1e-12)
    known = np.setdiff1d(np.arange(86), sorted(unidentifiable))
    assert len(known) >= 60
    assert np.allclose(fitted.springs.stiffness[known], truth.springs.stiffness[known], rtol=1e-6)
    assert np.allclose(fitted.springs.damping[known], truth.springs.damping[known], rtol=1e-6)
    free = truth.mesh.free
    assert np.allclose(fitted.node_mass[free], truth.node_mass[free], rtol=1e-6)
    assert learner.rms_error_ < 1e-9 * CUBE["edge_length"]


def test_tied_fit_reports_standard_errors(cube_experiment):
    noisy = paper_cube_experiment(paper_cube_model(), noise=2e-5, seed=1)
    start = paper_cube_model(stiffness=70.0, damping=0.03, tie="groups")
    learner = GradientLearner().fit(start, noisy)
    assert learner.parameter_names_ == ["stiffness[edge]", "stiffness[diagonal]",
                                        "damping[edge]", "damping[diagonal]"]
    errors = learner.std_errors_
    assert np.all(np.isfinite(errors)) and np.all(errors > 0)
    fitted = learner.model_.group_values(learner.model_.springs.stiffness)
    # the truth lies within a few standard errors (relative, since parameters are logs)
    assert abs(np.log(fitted["edge"] / 50.0)) < 5 * errors[0] + 1e-3
    assert abs(np.log(fitted["diagonal"] / 50.0)) < 5 * errors[1] + 1e-3


@pytest.mark.slow
def test_groups_recovered_within_two_percent_from_a_different_integrator():
    truth = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0}, damping=0.02)
    loads = point_load(truth.mesh, top_centre_node(truth.mesh), CUBE["force"])
    data = reference_experiment(truth, dt=CUBE["dt"], n_frames=251, external_forces=loads,
                                method="rk4", substeps=10)
    start = paper_cube_model(stiffness=45.0, damping=0.03, tie="groups")
    learner = GradientLearner(substeps="auto").fit(start, data)
    fitted = learner.model_
    stiffness = fitted.group_values(fitted.springs.stiffness)
    damping = fitted.group_values(fitted.springs.damping)
    assert stiffness["edge"] == pytest.approx(60.0, rel=0.02)
    assert stiffness["diagonal"] == pytest.approx(35.0, rel=0.02)
    assert damping["edge"] == pytest.approx(0.02, rel=0.02)
    assert damping["diagonal"] == pytest.approx(0.02, rel=0.02)
    assert learner.extrapolated_ and learner.substeps_ == 2 * auto_substeps(start, CUBE["dt"])


def test_auto_substeps_keeps_one_step_for_our_own_data(cube_experiment):
    start = paper_cube_model(stiffness=55.0, damping=0.025, tie="global")
    learner = GradientLearner(substeps="auto").fit(start, cube_experiment)
    assert learner.substeps_ == 1 and not learner.extrapolated_
    assert learner.model_.springs.stiffness[0] == pytest.approx(50.0, rel=1e-9)


@pytest.mark.slow
def test_every_spring_from_two_load_cases_of_rk4_data():
    from neurofuzzy.datasets import per_spring_cube

    base, truth, data = per_spring_cube(seed=0)
    learner = GradientLearner(substeps="auto").fit(base, data)
    moving = base.mesh.free[base.mesh.springs].any(axis=1)
    fitted = learner.model_
    assert np.median(np.abs(fitted.springs.stiffness / truth.springs.stiffness - 1)[moving]) < 0.01
    assert np.median(np.abs(fitted.springs.damping / truth.springs.damping - 1)[moving]) < 0.01


@pytest.mark.parametrize("method", ["lm", "lbfgs"])
def test_the_error_curve_has_one_point_per_cycle(tmp_path, cube_experiment, method):
    """The report's 'in N cycles' and its error curve count the same thing: every simulation
    of the data, Jacobian passes included (the demo's 15 cycles had 8 points)."""
    import json
    import re

    from neurofuzzy.learn import StartModel
    from neurofuzzy.pipeline import FitOutcome
    from neurofuzzy.report import fit_report

    start = paper_cube_model(stiffness=70.0, damping=0.03, tie="groups")
    learner = GradientLearner(method=method).fit(start, cube_experiment)
    assert learner.n_cycles_ > 2 and len(learner.history_) == learner.n_cycles_
    assert np.all(np.diff(learner.history_) <= 0)              # best so far
    outcome = FitOutcome(model=learner.model_, learner=learner,
                         start=StartModel(start, "model", "given"), prior=None,
                         experiments=[cube_experiment], summary={}, record={})
    report = fit_report(outcome, tmp_path / "fit.html")
    cycles = int(re.search(r"in (\d+) cycles", report.read_text())[1])
    twin = json.loads(report.with_suffix(".json").read_text())
    assert cycles == learner.n_cycles_ == twin["cycles"] == len(twin["history"])


def test_a_window_starts_from_the_velocity_the_substeps_reached():
    """At one substep a frame the backward difference of the measured positions is the
    network's velocity exactly; at more it is the frame's mean velocity, half a frame late,
    and the window starts from the central difference instead, nearer the true one."""
    from neurofuzzy.simulation import simulate

    truth = paper_cube_model()
    sensitivity = Sensitivity(Parameterization(truth), CUBE["edge_length"])
    loads = point_load(truth.mesh, top_centre_node(truth.mesh), CUBE["force"])
    for substeps in (1, 4):
        data = paper_cube_experiment(truth, n_frames=60, substeps=substeps)
        run = simulate(truth, dt=data.dt, n_frames=60, external_forces=loads,
                       substeps=substeps)
        assert np.allclose(run.positions, data.positions, rtol=0, atol=1e-15)
        p, v = sensitivity._window_state(data, 30, substeps)
        assert np.array_equal(p, data.positions[30])
        backward = (data.positions[30] - data.positions[29]) / data.dt
        if substeps == 1:
            assert np.allclose(v, run.velocities[30], rtol=0, atol=1e-12)
            assert np.array_equal(v, backward)
            continue
        assert np.array_equal(v, (data.positions[31] - data.positions[29]) / (2 * data.dt))
        assert np.abs(run.velocities[30]).max() > 0
        assert (np.abs(v - run.velocities[30]).max()
                < 0.5 * np.abs(backward - run.velocities[30]).max())
