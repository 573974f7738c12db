import numpy as np
import pytest

from neurofuzzy.datasets import CUBE, paper_cube_experiment, paper_cube_model
from neurofuzzy.effects import (EFFECTS, Gravity, NodeDrag, NonlinearStiffening, SoftInclusion,
                                StiffInclusion, UnmodeledLoad, effect_from_dict, effect_to_dict)
from neurofuzzy.errors import InputError
from neurofuzzy.io import load_model, save_model
from neurofuzzy.learn import GradientLearner, PaperLearner
from neurofuzzy.learn import Parameterization, Sensitivity
from neurofuzzy.simulation import internal_forces

TRUTH = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0})
CENTRE = [j for j in range(86) if 13 in TRUTH.mesh.springs[j]]


def all_effects(model):
    return [Gravity([0.1, -0.2, -9.0]), NodeDrag([0.01]),
            StiffInclusion.for_model(model, [30.0, 20.0], springs=CENTRE[:6] + [54]),
            SoftInclusion.for_model(model, [-10.0], springs=[50, 51]),
            NonlinearStiffening.for_model(model, [100.0, 50.0]),
            UnmodeledLoad([0.01, 0.02, -0.03], node=20)]


def test_the_vocabulary_is_registered():
    # DESIGN.md's vocabulary and the switches of the elements' material of issue 27
    # (hyperelasticity: the elements become neo-Hookean; relaxation: they get a Prony term)
    assert set(EFFECTS) == {"gravity", "node_drag", "stiff_inclusion", "soft_inclusion",
                            "nonlinear_stiffening", "unmodeled_load", "hyperelasticity",
                            "relaxation"}


@pytest.mark.parametrize("index", [0, 5] + [pytest.param(i, marks=pytest.mark.slow)
                                            for i in (1, 2, 3, 4)])
def test_effect_derivatives_are_exact(index, cube_experiment):
    rng = np.random.default_rng(index)
    effect = all_effects(TRUTH)[index]
    model = TRUTH.with_springs(stiffness=TRUTH.springs.stiffness * rng.uniform(0.8, 1.2, 86))
    parameters = Parameterization(model.with_effects(effect), learn_masses=True)
    sensitivity = Sensitivity(parameters, CUBE["edge_length"])
    theta = parameters.initial()
    data = cube_experiment.replace(positions=cube_experiment.positions[:120])
    _, gradient, _ = sensitivity.gradient(theta, data, substeps=2, starts=(0, 60))
    run = sensitivity.run(theta, data, substeps=2, starts=(0, 60), tangents=True)
    assert np.allclose(run.jacobian.reshape(-1, theta.size).T @ run.residuals.ravel(),
                       gradient, rtol=1e-9, atol=1e-12 * np.abs(gradient).max())
    for direction in rng.normal(size=(2, theta.size)):
        direction /= np.linalg.norm(direction)
        plus = sensitivity.gradient(theta + 1e-6 * direction, data, substeps=2,
                                    starts=(0, 60))[0]
        minus = sensitivity.gradient(theta - 1e-6 * direction, data, substeps=2,
                                     starts=(0, 60))[0]
        numeric = (plus - minus) / 2e-6
        assert abs(gradient @ direction - numeric) < 1e-6 * abs(numeric)


def test_forces_act_as_described(rng):
    p = TRUTH.mesh.rest_positions + rng.normal(0, 1e-4, (27, 3))
    v = rng.normal(0, 1e-2, (27, 3))
    gravity = Gravity([0, 0, -9.81]).force(TRUTH, p, v)
    assert np.allclose(gravity, TRUTH.node_mass[:, None] * [0, 0, -9.81])
    assert np.allclose(NodeDrag([0.5]).force(TRUTH, p, v), -0.5 * v)
    load = UnmodeledLoad([1.0, 2.0, 3.0], node=7).force(TRUTH, p, v)
    assert np.allclose(load[7], [1, 2, 3]) and np.count_nonzero(load) == 3
    # an inclusion of +100 % stiffness doubles the spring forces of its springs
    region = list(range(86))
    doubled = TRUTH.with_effects(StiffInclusion.for_model(TRUTH, [60.0, 35.0], springs=region))
    still = np.zeros_like(v)
    assert np.allclose(internal_forces(doubled, p, still), 2 * internal_forces(TRUTH, p, still))
    # nonlinear stiffening adds nothing at rest and grows with the cube of the stretch
    stiffening = NonlinearStiffening.for_model(TRUTH, [100.0, 50.0])
    assert np.allclose(stiffening.force(TRUTH, TRUTH.mesh.rest_positions, v), 0.0)
    stretched = TRUTH.mesh.rest_positions * 1.01
    twice = TRUTH.mesh.rest_positions * 1.02
    ratio = (np.abs(stiffening.force(TRUTH, twice, v)).sum()
             / np.abs(stiffening.force(TRUTH, stretched, v)).sum())
    assert ratio == pytest.approx(8.0, rel=1e-6)


def test_effects_round_trip_through_model_files(tmp_path):
    model = TRUTH.with_effects(*all_effects(TRUTH))
    loaded = load_model(save_model(model, tmp_path / "m.yaml"))
    assert [e.name for e in loaded.effects] == [e.name for e in model.effects]
    for a, b in zip(loaded.effects, model.effects):
        assert np.array_equal(a.params, b.params) and a.options == b.options
    with pytest.raises(InputError, match="did you mean 'gravity'"):
        effect_from_dict({"name": "gravty", "params": [0, 0, 1]})
    with pytest.raises(InputError, match="takes 3 parameter"):
        effect_from_dict({"name": "gravity", "params": [1.0]})
    assert effect_from_dict(effect_to_dict(NodeDrag([0.2]))).params.tolist() == [0.2]


def test_both_learners_fit_effect_parameters():
    truth = TRUTH.with_effects(Gravity([0.0, 0.0, -9.81]))
    data = paper_cube_experiment(truth)
    start = TRUTH.tied("groups").with_effects(Gravity([0.0, 0.0, -5.0]))
    gradient = GradientLearner().fit(start, data)
    assert np.allclose(gradient.model_.effects[0].params, [0, 0, -9.81], atol=1e-8)
    paper = PaperLearner(learning_rate=0.0, cycles=30).fit(start, data)
    assert np.allclose(paper.model_.effects[0].params, [0, 0, -9.81], atol=1e-6)


def _element_block():
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                           viscosity=2.0, density=1000.0)


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_an_element_inclusion_is_extra_youngs_modulus_on_its_region(volumetric, rng):
    """Its force is exactly the model's own with E + δ on the region's elements (and the same
    viscosity), for both volumetric forms; derivatives are exact; it round-trips."""

    model = _element_block().with_elements(volumetric=volumetric)
    region = [0, 1, 5, 9]
    inclusion = StiffInclusion.of_elements(model, region, 2500.0)
    assert inclusion.options["poisson_ratio"] == pytest.approx(0.45)
    p = model.mesh.rest_positions + rng.normal(0, 2e-4, (model.n_nodes, 3))
    v = rng.normal(0, 1e-2, (model.n_nodes, 3))
    stiffer = model.elements.youngs_modulus.copy()
    stiffer[region] += 2500.0
    both = model.elements.force(model, p, v) + inclusion.force(model, p, v)
    stiffened = model.with_elements(youngs_modulus=stiffer)
    assert np.allclose(both, stiffened.elements.force(stiffened, p, v), rtol=0,
                       atol=1e-12 * np.abs(both).max())
    jacobian = inclusion.parameter_jacobian(model, p, v)
    assert np.allclose(jacobian[:, 0] * 2500.0, inclusion.force(model, p, v))
    assert inclusion.labels == ("extra_youngs_modulus",)
    assert inclusion.relative(model)["extra_youngs_modulus"] == pytest.approx(2500 / 6000)
    dp, dv = rng.normal(size=(2, model.n_nodes, 1, 3))
    jvp = inclusion.state_jvp(model, p, v, dp, dv)[:, 0]
    numeric = (inclusion.force(model, p + 1e-7 * dp[:, 0], v + 1e-7 * dv[:, 0])
               - inclusion.force(model, p - 1e-7 * dp[:, 0], v - 1e-7 * dv[:, 0])) / 2e-7
    assert np.allclose(jvp, numeric, atol=1e-6 * np.abs(numeric).max())
    cotangent = rng.normal(size=(model.n_nodes, 3))
    lam_p, lam_v = inclusion.state_vjp(model, p, v, cotangent)
    assert np.sum(jvp * cotangent) == pytest.approx(np.sum(lam_p * dp[:, 0])
                                                    + np.sum(lam_v * dv[:, 0]), rel=1e-10)
    restored = effect_from_dict(effect_to_dict(SoftInclusion([-100.0], elements=region,
                                                             poisson_ratio=0.4)))
    assert restored.name == "soft_inclusion" and restored.elements.tolist() == region
    assert restored.options["poisson_ratio"] == 0.4
    with pytest.raises(InputError, match="springs or its elements"):
        StiffInclusion([1.0])
    with pytest.raises(InputError, match="Poisson's ratio"):
        StiffInclusion([1.0], elements=region)


def test_element_inclusion_gradients_are_exact():
    from helpers import assert_gradient_exact

    from neurofuzzy.experiment import simulate_experiment

    model = _element_block()
    truth = model.with_effects(StiffInclusion.of_elements(model, [0, 1, 2, 3, 4, 5], 8000.0))
    load = np.zeros((model.n_nodes, 3))
    load[-1] = (0.0, 0.01, -0.02)
    data = simulate_experiment(truth, dt=1e-3, n_frames=12, external_forces=load, substeps=4)
    start = model.with_effects(StiffInclusion([3000.0], elements=[0, 1, 2, 3, 4, 5],
                                              poisson_ratio=0.4))
    parameters = Parameterization(start)
    assert parameters.names()[-1] == "stiff_inclusion.extra_youngs_modulus"
    assert_gradient_exact(Sensitivity(parameters, 0.01), parameters.initial(), data, 4)


def test_element_stiffening_is_the_quartic_strain_energy_with_exact_derivatives(rng):
    """On elements, nonlinear_stiffening is the force of ``W = ½ κ V (G:G)²`` (checked by
    differentiating the energy numerically), nothing at small strain, with exact state and
    parameter derivatives, and it round-trips through model files."""
    from neurofuzzy.forces import tetrahedron_geometry

    model = _element_block()
    effect = NonlinearStiffening([3000.0], on="elements")
    geometry = tetrahedron_geometry(model.mesh)

    def energy(positions):
        F = geometry.edges(positions) @ geometry.inverse_rest
        green = 0.5 * (np.swapaxes(F, 1, 2) @ F - np.eye(3))
        return 0.5 * 3000.0 * np.sum(geometry.volume * np.einsum("kij,kij->k", green, green)**2)

    p = model.mesh.rest_positions + rng.normal(0, 1e-3, (model.n_nodes, 3))
    v = rng.normal(0, 1e-2, (model.n_nodes, 3))
    force = effect.force(model, p, v)
    direction = rng.normal(size=p.shape)
    numeric = -(energy(p + 1e-7 * direction) - energy(p - 1e-7 * direction)) / 2e-7
    assert np.sum(force * direction) == pytest.approx(numeric, rel=1e-6)
    small = model.mesh.rest_positions + 1e-3 * (p - model.mesh.rest_positions)
    assert np.abs(effect.force(model, small, v)).max() < 1e-8 * np.abs(force).max()
    assert np.allclose(effect.parameter_jacobian(model, p, v)[:, 0] * 3000.0, force)
    dp, dv = rng.normal(size=(2, model.n_nodes, 1, 3))
    jvp = effect.state_jvp(model, p, v, dp, dv)[:, 0]
    numeric = (effect.force(model, p + 1e-7 * dp[:, 0], v)
               - effect.force(model, p - 1e-7 * dp[:, 0], v)) / 2e-7
    assert np.allclose(jvp, numeric, atol=1e-6 * np.abs(numeric).max())
    cotangent = rng.normal(size=(model.n_nodes, 3))
    lam_p, lam_v = effect.state_vjp(model, p, v, cotangent)
    assert np.sum(jvp * cotangent) == pytest.approx(np.sum(lam_p * dp[:, 0]), rel=1e-10)
    assert not lam_v.any()
    restored = effect_from_dict(effect_to_dict(effect))
    assert restored.on_elements and restored.labels == ("kappa",)
    assert np.allclose(restored.force(model, p, v), force)
    assert effect.relative(model)["kappa"] == pytest.approx(3000.0 / (6000.0 / 2.9))
    with pytest.raises(InputError, match="'springs' or 'elements'"):
        NonlinearStiffening([1.0], on="tetrahedra")


def test_element_stiffening_gradients_are_exact():
    from helpers import assert_gradient_exact

    from neurofuzzy.experiment import simulate_experiment

    model = _element_block()
    truth = model.with_effects(NonlinearStiffening([2e5], on="elements"))
    load = np.zeros((model.n_nodes, 3))
    load[-1] = (0.0, 0.2, -0.4)
    data = simulate_experiment(truth, dt=1e-3, n_frames=12, external_forces=load, substeps=4)
    parameters = Parameterization(model.with_effects(NonlinearStiffening([5e4], on="elements")))
    assert parameters.names()[-1] == "nonlinear_stiffening.kappa"
    assert_gradient_exact(Sensitivity(parameters, 0.01), parameters.initial(), data, 4)
