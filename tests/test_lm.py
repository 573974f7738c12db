"""Levenberg–Marquardt (:mod:`neurofuzzy.learn._lm`) with the trial steps' Jacobian taken from
the same pass as their residuals (``both``): the same steps, fewer passes; and in the
gradient learner, the Jacobian at the result reused for the standard errors."""

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


def test_the_learner_reuses_the_jacobian_at_its_result(monkeypatch):
    """A per-region element fit: with the trial steps' Jacobians, the same model, standard
    errors and lack of fit from fewer simulations of the data (the standard errors take the
    last Jacobian instead of one more pass). The same to round-off: a trial step without its
    Jacobian is a run of the stepper's driver, whose St. Venant–Kirchhoff loop adds the
    volumetric stresses in another order than the sensitivities' (3e-16 of E here)."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn import GradientLearner, gradient
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
    for cost in (0, gradient.SPECULATE_COST):          # 0: never with the trial steps
        monkeypatch.setattr(gradient, "SPECULATE_COST", cost)
        fits[cost] = GradientLearner(substeps=steps).fit(model(4000.0, 0.4, 3.0), data)
    apart, together = fits[0], fits[gradient.SPECULATE_COST]
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
