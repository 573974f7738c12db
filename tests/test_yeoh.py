"""Yeoh's strain-stiffening elements (``law="yeoh"``, :mod:`neurofuzzy.forces.laws`; the block
against the closed form of uniaxial stress is in tests/test_material_laws.py): the stiffening
constant learned with exact derivatives (against central differences, at large strain where it matters), and the constant
as a user meets it (model files, the command line, bad values)."""

import json

import numpy as np
import pytest
import yaml

from helpers import cli, pressed_on_top
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError
from neurofuzzy.io import load_model, save_experiment, save_model
from neurofuzzy.learn import Parameterization, Sensitivity
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.simulation import required_substeps

import numpy_reference as reference

E, NU = 6000.0, 0.45


def _block(stiffening=1.0, cells=(2, 2, 2), volumetric="nodal", law="yeoh"):
    mesh = from_tetra(*kuhn_block(cells, 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=2.0,
                           density=1000.0, volumetric=volumetric, law=law,
                           stiffening=stiffening)


_pressed = pressed_on_top


def test_stiffening_changes_nothing_at_small_strain_and_much_at_large():
    """Pressed by 2 mN the stiffening constant moves nothing (to 1e-4 of the motion); pressed
    by 1 N the block with C20 = 2 C10 sinks less than the one with C20 = 0 (the uncoupled
    neo-Hookean solid), and the compiled and numpy steppers agree on it."""
    small = [_pressed(_block(c), 0.002).positions[-1] for c in (0.0, 2.0)]
    rest = _block().mesh.rest_positions
    assert np.abs(small[1] - small[0]).max() < 1e-4 * np.abs(small[0] - rest).max()
    large = [_pressed(_block(c), 1.0).positions[-1] - rest for c in (0.0, 2.0)]
    sink = [-d[:, 2].min() for d in large]
    assert sink[0] > 0.2 * 0.02 and sink[1] < 0.85 * sink[0]


def _large_strain_data():
    truth = _block(1.2, cells=(2, 2, 1))
    return truth, _pressed(truth, 0.4, frames=40)


def test_the_stiffening_s_jacobian_and_gradient_are_central_differences():
    """At 20-30 % strain, the derivative of the simulated markers and of the cost by
    ``log c`` (Jacobian: forward sensitivities; gradient: the adjoint), compiled and numpy,
    against central differences of the simulation."""
    truth, data = _large_strain_data()
    parameters = Parameterization(truth)
    block = parameters.blocks["log_stiffening"]
    assert block.stop - block.start == 1
    theta = parameters.initial() + 0.05
    column = block.start
    substeps = required_substeps(truth, 1e-3)
    eps = 1e-5

    def residuals(t):
        run = Sensitivity(parameters, 0.01).run(t, data, substeps=substeps)
        return run.residuals

    step = np.zeros_like(theta)
    step[column] = eps
    central = (residuals(theta + step) - residuals(theta - step)) / (2 * eps)
    assert np.abs(central).max() > 1e-3            # the constant matters at this strain
    for backend in ("numba", "numpy"):
        sensitivity = reference.sensitivity(parameters, 0.01, backend=backend)
        run = sensitivity.run(theta, data, substeps=substeps, tangents=True)
        jacobian = run.jacobian[..., column].reshape(central.shape)
        assert np.abs(jacobian - central).max() < 1e-5 * np.abs(central).max()
        cost, gradient, _ = sensitivity.gradient(theta, data, substeps=substeps)
        plus = 0.5 * np.sum(residuals(theta + step) ** 2)
        minus = 0.5 * np.sum(residuals(theta - step) ** 2)
        assert gradient[column] == pytest.approx((plus - minus) / (2 * eps), rel=1e-5)


def test_stiffening_values_are_checked_and_survive_model_files(tmp_path):
    model = _block(np.linspace(0.5, 2.0, 48))
    assert "Yeoh C20/C10" in model.summary()
    path = save_model(model, tmp_path / "yeoh.yaml")
    assert yaml.safe_load(path.read_text())["elements"]["law"] == "yeoh"
    back = load_model(path)
    np.testing.assert_array_equal(back.elements.stiffening, model.elements.stiffening)
    assert np.all(_block(None).elements.stiffening == 1.0)              # the default
    # kept unused by a law without the constant, and taken up when the elements become Yeoh's
    neo = _block(3.0, law="neo-hookean")
    rest = neo.mesh.rest_positions
    pressed = rest * (1.0, 1.0, 0.7)
    plain = _block(0.0, law="neo-hookean")
    assert np.array_equal(neo.elements.force(neo, pressed, 0 * rest),
                          plain.elements.force(plain, pressed, 0 * rest))
    assert np.all(neo.with_elements(law="yeoh").elements.stiffening == 3.0)
    # a fit moves the Yeoh elements' constant only
    mixed = neo.with_elements(law=np.arange(48) % 2 * 2)
    parameters = Parameterization(mixed)
    theta = parameters.initial()
    theta[parameters.blocks["log_stiffening"].slice] += np.log(2.0)
    moved = parameters.model(theta).elements.stiffening
    assert np.allclose(moved[1::2], 6.0) and np.all(moved[::2] == 3.0)
    for value, words in ((-0.5, ">= 0"), (np.nan, ">= 0"), ([1.0, 2.0], "one per element")):
        with pytest.raises(InputError, match=words) as error:
            _block(value)
        assert error.value.key == "element_stiffening"


def test_fit_with_the_yeoh_law_from_the_command_line(tmp_path):
    """``fit --law yeoh --stiffening C`` fits E, ν, η and C20/C10 of a pressed block
    (self-consistent data, 2 µm noise: a start 40 % off in the constant and 30 % in E comes
    back close), its JSON names the constant per element; a stiffening without Yeoh
    elements and a negative one exit with status 2, naming the option or key."""
    truth = _block(1.2, cells=(2, 2, 1))
    path = save_experiment(_pressed(truth, 0.4, frames=40, noise=2e-6, seed=1),
                           tmp_path / "pressed.npz")
    start = save_model(_block(None, cells=(2, 2, 1), law="st-venant-kirchhoff").with_elements(
        youngs_modulus=np.full(24, 8000.0)), tmp_path / "start.yaml")
    result = cli("fit", path, "--start", start, "--law", "yeoh", "--stiffening", "0.7",
                 "--tie", "global", "--json", "--out", tmp_path / "fitted.yaml")
    assert result.returncode == 0, result.stderr
    fitted = load_model(tmp_path / "fitted.yaml")
    assert set(fitted.elements.law) == {2}
    assert fitted.elements.stiffening[0] == pytest.approx(1.2, rel=0.1)
    assert fitted.elements.youngs_modulus[0] == pytest.approx(E, rel=0.02)
    assert np.shape(json.loads(result.stdout)["elements"]["stiffening"]) == (24,)
    for args, words in ((("--stiffening", "1.0"), "no elements of such a law"),
                        (("--law", "yeoh", "--stiffening", "-1"), ">= 0")):
        bad = cli("fit", path, "--start", start, *args, "--out", tmp_path / "x.yaml")
        assert bad.returncode == 2 and words in bad.stderr, bad.stderr
        assert "Traceback" not in bad.stderr


def test_words_of_stiffening_make_yeoh_elements_and_come_back(tmp_path):
    """A tissue described as stiffening strongly becomes Yeoh elements with the rule base's
    C20/C10; fitted values come back as words ("little" for 0.05, "moderate" for 1,
    "strongly" for 8); a tissue that says nothing of it keeps the default law, and its words
    leave the quantity out."""
    from helpers import FIRM, soft_tissue_rules
    from neurofuzzy.tissues import initialize, materials

    rules = soft_tissue_rules(tmp_path / "r.yaml", "stiffening", {
        "hardening": f"{FIRM}, stiffening: strongly", "plain": FIRM})
    mesh = _block().mesh
    model = initialize(rules, mesh, "hardening", elements=True)
    assert set(model.elements.law) == {2}
    value = rules.tissue("hardening")["strain_stiffening"]
    assert value > 1.5 and model.elements.stiffening[0] == pytest.approx(value, rel=1e-12)
    assert materials(model, rules)["hardening"]["labels"]["strain_stiffening"] == "strongly"
    for c, word in ((0.05, "little"), (1.0, "moderate"), (8.0, "strongly")):
        fitted = model.with_elements(stiffening=np.full(48, c))
        assert materials(fitted, rules)["hardening"]["labels"]["strain_stiffening"] == word
    plain = initialize(rules, mesh, "plain", elements=True)
    assert set(plain.elements.law) == {0}
    assert "strain_stiffening" not in materials(plain, rules)["plain"]["labels"]


def test_the_diagnosis_offers_each_law_switch_in_turn():
    """SVK elements are offered ``hyperelasticity`` (to neo-Hookean) and not the Yeoh switch;
    neo-Hookean ones ``nonlinear_stiffening`` (to Yeoh's law, a switch, not a force patch);
    Yeoh's neither; a spring network keeps the cubic spring term."""
    from types import SimpleNamespace

    from neurofuzzy.datasets import paper_cube_model
    from neurofuzzy.effects import Hyperelasticity, NonlinearStiffening

    nothing = SimpleNamespace(present=set())

    def offered(model):
        return [effect for cls in (Hyperelasticity, NonlinearStiffening)
                for effect in cls.propose(model, nothing)]

    svk, neo, yeoh = (_block(law=law) for law in ("st-venant-kirchhoff", "neo-hookean", "yeoh"))
    assert [e.name for e in offered(svk)] == ["hyperelasticity"]
    [switch] = offered(neo)
    assert switch.name == "nonlinear_stiffening" and switch.switches_material
    switched = switch.switch(neo, 0.1)
    assert set(switched.elements.law) == {2} and np.all(switched.elements.stiffening == 1.0)
    assert switch.switched_values(switched) == {"stiffening": 1.0}
    assert offered(yeoh) == []
    [spring] = offered(paper_cube_model())
    assert spring.name == "nonlinear_stiffening" and not spring.switches_material
