"""The force-term interface: every term (springs and each effect) checked the same way.

For each term: the state JVP agrees with central differences of ``force``, the state VJP is its
transpose (dot-product test), parameter derivatives agree with central differences, and the
spring force obeys Newton's third law. The compiled kernel is tested equal to the spring term
in ``tests/test_simulate.py``.
"""

import numpy as np
import pytest

from neurofuzzy.datasets import paper_cube_model
from neurofuzzy.effects import (EFFECTS, Gravity, NodeDrag, NonlinearStiffening, StiffInclusion,
                                UnmodeledLoad)
from neurofuzzy.forces import ForceTerm, incidence
from neurofuzzy.simulation import internal_forces

MODEL = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0})
TERMS = [MODEL.springs, Gravity([0.1, -0.2, -9.0]), NodeDrag([0.01]),
         StiffInclusion.for_model(MODEL, [30.0, 20.0], springs=[0, 1, 2, 54, 55]),
         NonlinearStiffening.for_model(MODEL, [100.0, 50.0]),
         UnmodeledLoad([0.01, 0.02, -0.03], node=20)]


def state(seed):
    rng = np.random.default_rng(seed)
    p = MODEL.mesh.rest_positions + rng.normal(0, 2e-3, (MODEL.n_nodes, 3))
    v = rng.normal(0, 5e-2, (MODEL.n_nodes, 3))
    return p, v


def test_every_registered_effect_is_a_force_term_or_a_switch_of_the_material():
    from neurofuzzy.effects import MaterialSwitch

    for cls in EFFECTS.values():
        assert issubclass(cls, ForceTerm) != issubclass(cls, MaterialSwitch), cls.__name__
    assert {type(term).__name__ for term in TERMS[1:]} <= {c.__name__ for c in EFFECTS.values()}


@pytest.mark.parametrize("term", TERMS, ids=lambda t: t.name)
def test_state_jvp_matches_central_differences(term):
    p, v = state(1)
    rng = np.random.default_rng(2)
    dp, dv = rng.normal(size=(2, MODEL.n_nodes, 2, 3))
    jvp = term.state_jvp(MODEL, p, v, dp, dv)
    assert jvp.shape == (MODEL.n_nodes, 2, 3)
    eps = 1e-7
    for k in range(2):
        numeric = (term.force(MODEL, p + eps * dp[:, k], v + eps * dv[:, k])
                   - term.force(MODEL, p - eps * dp[:, k], v - eps * dv[:, k])) / (2 * eps)
        scale = np.abs(numeric).max() + 1e-12
        assert np.abs(jvp[:, k] - numeric).max() <= 1e-6 * scale


@pytest.mark.parametrize("term", TERMS, ids=lambda t: t.name)
def test_state_vjp_is_the_transpose_of_the_jvp(term):
    p, v = state(3)
    rng = np.random.default_rng(4)
    dp, dv = rng.normal(size=(2, MODEL.n_nodes, 1, 3))
    cotangent = rng.normal(size=(MODEL.n_nodes, 3))
    forward = np.sum(term.state_jvp(MODEL, p, v, dp, dv)[:, 0] * cotangent)
    lam_p, lam_v = term.state_vjp(MODEL, p, v, cotangent)
    reverse = np.sum(lam_p * dp[:, 0]) + np.sum(lam_v * dv[:, 0])
    assert forward == pytest.approx(reverse, rel=1e-10, abs=1e-14)


@pytest.mark.parametrize("term", TERMS[1:], ids=lambda t: t.name)
def test_effect_parameter_jacobian_matches_central_differences(term):
    p, v = state(5)
    jacobian = term.parameter_jacobian(MODEL, p, v)
    assert jacobian.shape == (MODEL.n_nodes, len(term.params), 3)
    for k in range(len(term.params)):
        step = np.zeros(len(term.params))
        step[k] = 1e-6 * max(1.0, abs(term.params[k]))
        numeric = (term.with_params(term.params + step).force(MODEL, p, v)
                   - term.with_params(term.params - step).force(MODEL, p, v)) / (2 * step[k])
        assert np.allclose(jacobian[:, k], numeric, rtol=1e-6,
                           atol=1e-9 * (np.abs(numeric).max() + 1e-12))


def test_spring_parameter_templates_and_vjp_match_finite_differences():
    p, v = state(6)
    rng = np.random.default_rng(7)
    cotangent = rng.normal(size=(MODEL.n_nodes, 3))
    spring_state = MODEL.springs.state(MODEL, p, v)
    templates = MODEL.springs.parameter_templates(spring_state)
    _, _, per_spring = MODEL.springs.vjp(MODEL, cotangent, spring_state)
    maps = incidence(MODEL.mesh)
    for name in ("stiffness", "damping"):
        for j in (0, 40, 85):
            values = getattr(MODEL.springs, name).copy()
            values[j] *= 1.001
            changed = MODEL.with_springs(**{name: values})
            numeric = (changed.springs.force(changed, p, v) - MODEL.springs.force(MODEL, p, v)) / (
                0.001 * getattr(MODEL.springs, name)[j])
            single = np.zeros((MODEL.n_springs, 3))
            single[j] = templates[name][j]
            assert np.allclose(maps.accumulate(single), numeric, rtol=1e-6, atol=1e-12)
            assert per_spring[name][j] == pytest.approx(np.sum(numeric * cotangent), rel=1e-6)


def test_spring_forces_balance_and_vanish_at_rest():
    p, v = state(8)
    force = MODEL.springs.force(MODEL, p, v)
    assert np.allclose(force.sum(axis=0), 0.0, atol=1e-12)
    torque = np.cross(p, force).sum(axis=0)
    assert np.abs(torque).max() < 1e-10 * np.abs(force).max()
    rest = MODEL.mesh.rest_positions
    assert np.abs(MODEL.springs.force(MODEL, rest, np.zeros_like(rest))).max() < 1e-12


def test_internal_forces_are_the_sum_of_the_model_terms():
    model = MODEL.with_effects(*TERMS[1:])
    p, v = state(9)
    assert model.force_terms[0] is model.springs is MODEL.springs
    expected = sum(term.force(model, p, v) for term in TERMS)
    assert np.allclose(internal_forces(model, p, v), expected)


def test_group_sums_split_the_net_force_by_group():
    p, v = state(10)
    maps = incidence(MODEL.mesh)
    spring_state = MODEL.springs.state(MODEL, p, v)
    per_spring = (MODEL.springs.magnitude(MODEL, spring_state)[:, None] * spring_state.direction)
    groups = MODEL.mesh.spring_group
    split = maps.group_sums(per_spring, groups, int(groups.max()) + 1)
    assert np.allclose(split.sum(axis=1), MODEL.springs.force(MODEL, p, v))


def test_the_spring_magnitude_is_one_law_with_its_own_derivatives():
    """kernels/springs.py: ``∂m/∂l`` and the partials by s, c, q are the central
    differences of the magnitude, and the numpy springs and shapes take their values from it."""
    from neurofuzzy.kernels.springs import CLOSING, CUBIC, STRETCH, magnitudes, partials

    rng = np.random.default_rng(11)
    n = 20
    x, xdot = rng.normal(0, 2e-3, n), rng.normal(0, 1e-2, n)
    s, c, q = rng.uniform(10, 100, n), rng.uniform(0.1, 1, n), rng.uniform(1e5, 1e6, n)
    value, slope = magnitudes(x, xdot, stiffness=s, damping=c, cubic=q)
    np.testing.assert_allclose(value, s * x + c * xdot + q * x**3, rtol=1e-13)
    h = 1e-7
    step = magnitudes(x + h, xdot, stiffness=s, damping=c, cubic=q)[0]
    back = magnitudes(x - h, xdot, stiffness=s, damping=c, cubic=q)[0]
    np.testing.assert_allclose(slope, (step - back) / (2 * h), rtol=1e-6)
    for basis, name in ((STRETCH, "stiffness"), (CLOSING, "damping"), (CUBIC, "cubic")):
        constants = {"stiffness": s, "damping": c, "cubic": q}
        up = magnitudes(x, xdot, **{**constants, name: constants[name] + 1.0})[0]
        down = magnitudes(x, xdot, **{**constants, name: constants[name] - 1.0})[0]
        np.testing.assert_allclose(partials(basis, x, xdot), (up - down) / 2, rtol=1e-6,
                                   atol=1e-18)
    model = paper_cube_model()
    p = model.mesh.rest_positions * 1.01
    v = rng.normal(0, 1e-3, p.shape)
    state = model.springs.state(model, p, v)
    np.testing.assert_array_equal(
        model.springs.magnitude(model, state),
        magnitudes(state.stretch, state.closing_speed, stiffness=model.springs.stiffness,
                   damping=model.springs.damping)[0])
