"""Mooney–Rivlin elements (``law="mooney-rivlin"``), added as one record
(:data:`neurofuzzy.forces.laws.LAW_RECORDS`) and one kernel function: its stress against
FElupe's Mooney–Rivlin solid (code nobody here wrote) and a fit of it from the command line
(its FEBio material: tests/test_export_formats.py). Its derivatives, small-strain limit,
constant and force, stiffness and adjoint sweeps are checked with every other law's by
tests/test_kernels_law.py and tests/test_terms_registry.py without being told."""

import json

import numpy as np
import pytest

from helpers import cli, pressed_on_top
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.forces.laws import LAWS, STIFFENING_CONSTANT, law_number
from neurofuzzy.io import load_model, save_experiment, save_model
from neurofuzzy.kernels.laws import elastic
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model

MR = law_number("mooney-rivlin")
E, NU = 6000.0, 0.45


def _block(ratio=1.0, cells=(2, 2, 1), law="mooney-rivlin"):
    mesh = from_tetra(*kuhn_block(cells, 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=2.0,
                           density=1000.0, law=law, stiffening=ratio)


def test_the_records_and_the_kernels_name_the_same_laws_in_the_same_order():
    """A law's number is its position in both lists, and the laws with a constant of their
    own are the same in both (the kernels' adjoint forms its cotangent for those)."""
    from neurofuzzy.kernels.laws import KERNEL_LAWS, OWN_CONSTANT

    assert tuple(name for name, _ in KERNEL_LAWS) == LAWS
    assert {n for n, own in enumerate(OWN_CONSTANT) if own} == set(STIFFENING_CONSTANT)
    assert LAWS[MR] == "mooney-rivlin" and STIFFENING_CONSTANT[MR] == "C01/C10"
    assert law_number("MR") == MR


def test_its_constant_has_no_words_where_yeoh_s_has():
    """Yeoh's C20/C10 comes back as the rule base's ``strain_stiffening`` (words of
    stiffening); Mooney–Rivlin's C01/C10 is not a stiffening and gets no such word."""
    from neurofuzzy.constants.elements import element_values

    everything = np.ones(24, bool)
    assert element_values(_block(0.5, law="yeoh"), everything)["strain_stiffening"] == 0.5
    assert "strain_stiffening" not in element_values(_block(0.5), everything)


@pytest.mark.parametrize("ratio", [0.0, 0.4, 2.5])
def test_the_stress_is_felupe_s_mooney_rivlin_solid(ratio):
    """First Piola–Kirchhoff stress ``F S`` at large random deformations (stretches up to
    about 1.5 and 0.6) equals FElupe's ``mooney_rivlin(C10, C01)`` with its
    ``Volumetric(K)`` (``K/2 (J - 1)²``) for ``C10 + C01 = μ/2``, ``C01 = r C10``,
    ``K = λ + 2μ/3``."""
    fem = pytest.importorskip("felupe")
    pytest.importorskip("tensortrax")
    import felupe.constitution.tensortrax as tensortrax

    mu, lam = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    c10 = mu / (2 * (1 + ratio))
    reference = (tensortrax.Hyperelastic(tensortrax.models.hyperelastic.mooney_rivlin,
                                         C10=c10, C01=ratio * c10)
                 & fem.Volumetric(bulk=lam + 2 * mu / 3))
    rng = np.random.default_rng(3)
    for _ in range(6):
        F = np.eye(3) + rng.uniform(-0.3, 0.3, (3, 3))
        assert np.linalg.det(F) > 0.3
        G = 0.5 * (F.T @ F - np.eye(3))
        six = (G[0, 0], G[1, 1], G[2, 2], G[0, 1], G[0, 2], G[1, 2])
        theta = np.linalg.det(F) - 1
        s, got_theta = elastic(MR, six, 2 * mu, lam * theta, ratio)
        S = np.array([[s[0], s[3], s[4]], [s[3], s[1], s[5]], [s[4], s[5], s[2]]])
        want = reference.gradient([F[:, :, None, None], None])[0][:, :, 0, 0]
        assert got_theta == pytest.approx(theta, rel=1e-12)
        assert np.allclose(F @ S, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def test_fit_with_the_mooney_rivlin_law_from_the_command_line(tmp_path):
    """``fit --law mooney-rivlin --stiffening R`` fits E, ν, η and C01/C10 of a block pressed
    about 40 % (self-consistent data, 2 µm noise) from a start 30 % off in E and
    twice the constant; the JSON and the
    model file keep the law and the constant."""
    truth = _block(0.5)
    path = save_experiment(pressed_on_top(truth, 0.4, frames=40, noise=2e-6, seed=1),
                           tmp_path / "pressed.npz")
    start = save_model(_block(None, law="st-venant-kirchhoff").with_elements(
        youngs_modulus=np.full(24, 8000.0)), tmp_path / "start.yaml")
    result = cli("fit", path, "--start", start, "--law", "mooney-rivlin", "--stiffening", "1",
                 "--tie", "global", "--json", "--out", tmp_path / "fitted.yaml")
    assert result.returncode == 0, result.stderr
    fitted = load_model(tmp_path / "fitted.yaml")
    assert set(fitted.elements.law) == {MR}
    assert fitted.elements.youngs_modulus[0] == pytest.approx(E, rel=0.02)
    assert fitted.elements.stiffening[0] == pytest.approx(0.5, rel=0.05)
    assert np.shape(json.loads(result.stdout)["elements"]["stiffening"]) == (24,)
    assert "Mooney-rivlin C01/C10" in fitted.summary()
