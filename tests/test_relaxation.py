"""Prony-series relaxation of the elements (:mod:`neurofuzzy.forces.relaxation`): the creep of a
block against the closed form of the standard linear solid, the compiled update against its
numpy reference, the stability bound, model files and the paths that cannot simulate it."""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError
from neurofuzzy.forces.relaxation import (decay, relaxation_arrays, relaxation_update,
                                          relaxed_stress)
from neurofuzzy.io import load_model, save_model
from neurofuzzy.kernels.relaxation import relax, relaxed
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.validation.nonlinear import sls_creep
from neurofuzzy.simulation import required_substeps, simulate

import numpy_reference as reference

E, NU, G, TAU = 6000.0, 0.3, 0.5, 0.05


def _block(law="st-venant-kirchhoff", relaxation=((G, TAU),), density=50.0):
    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.005)).with_fixed(
        where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=0.5,
                           density=density, law=law, relaxation=relaxation)


def _top_load(model, newtons=0.002):
    rest = model.mesh.rest_positions
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    load = np.zeros((model.n_nodes, 3))
    load[top, 2] = -newtons / len(top)
    return top, load


@pytest.mark.parametrize("law", ["st-venant-kirchhoff", "neo-hookean"])
def test_a_relaxing_block_creeps_as_the_standard_linear_solid(law):
    """Under a held load at small strain every stress of the block relaxes by the same
    function, so (correspondence principle) its displacement is the long-term one times the
    SLS creep compliance of one dimension, ``1 - g/(1+g) e^(-t/((1+g)τ))``: the simulated
    creep follows the closed form within 0.005 once the wave transients have died out (the
    block is light, so they die in a few ms), for both laws; the plain block does not creep."""
    model = _block(law)
    top, load = _top_load(model)
    dt, n = 0.002, 300
    t = np.arange(n) * dt
    moved = simulate(model, dt=dt, n_frames=n, external_forces=load,
                     substeps="auto").positions[:, top, 2].mean(axis=1)
    plain = simulate(_block(law, relaxation=None), dt=dt, n_frames=n, external_forces=load,
                     substeps="auto").positions[:, top, 2].mean(axis=1)
    rest = model.mesh.rest_positions[top, 2].mean()
    long_term = plain[-50:].mean() - rest
    ratio = (moved - rest) / long_term
    closed = sls_creep(t, 1.0, modulus=1.0, relative_modulus=G, time=TAU)
    settled = t >= 0.04
    assert np.abs(ratio[settled] - closed[settled]).max() < 0.005
    assert ratio[20] < 0.85 and ratio[-1] > 0.99                     # it did creep
    assert np.abs((plain[settled] - rest) / long_term - 1).max() < 0.01


def test_no_relaxation_is_the_plain_model_and_more_is_stiffer_at_once():
    """g = 0 simulates the plain block (to round-off: the stepper of a block that does not
    relax adds its elastic and viscous volumetric stresses at the nodes first); a Prony term
    makes the first response stiffer (by 1 + g at once) and the stability bound follows the
    instantaneous modulus."""
    plain, zero, relaxing = (_block(relaxation=r) for r in (None, ((0.0, TAU),), ((G, TAU),)))
    _, load = _top_load(plain)
    runs = [simulate(m, dt=0.002, n_frames=40, external_forces=load, substeps=12).positions
            for m in (plain, zero, relaxing)]
    motion = np.abs(runs[0] - runs[0][0]).max()
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-12 * motion)
    assert np.abs(runs[2] - runs[0]).max() > 1e-5
    stiff = plain.with_elements(youngs_modulus=plain.elements.youngs_modulus * (1 + G))
    assert required_substeps(relaxing, 0.002) == required_substeps(stiff, 0.002)
    assert required_substeps(relaxing, 0.002) > required_substeps(plain, 0.002)


def test_the_compiled_update_is_its_numpy_reference():
    """The kernels' stress and update of the internal variables equal the numpy reference for
    random values of two terms."""
    rng = np.random.default_rng(3)
    n, k = 5, 2
    g = rng.uniform(0, 1, (n, k))
    a = decay(rng.uniform(0.01, 0.2, (n, k)), 0.001)
    history = rng.normal(size=(n, k, 6))
    S = rng.normal(size=(n, 6))
    S_el = rng.normal(size=(n, 6))
    full = [0, 3, 4, 3, 1, 5, 4, 5, 2]          # six entries -> row-major 3x3

    def matrix(six):
        return np.asarray(six)[..., full].reshape(*np.shape(six)[:-1], 3, 3)

    expected_stress = relaxed_stress(matrix(S_el), matrix(history), g) - matrix(S_el) \
        + matrix(S)
    expected_history = relaxation_update(matrix(S_el), matrix(history), a)
    for e in range(n):
        out = relaxed(tuple(S[e]), tuple(S_el[e]), g, history, e)
        np.testing.assert_allclose(matrix(out), expected_stress[e], rtol=1e-14)
        relax(tuple(S_el[e]), a, history, e)
    np.testing.assert_allclose(matrix(history), expected_history, rtol=1e-14)


def test_relaxation_values_are_checked_and_survive_model_files(tmp_path):
    """Bad Prony terms are refused with the key named; a model file keeps the terms."""
    model = _block(relaxation=((0.5, 0.05), (0.2, 1.0)))
    assert model.n_relaxation_terms == 2
    assert "relaxation term 2: relative modulus 0.2, time 1 s" in model.summary()
    path = tmp_path / "model.yaml"
    save_model(model, path)
    back = load_model(path)
    np.testing.assert_array_equal(back.elements.relaxation_moduli,
                                  model.elements.relaxation_moduli)
    np.testing.assert_array_equal(back.elements.relaxation_times, model.elements.relaxation_times)
    assert load_model(_saved(tmp_path, _block(relaxation=None))).n_relaxation_terms == 0
    for terms, key, words in ((((-0.1, 0.05),), "element_relaxation_moduli", "negative"),
                              (((0.5, 0.0),), "element_relaxation_times", "positive"),
                              (((0.5, np.nan),), "element_relaxation_times", "NaN"),
                              (((0.1, 1.0),) * 4, "element_relaxation_moduli", "at most 3")):
        with pytest.raises(InputError, match=words) as error:
            _block(relaxation=terms)
        assert error.value.key == key
    with pytest.raises(InputError, match="both"):
        relaxation_arrays([0.5], None, 3)


def _saved(tmp_path, model):
    path = tmp_path / "plain.yaml"
    save_model(model, path)
    return path


def test_the_numpy_path_refuses_a_relaxing_model():
    """The numpy force has no internal variables: it says so instead of simulating the
    elements without their relaxation."""
    model = _block()
    rest = model.mesh.rest_positions
    with pytest.raises(InputError, match="relax"):
        model.elements.force(model, rest, np.zeros_like(rest))
    with pytest.raises(InputError, match="relax"):
        reference.simulate(model, dt=0.002, n_frames=3, substeps=12, backend="numpy")


@pytest.mark.parametrize("law", ["st-venant-kirchhoff", "neo-hookean"])
@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_the_sensitivities_of_a_relaxing_model_are_exact(law, volumetric):
    """Forward sensitivities of the compiled kernel (E, ν, η and two Prony terms' g and τ, with
    the internal variables' tangents) against central differences of the simulated markers,
    the adjoint's gradient (the internal variables' cotangents) against those of the loss,
    and both against each other when a window starts mid-recording (the internal variables
    run on across it, forwards and backwards)."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn._parameters import Parameterization
    from neurofuzzy.learn._sensitivity import Sensitivity

    model = _block(law, relaxation=((0.5, 0.02), (0.3, 0.1))).with_elements(
        volumetric=volumetric, poisson_ratio=np.full(48, 0.4))
    top, load = _top_load(model, 0.2)
    load[top, 0] = 0.05 / len(top)
    experiment = simulate_experiment(model, dt=0.002, n_frames=25, external_forces=load,
                                     substeps=20)
    parameters = Parameterization(model)
    assert parameters.names()[-4:] == ["relaxation_modulus1[all elements]",
                                       "relaxation_modulus2[all elements]",
                                       "relaxation_time1[all elements]",
                                       "relaxation_time2[all elements]"]
    sensitivity = Sensitivity(parameters, 1e-3)
    theta = parameters.initial() + np.random.default_rng(0).normal(0, 0.05, parameters.size)
    run = sensitivity.run(theta, experiment, substeps=20, tangents=True)
    loss, gradient, _ = sensitivity.gradient(theta, experiment, substeps=20)
    step = 1e-6
    for p in range(parameters.size):
        e = np.zeros(parameters.size)
        e[p] = step
        ahead, behind = (sensitivity.run(theta + s * e, experiment, substeps=20)
                         for s in (1, -1))
        central = (ahead.residuals - behind.residuals) / (2 * step)
        assert np.abs(central - run.jacobian[..., p]).max() < 1e-5 * np.abs(central).max()
        slope = (np.sum(ahead.residuals ** 2) - np.sum(behind.residuals ** 2)) / (4 * step)
        assert gradient[p] == pytest.approx(slope, rel=1e-5, abs=1e-9 * abs(loss))
    windows = sensitivity.run(theta, experiment, substeps=20, starts=(0, 12), tangents=True)
    _, adjoint, _ = sensitivity.gradient(theta, experiment, substeps=20, starts=(0, 12))
    forward = np.einsum("trk,trkp->p", windows.residuals, windows.jacobian)
    np.testing.assert_allclose(adjoint, forward, rtol=1e-9, atol=1e-12 * np.abs(forward).max())


def test_words_of_relaxation_make_a_relaxing_model_and_come_back(tmp_path):
    """A tissue described as relaxing quickly becomes elements with one Prony term of the rule
    base's g and τ; the fitted values come back as words ("moderate", "quick"); a tissue that
    says nothing of relaxation gets none, and the words of the fit leave it out."""
    from helpers import FIRM, soft_tissue_rules
    from neurofuzzy.tissues import initialize, materials

    rules = soft_tissue_rules(tmp_path / "r.yaml", "relaxing", {
        "creeping": f"{FIRM}, relaxation: relaxes, relaxation_speed: quickly", "plain": FIRM})
    mesh = _block().mesh
    model = initialize(rules, mesh, "creeping", elements=True)
    values = rules.tissue("creeping")
    assert model.n_relaxation_terms == 1
    assert model.elements.relaxation_moduli[0, 0] == pytest.approx(
        values["relaxation_modulus"], rel=1e-12)
    assert model.elements.relaxation_times[0, 0] == pytest.approx(
        values["relaxation_time"], rel=1e-12)
    words = materials(model, rules)["creeping"]["labels"]
    assert (words["relaxation_modulus"], words["relaxation_time"]) == ("moderate", "quick")
    fitted = model.with_elements(relaxation_moduli=np.full((48, 1), 2.0),
                                 relaxation_times=np.full((48, 1), 20.0))
    words = materials(fitted, rules)["creeping"]["labels"]
    assert (words["relaxation_modulus"], words["relaxation_time"]) == ("much", "slow")
    plain = initialize(rules, mesh, "plain", elements=True)
    assert plain.n_relaxation_terms == 0
    assert "relaxation_modulus" not in materials(plain, rules)["plain"]["labels"]


def test_fit_and_diagnose_take_relaxation_from_the_command_line(tmp_path):
    """``fit --relaxation 1`` fits a Prony term (its JSON names the relaxation's values),
    ``--relaxation 0.4:0.03`` starts it there, and a bad one exits 2 naming the option."""
    import json

    from helpers import cli
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.io import save_experiment

    truth = _block(relaxation=((0.5, 0.03),))
    top, load = _top_load(truth, 0.02)
    path = save_experiment(simulate_experiment(truth, dt=0.002, n_frames=100,
                                               external_forces=load, substeps=16, noise=2e-6,
                                               seed=1), tmp_path / "creep.npz")
    start = tmp_path / "start.yaml"
    save_model(_block(relaxation=None).with_elements(
        youngs_modulus=np.full(48, 8000.0)), start)
    result = cli("fit", path, "--start", start, "--relaxation", "1", "--tie", "global",
                 "--json", "--out", tmp_path / "fitted.yaml")
    assert result.returncode == 0, result.stderr
    fitted = load_model(tmp_path / "fitted.yaml")
    assert fitted.n_relaxation_terms == 1
    # the tolerances (g within 0.05, τ within 15 %): measured 0.528 and -8 % here,
    # where g, τ and η trade against each other at this noise (2 µm)
    assert fitted.elements.relaxation_moduli[0, 0] == pytest.approx(0.5, abs=0.05)
    assert fitted.elements.relaxation_times[0, 0] == pytest.approx(0.03, rel=0.15)
    assert fitted.elements.youngs_modulus[0] == pytest.approx(E, rel=0.02)
    assert np.shape(json.loads(result.stdout)["elements"]["relaxation_moduli"]) == (48, 1)
    bad = cli("fit", path, "--start", start, "--relaxation", "0.5:x")
    assert bad.returncode == 2 and "--relaxation" in bad.stderr


def test_the_report_shows_the_relaxation_modulus():
    """A relaxing model's "Material law" section adds the relaxation modulus plot, naming each
    region's g and τ; a plain model's has none."""
    from neurofuzzy.report.html import pyplot
    from neurofuzzy.report.laws import law_section

    _, text = law_section(pyplot(), _block(relaxation=((0.5, 0.05),)))
    assert "relaxation modulus" in text and text.count("<img") == 2
    _, plain = law_section(pyplot(), _block(relaxation=None))
    assert "relaxation modulus" not in plain and plain.count("<img") == 1


def test_a_trial_step_far_out_keeps_the_prony_terms_valid():
    """A fit's trial step may put log g or log τ anywhere: the model it stands for stays
    valid (τ positive and finite; a diagnosis once stopped on τ = 0 from an underflow) and
    its simulation runs."""
    from neurofuzzy.learn._parameters import Parameterization

    model = _block()
    parameters = Parameterization(model)
    for far in (-1000.0, 1000.0):
        theta = parameters.initial()
        theta[parameters.blocks["log_relaxation_times"].slice] = far
        theta[parameters.blocks["log_relaxation_moduli"].slice] = -abs(far)
        stepped = parameters.model(theta)
        times = stepped.elements.relaxation_times
        assert np.all((times > 0) & np.isfinite(times))
        _, load = _top_load(stepped)
        run = simulate(stepped, dt=0.002, n_frames=5, external_forces=load, substeps=12)
        assert np.all(np.isfinite(run.positions))


def test_the_studio_pokes_a_tissue_whose_words_make_it_relax(tmp_path):
    """The rule studio's block of a relaxing tissue (its words name relaxation) is simulated
    with its Prony term (the studio asked for the numpy stepper, which refuses relaxing
    elements: the block failed with a message about backends), says its g and τ, and is
    stiffer at once than the same tissue without relaxation under the same push."""
    from helpers import FIRM, soft_tissue_rules
    from neurofuzzy.rulestudio.tissue import BLOCK, poke

    rules = soft_tissue_rules(tmp_path / "r.yaml", "relaxing", {
        "creeping": f"{FIRM}, relaxation: relaxes, relaxation_speed: quickly", "plain": FIRM})
    creeping = poke(rules, "creeping")
    plain = poke(rules, "plain", force=creeping["probe"]["force"])
    values = rules.tissue("creeping")
    by_quantity = {rules.outputs[name].quantity: value for name, value in values.items()}
    assert creeping["material"]["relaxation_modulus"] == pytest.approx(
        by_quantity["relaxation_modulus"])
    assert creeping["material"]["relaxation_time"] == pytest.approx(
        by_quantity["relaxation_time"])
    assert "relaxation_modulus" not in plain["material"]
    ramped = BLOCK["ramp_frames"]
    assert 0 < creeping["depth"][ramped] < 0.9 * plain["depth"][ramped]
