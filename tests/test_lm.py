"""Levenberg–Marquardt (:mod:`neurofuzzy.learn._lm`) with the trial steps' Jacobian taken from
the same pass as their residuals (``both``): the same steps, fewer passes; and in the
gradient learner, the Jacobian at the result reused for the standard errors, or the one a
statistically empty last step behind it (``jacobian_at_end="near"``)."""

import numpy as np
import pytest

from neurofuzzy.learn import _lm

TIMES = np.linspace(0.0, 4.0, 40)


def _problem(noise: float):
    """Residuals and Jacobian of a damped oscillation ``a e^{-bt} cos(ct)`` against data made
    with ``(2, 0.5, 3)`` (plus seeded noise), with counters of the passes."""
    rng = np.random.default_rng(7)
    data = 2.0 * np.exp(-0.5 * TIMES) * np.cos(3.0 * TIMES) + noise * rng.standard_normal(40)
    calls = {"residuals": 0, "jacobian": 0, "both": 0}

    def model(x):
        a, b, c = x
        decay, wave = np.exp(-b * TIMES), np.cos(c * TIMES)
        jac = np.column_stack([decay * wave, -a * TIMES * decay * wave,
                               -a * TIMES * decay * np.sin(c * TIMES)])
        return a * decay * wave - data, jac

    def residuals(x):
        calls["residuals"] += 1
        return model(x)[0]

    def jacobian(x):
        calls["jacobian"] += 1
        return model(x)[1]

    def both(x):
        calls["both"] += 1
        return model(x)

    return residuals, jacobian, both, calls


@pytest.mark.parametrize("noise", [0.0, 0.05])
@pytest.mark.parametrize("start", [(1.5, 0.4, 2.8), (4.0, 2.0, 2.2)])
def test_the_same_steps_with_the_jacobian_taken_along(noise, start):
    """Near start (every step accepted) and far (rejected trials): ``both`` changes which
    passes run, never the iterate, the cost or the stop; it saves passes near the solution."""
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    runs = {}
    for name in ("apart", "together"):
        residuals, jacobian, both, calls = _problem(noise)
        solution = _lm.levenberg_marquardt(
            residuals, jacobian, np.array(start), lower, upper, max_evaluations=100,
            tolerance=1e-10, both=both if name == "together" else None)
        runs[name] = (solution, calls)
    (apart, separate), (together, combined) = runs["apart"], runs["together"]
    assert np.array_equal(apart.x, together.x)
    assert apart.cost == together.cost and apart.reason == together.reason
    assert apart.evaluations == together.evaluations
    assert separate["both"] == 0 and combined["both"] > 0
    passes = (sum(separate.values()), sum(combined.values()))
    if start == (1.5, 0.4, 2.8):
        assert np.allclose(together.x, [2.0, 0.5, 3.0], atol=0.05)
        assert passes[1] < passes[0]


def test_the_first_trial_is_not_taken_with_its_jacobian_when_it_should_end_the_fit():
    """At the solution the predicted decrease is below the tolerance: the trial is evaluated
    by its residuals only (its Jacobian would go unused)."""
    residuals, jacobian, both, calls = _problem(0.05)
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    solved = _lm.levenberg_marquardt(residuals, jacobian, np.array([1.5, 0.4, 2.8]), lower,
                                     upper, max_evaluations=100, tolerance=1e-10)
    residuals, jacobian, both, calls = _problem(0.05)
    again = _lm.levenberg_marquardt(residuals, jacobian, solved.x, lower, upper,
                                    max_evaluations=100, tolerance=1e-3, both=both)
    assert again.reason == "converged"
    assert calls == {"residuals": 1, "jacobian": 0, "both": 1}


@pytest.mark.parametrize("at_end", [True, False])
def test_a_stage_before_the_last_takes_a_step_that_ends_it_without_its_jacobian(at_end):
    """Exact data, a start 1e-4 off: the first step is short enough to end the fit, and it
    lowers the cost by nearly all of it. A stage before the last (``jacobian_at_end``
    False), whose Jacobian at the result goes unused, takes it by its residuals alone; the
    last stage takes it with its Jacobian, which the standard errors then use. The same
    step either way."""
    residuals, jacobian, both, calls = _problem(0.0)
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    solution = _lm.levenberg_marquardt(residuals, jacobian, np.array([2.0, 0.5, 3.0]) + 1e-4,
                                       lower, upper, max_evaluations=100, tolerance=1e-3,
                                       both=both, jacobian_at_end=at_end)
    assert solution.reason == "converged" and solution.evaluations == 2
    assert np.allclose(solution.x, [2.0, 0.5, 3.0], atol=1e-6)
    if at_end:
        assert calls == {"residuals": 0, "jacobian": 0, "both": 2}
    else:
        assert calls == {"residuals": 1, "jacobian": 0, "both": 1}
    again = _lm.levenberg_marquardt(*_problem(0.0)[:2], np.array([2.0, 0.5, 3.0]) + 1e-4,
                                    lower, upper, max_evaluations=100, tolerance=1e-3)
    assert np.array_equal(again.x, solution.x) and again.cost == solution.cost


@pytest.mark.parametrize("start", [(1.5, 0.4, 2.8), (4.0, 2.0, 2.2)])
def test_a_last_step_that_is_statistically_nothing_is_taken_without_its_jacobian(start):
    """Noisy data end on a step below a tenth of the standard errors. Asked for a Jacobian
    near the result (``"near"``), the solver takes that step by its residuals alone and says
    so (``jacobian_behind``): the same steps and stop, one Jacobian fewer, and the standard
    errors of the Jacobian one step behind are those at the result to 1e-3."""
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    fits = {}
    for at_end in (True, "near"):
        residuals, jacobian, both, calls = _problem(0.05)
        taken = []              # where the solver took its Jacobians

        def both_kept(x, both=both, taken=taken):
            taken.append(x.copy())
            return both(x)

        solution = _lm.levenberg_marquardt(
            residuals, jacobian, np.array(start), lower, upper, max_evaluations=100,
            tolerance=1e-10, both=both_kept, jacobian_at_end=at_end)
        fits[at_end] = (solution, calls, taken)
    (exact, exact_calls, _), (near, near_calls, taken) = fits[True], fits["near"]
    assert exact.reason == near.reason == "step below the standard errors"
    assert np.array_equal(exact.x, near.x) and exact.cost == near.cost
    assert near.jacobian_behind and not exact.jacobian_behind
    assert near_calls["both"] == exact_calls["both"] - 1 and near_calls["residuals"] == 1
    assert not np.array_equal(taken[-1], near.x)

    def std_errors(x):
        J = _problem(0.05)[1](x)
        return np.sqrt(np.diag(np.linalg.inv(J.T @ J)))

    assert np.allclose(std_errors(taken[-1]), std_errors(near.x), rtol=1e-3, atol=0)


def test_a_step_wrongly_predicted_to_be_nothing_is_followed_by_its_jacobian(monkeypatch):
    """A step predicted to be statistically nothing is taken by its residuals alone; when its
    cost says otherwise, the fit goes on from there with the Jacobian taken at that point:
    the same steps, stop and result as a fit that never predicted (here the first prediction
    is made to be wrong, from the far start)."""
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    start = np.array([4.0, 2.0, 2.2])
    residuals, jacobian, both, _ = _problem(0.05)
    exact = _lm.levenberg_marquardt(residuals, jacobian, start, lower, upper,
                                    max_evaluations=100, tolerance=1e-10, both=both)
    real, said = _lm._nothing, []

    def first_said_wrongly(*args):
        said.append(real(*args))
        return len(said) == 1 or said[-1]

    monkeypatch.setattr(_lm, "_nothing", first_said_wrongly)
    residuals, jacobian, both, calls = _problem(0.05)
    near = _lm.levenberg_marquardt(residuals, jacobian, start, lower, upper,
                                   max_evaluations=100, tolerance=1e-10, both=both,
                                   jacobian_at_end="near")
    assert not said[0]                  # the far start's first step is not nothing
    assert calls["jacobian"] == 1 and calls["residuals"] >= 2
    assert np.array_equal(near.x, exact.x) and near.cost == exact.cost
    assert near.reason == exact.reason and near.jacobian_behind


def test_the_learner_reuses_the_jacobian_at_its_result(monkeypatch):
    """A per-region element fit: with the trial steps' Jacobians, the same model, standard
    errors and lack of fit from fewer simulations of the data (the standard errors take the
    last Jacobian instead of one more pass). The same to round-off: a trial step without its
    Jacobian is a run of the stepper's driver, whose St. Venant–Kirchhoff loop adds the
    volumetric stresses in another order than the sensitivities' (3e-16 of E here)."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn import GradientLearner, _solvers
    from neurofuzzy.learn.steps import auto_substeps
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((3, 3, 3), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)

    def model(modulus, ratio, viscosity):
        return Model.continuum(mesh, youngs_modulus=modulus, poisson_ratio=ratio,
                               viscosity=viscosity, density=1050.0)

    truth = model(6000.0, 0.45, 2.0)
    load = np.zeros((mesh.n_nodes, 3))
    load[mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9] = [0.0, 0.0, -0.01]
    steps = auto_substeps(truth, 1e-3)
    data = simulate_experiment(truth, dt=1e-3, n_frames=30, external_forces=load,
                               substeps=steps)
    fits = {}
    for cost in (0, _solvers.SPECULATE_COST):          # 0: never with the trial steps
        monkeypatch.setattr(_solvers, "SPECULATE_COST", cost)
        fits[cost] = GradientLearner(substeps=steps).fit(model(4000.0, 0.4, 3.0), data)
    apart, together = fits[0], fits[_solvers.SPECULATE_COST]
    assert together.model_.elements.youngs_modulus[0] == pytest.approx(6000.0, rel=1e-6)
    for name in ("youngs_modulus", "poisson_ratio", "viscosity"):
        assert np.allclose(getattr(apart.model_.elements, name),
                           getattr(together.model_.elements, name),
                           rtol=1e-12, atol=0)
    assert np.allclose(apart.std_errors_, together.std_errors_, rtol=1e-9)
    assert apart.rms_error_ == pytest.approx(together.rms_error_, rel=1e-12)
    assert together.n_cycles_ < apart.n_cycles_
    assert len(together.history_) == together.n_cycles_
    assert together._last is None          # the last Jacobian is not kept with the result


def _noisy_block():
    """``(model(E, η), data)``: a 3³ Kuhn block at ν 0.45 pressed at its top for 30 frames
    of 1 ms at 4 substeps, with 2 µm of seeded noise (E 6 kPa, η 2 Pa·s)."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((3, 3, 3), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)

    def model(modulus, viscosity):
        return Model.continuum(mesh, youngs_modulus=modulus, poisson_ratio=0.45,
                               viscosity=viscosity, density=1050.0)

    load = np.zeros((mesh.n_nodes, 3))
    load[mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9] = [0.0, 0.0, -0.01]
    data = simulate_experiment(model(6000.0, 2.0), dt=1e-3, n_frames=30, external_forces=load,
                               substeps=4, noise=2e-6, seed=5)
    return model, data


def test_the_learner_takes_its_standard_errors_one_nothing_step_behind(monkeypatch):
    """A per-region element fit of noisy data ends on a step that is statistically nothing:
    taken by its residuals, one Jacobian pass fewer than with the Jacobian at the result,
    the same model, and the same standard errors to 1e-3 (from the Jacobian one step
    behind). The lack of fit is that of the residuals at the result."""
    from neurofuzzy.learn import GradientLearner, _passes, _solvers

    model, data = _noisy_block()
    counted, solver = [], _solvers.levenberg_marquardt
    jacobian_pass = _passes.jacobian
    monkeypatch.setattr(_passes, "jacobian",
                        lambda *a, **k: counted.append(1) or jacobian_pass(*a, **k))
    fits = {}
    for at_end in ("near", True):
        def solve(*args, jacobian_at_end, at_end=at_end, **kwargs):
            wanted = at_end if jacobian_at_end == "near" else jacobian_at_end
            return solver(*args, jacobian_at_end=wanted, **kwargs)

        monkeypatch.setattr(_solvers, "levenberg_marquardt", solve)
        counted.clear()
        fits[at_end] = (GradientLearner(substeps=4, mesh_check=False).fit(
            model(3000.0, 4.0), data), len(counted))
    (near, near_passes), (exact, exact_passes) = fits["near"], fits[True]
    assert near_passes == exact_passes - 1
    for name in ("youngs_modulus", "poisson_ratio", "viscosity"):
        assert np.array_equal(getattr(near.model_.elements, name),
                              getattr(exact.model_.elements, name))
    assert np.allclose(near.std_errors_, exact.std_errors_, rtol=1e-3, atol=0)
    assert not np.array_equal(near.std_errors_, exact.std_errors_)
    # the residuals at the result from the stepper's driver against the sensitivities' run:
    # the same to round-off (they add the volumetric stresses in other orders)
    assert near.lack_of_fit_.rms == pytest.approx(exact.lack_of_fit_.rms, rel=1e-12)


def test_the_floor_is_the_least_cost_of_a_linear_problem():
    """For residuals linear in x, Gauss–Newton's floor at any point is the least-squares
    minimum (numpy's lstsq), whichever point it is computed at."""
    rng = np.random.default_rng(3)
    A, b = rng.standard_normal((30, 4)), rng.standard_normal(30)
    least = 0.5 * float(np.sum((A @ np.linalg.lstsq(A, b, rcond=None)[0] - b) ** 2))
    for x in (np.zeros(4), rng.standard_normal(4) * 10):
        r = A @ x - b
        assert _lm.floor(A.T @ A, A.T @ r, 0.5 * float(r @ r)) == pytest.approx(least,
                                                                                 rel=1e-9)


@pytest.mark.parametrize("target", ["below", "above"])
def test_a_fit_that_cannot_beat_the_target_gives_up(target):
    """Asked to give up once the floor is above a target: with the target below the noisy
    problem's minimum the fit stops early ("given up", fewer passes); with it above, the fit
    is the one without the question, step for step. From this far start the first floors
    promise far too little (39, 7 and 3 times the least cost): they are not asked about."""
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    residuals, jacobian, _, calls = _problem(0.05)
    free = _lm.levenberg_marquardt(residuals, jacobian, np.array([4.0, 2.0, 2.2]), lower,
                                   upper, max_evaluations=100, tolerance=1e-10)
    threshold = free.cost * (0.5 if target == "below" else 2.0)
    asked = []
    residuals, jacobian, _, calls = _problem(0.05)
    solution = _lm.levenberg_marquardt(
        residuals, jacobian, np.array([4.0, 2.0, 2.2]), lower, upper, max_evaluations=100,
        tolerance=1e-10, give_up=lambda least: asked.append(least) or least > threshold)
    if target == "below":
        assert solution.reason == "given up" and solution.evaluations < free.evaluations
        assert asked[-1] > threshold and solution.cost > free.cost
    else:
        assert solution.reason == free.reason and np.array_equal(solution.x, free.x)
        # the floors asked about are the least cost within 1 %
        assert np.allclose(asked, free.cost, rtol=0.01) and len(asked) >= 2


@pytest.mark.parametrize("target", [0.8, 1.2])
def test_floors_that_agree_far_from_the_minimum_are_asked_about(target):
    """Rosenbrock's valley with a residual no parameter moves (0.01, the least cost): Gauss–
    Newton's floor is the least cost at every point, far below the cost for most of the way
    down the valley. Agreeing floors are asked about from the second Jacobian on: with a
    target below the least cost the fit gives up there; with one above, it is the fit
    without the question, step for step (targets as multiples of the least cost)."""
    least = 0.5e-4
    def residuals(x):
        return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0], 0.01])

    def jacobian(x):
        return np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0], [0.0, 0.0]])

    start, box = np.array([-1.2, 1.0]), (np.full(2, -np.inf), np.full(2, np.inf))
    free = _lm.levenberg_marquardt(residuals, jacobian, start, *box, max_evaluations=200,
                                   tolerance=1e-12)
    assert free.cost == pytest.approx(least, rel=1e-4) and free.evaluations > 5
    asked = []
    solution = _lm.levenberg_marquardt(
        residuals, jacobian, start, *box, max_evaluations=200, tolerance=1e-12,
        give_up=lambda floor: asked.append(floor) or floor > target * least)
    assert np.allclose(asked, least, rtol=1e-6)
    if target < 1:
        assert solution.reason == "given up" and len(asked) == 1
        assert solution.evaluations <= 3 and solution.cost > 10 * free.cost
    else:
        assert solution.reason == free.reason and np.array_equal(solution.x, free.x)
        assert len(asked) >= 3


def test_the_learner_abandons_a_fit_that_cannot_come_below_the_leader():
    """An element fit of noisy data: asked to beat half the noise, it gives up after two
    Jacobians (``abandoned_``) with fewer simulations than the whole fit; asked to beat
    twice the RMS it reaches, it is the whole fit."""
    from neurofuzzy.learn import GradientLearner

    model, data = _noisy_block()
    whole = GradientLearner(substeps=4).fit(model(3000.0, 4.0), data)
    assert not whole.abandoned_
    given_up = GradientLearner(substeps=4, abandon_above=0.5 * whole.rms_error_).fit(
        model(3000.0, 4.0), data)
    assert given_up.abandoned_ and given_up.n_cycles_ < whole.n_cycles_
    assert given_up.rms_error_ > whole.rms_error_
    kept = GradientLearner(substeps=4, abandon_above=2.0 * whole.rms_error_).fit(
        model(3000.0, 4.0), data)
    assert not kept.abandoned_ and kept.n_cycles_ == whole.n_cycles_
    assert kept.rms_error_ == whole.rms_error_


def test_a_fit_ends_where_it_leaves_the_range_it_can_be_trusted_in():
    """``leave`` is asked at every Jacobian: the first point it refuses ends the fit there
    (the learner then goes on at finer steps), before any further evaluation."""
    residuals, jacobian, _, calls = _problem(0.05)
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    asked = []
    solution = _lm.levenberg_marquardt(
        residuals, jacobian, np.array([1.5, 0.4, 2.8]), lower, upper, max_evaluations=100,
        tolerance=1e-10, leave=lambda x: asked.append(x.copy()) or len(asked) == 3)
    assert solution.reason == "left the trusted range" and len(asked) == 3
    assert np.array_equal(solution.x, asked[-1]) and calls["jacobian"] == 3


def test_a_model_that_misses_stops_at_its_robust_standard_errors():
    """An exponential and a line fitted to a curve they cannot follow: the residuals are
    smooth, correlated from one time to the next, so the data hold far less than their
    number says. Given the
    clusters' sandwich (``meat``), the fit stops once its steps are a tenth of the robust
    standard errors: sooner than on the plain ones, at the same cost within 1e-4."""
    from neurofuzzy.learn.identifiability import cluster_meat

    t = np.linspace(0.0, 1.0, 1200)
    curve = np.sin(3.0 * t) + 0.2 * t**3
    shapes = [(40, 10)]                     # 40 frames of 10 "markers", 3 coordinates

    def residuals(x):
        return x[0] * np.exp(x[1] * t) + x[2] * t - curve

    def jacobian(x):
        return np.column_stack([np.exp(x[1] * t), x[0] * t * np.exp(x[1] * t), t])

    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    start = np.array([1.0, -1.0, 0.5])
    plain = _lm.levenberg_marquardt(residuals, jacobian, start, lower, upper,
                                    max_evaluations=500, tolerance=1e-14)
    robust = _lm.levenberg_marquardt(residuals, jacobian, start, lower, upper,
                                     max_evaluations=500, tolerance=1e-14,
                                     meat=lambda J, r: cluster_meat(J, r, shapes))
    assert robust.reason == "step below the standard errors"
    assert robust.evaluations < plain.evaluations
    assert robust.cost == pytest.approx(plain.cost, rel=1e-4)


def test_a_diverged_trial_s_jacobian_pass_stops_where_the_state_diverges():
    """A trial step too far (E 10⁴ times the data's, at the data's substeps) diverges: the run
    with tangents ends where the state's run does (the same frames NaN) and leaves the
    Jacobian's later frames zero, instead of carrying NaN tangents to the last frame; a
    stable run's Jacobian is finite throughout."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn import Parameterization, Sensitivity
    from neurofuzzy.learn.steps import auto_substeps
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((3, 3, 3), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=2.0,
                            density=1050.0)
    load = np.zeros((mesh.n_nodes, 3))
    load[mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9] = [0, 0, -0.01]
    steps = auto_substeps(truth, 1e-3)
    data = simulate_experiment(truth, dt=1e-3, n_frames=30, external_forces=load,
                               substeps=steps)
    parameters = Parameterization(truth)
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial()
    stable = sensitivity.run(theta, data, substeps=steps, tangents=True, threads=2)
    assert stable.finite and np.all(np.isfinite(stable.jacobian))
    far = theta.copy()
    far[parameters.blocks["log_youngs_modulus"].slice] += np.log(1e4)
    state = sensitivity.run(far, data, substeps=steps)
    run = sensitivity.run(far, data, substeps=steps, tangents=True, threads=2)
    diverged = np.flatnonzero(~np.isfinite(state.positions).all(axis=(1, 2)))
    assert 0 < diverged[0] < data.n_frames - 5 and not run.finite
    assert np.array_equal(~np.isfinite(run.positions).all(axis=(1, 2)),
                          ~np.isfinite(state.positions).all(axis=(1, 2)))
    assert np.all(run.jacobian[diverged[0] - 1:] == 0.0)
