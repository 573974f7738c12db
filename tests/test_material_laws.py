"""The elements' material laws as a user meets them: the neo-Hookean element against the closed
form of uniaxial stress (:mod:`neurofuzzy.validation.nonlinear.closed_forms`), both laws alike at
small strain and apart at large, and the law carried by model files, the command line and
``nf.fit``."""

import json

import numpy as np
import pytest
import yaml

from helpers import cli
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.io import load_model, save_model
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.validation.nonlinear import NeoHookean, Yeoh, uniaxial_stress

E, NU = 6000.0, 0.45


def _block(law, volumetric="nodal", cells=(2, 2, 2)):
    mesh = from_tetra(*kuhn_block(cells, 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=2.0,
                           density=1000.0, volumetric=volumetric, law=law)


#: each curved law and its closed form (:mod:`neurofuzzy.validation.nonlinear`, written in
#: principal stretches apart from the elements); Yeoh's with C20 = 1.5 C10
CLOSED_FORMS = {"neo-hookean": NeoHookean(E, NU), "yeoh": Yeoh.from_youngs(E, NU, c20_ratio=1.5)}


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
@pytest.mark.parametrize("stretch", [0.7, 1.25])
@pytest.mark.parametrize("law", list(CLOSED_FORMS))
def test_a_block_carries_the_closed_form_uniaxial_stress_of_its_law(law, volumetric, stretch):
    """A block stretched homogeneously by the closed form's axial and lateral stretches: the
    force on its end face per reference area is the closed-form nominal stress, its free sides
    carry none and no inner node is pushed (to round-off), in both volumetric forms, for the
    neo-Hookean and the Yeoh law; an SVK block at the same stretches does not carry it at 30 %
    compression."""
    closed = uniaxial_stress(CLOSED_FORMS[law], stretch)
    F = np.diag([float(closed.lateral_stretch)] * 2 + [stretch])       # axial along z
    model = _block(law, volumetric).with_elements(stiffening=1.5)
    rest = model.mesh.rest_positions
    force = model.elements.force(model, rest @ F.T, np.zeros_like(rest))
    side = 0.02
    top = np.isclose(rest[:, 2], side)
    # the internal force balances the load: the load on the top face is -force
    assert -force[top, 2].sum() / side**2 == pytest.approx(float(closed.nominal_stress),
                                                           rel=1e-10)
    inner = np.all((rest > 1e-9) & (rest < side - 1e-9), axis=1)
    scale = np.abs(force).max()
    assert np.abs(force[inner]).max() < 1e-10 * scale
    for axis in (0, 1):
        face = np.isclose(rest[:, axis], side)
        assert abs(force[face, axis].sum()) < 1e-10 * scale
    block = _block("st-venant-kirchhoff", volumetric)
    svk = block.elements.force(block, rest @ F.T, np.zeros_like(rest))
    if stretch < 1:
        assert abs(svk[top, 2].sum() / force[top, 2].sum() - 1) > 0.15


def _pressed(law, newtons):
    model = _block(law, cells=(3, 3, 2))
    load = np.zeros((model.n_nodes, 3))
    top = np.flatnonzero(np.isclose(model.mesh.rest_positions[:, 2], 0.02))
    load[top, 2] = -newtons / len(top)
    return simulate_experiment(model, dt=1e-3, n_frames=200, external_forces=load,
                               substeps="auto").positions[-1] - model.mesh.rest_positions


def test_the_laws_agree_at_small_strain_and_part_at_large():
    """Pressed by 2 mN (0.07 % strain) the two laws move the block alike (to 1 %; they part
    at second order, by about λ/μ times the strain); pressed by 1 N neo-Hookean sinks by about
    30 % of the height, while SVK, which softens in compression, collapses (here through
    itself: 2.2 times the height)."""
    small = [_pressed(law, 0.002) for law in ("st-venant-kirchhoff", "neo-hookean")]
    assert np.abs(small[1] - small[0]).max() < 0.01 * np.abs(small[0]).max()
    large = [_pressed(law, 1.0) for law in ("st-venant-kirchhoff", "neo-hookean")]
    sink = [-d[:, 2].min() for d in large]
    assert 0.2 * 0.02 < sink[1] < 0.4 * 0.02         # about 30 % of the 2 cm height
    assert sink[0] > 2 * sink[1]


def test_model_files_keep_the_law_and_old_files_read_as_svk(tmp_path):
    uniform = _block("neo-hookean")
    path = save_model(uniform, tmp_path / "nh.yaml")
    assert yaml.safe_load(path.read_text())["elements"]["law"] == "neo-hookean"
    assert set(load_model(path).elements.law) == {1}
    mixed = uniform.with_elements(law=np.arange(uniform.mesh.n_tetrahedra) % 2)
    loaded = load_model(save_model(mixed, tmp_path / "mixed.yaml"))
    assert np.array_equal(loaded.elements.law, mixed.elements.law)
    assert "neo-hookean (24 elements), st-venant-kirchhoff" in loaded.summary() or \
        "st-venant-kirchhoff (24 elements), neo-hookean (24 elements)" in loaded.summary()
    svk = save_model(_block("st-venant-kirchhoff"), tmp_path / "svk.yaml")
    assert "law" not in yaml.safe_load(svk.read_text())["elements"]      # as before laws
    assert set(load_model(svk).elements.law) == {0}


def test_a_misspelt_law_in_a_model_file_is_named_with_the_closest(tmp_path):
    path = save_model(_block("neo-hookean"), tmp_path / "nh.yaml")
    path.write_text(path.read_text().replace("law: neo-hookean", "law: neo-hooken"))
    result = cli("simulate", path, "--frames", "3", "--out", tmp_path / "x.npz")
    assert result.returncode == 2
    assert "neo-hooken" in result.stderr and "did you mean 'neo-hookean'" in result.stderr
    assert "Traceback" not in result.stderr


def test_fit_with_a_law_and_refusals(tmp_path):
    """``fit --law`` fits neo-Hookean elements and records the law in the fitted model;
    ``--law`` on a spring network is refused with exit status 2."""
    truth = _block("neo-hookean", cells=(2, 2, 1))
    load = np.zeros((truth.n_nodes, 3))
    load[-1] = (0.0, 0.0, -0.05)
    data = simulate_experiment(truth, dt=1e-3, n_frames=40, external_forces=load,
                               substeps="auto")
    data_path = tmp_path / "data.npz"
    from neurofuzzy.io import save_experiment

    save_experiment(data, data_path)
    start = save_model(truth.with_elements(youngs_modulus=np.full(truth.mesh.n_tetrahedra,
                                                                    4000.0),
                                           law=0), tmp_path / "start.yaml")
    result = cli("fit", data_path, "--start", start, "--law", "neo-hookean", "--tie", "global",
                 "--out", tmp_path / "fitted.yaml", "--quiet", "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["material_law"] == "neo-hookean"
    fitted = load_model(tmp_path / "fitted.yaml")
    assert set(fitted.elements.law) == {1}
    assert fitted.elements.youngs_modulus[0] == pytest.approx(E, rel=1e-3)
    springs = save_model(Model.uniform(truth.mesh, stiffness=10.0, damping=0.01,
                                       total_mass=0.01), tmp_path / "springs.yaml")
    result = cli("fit", data_path, "--start", springs, "--law", "neo-hookean",
                 "--out", tmp_path / "no.yaml")
    assert result.returncode == 2
    assert "--law" in result.stderr and "spring network" in result.stderr


def test_the_mesh_command_writes_the_law_and_refuses_it_for_springs(tmp_path):
    import trimesh

    trimesh.creation.box(extents=(0.03, 0.03, 0.02)).export(tmp_path / "box.stl")
    common = ["mesh", tmp_path / "box.stl", "--pitch", "0.01", "--fix-bottom", "--rules",
              "liver", "--tissue", "liver"]
    result = cli(*common, "--law", "neo-hookean", "--out", tmp_path / "nh.yaml")
    assert result.returncode == 0, result.stderr
    assert "material law: neo-hookean" in result.stdout
    assert set(load_model(tmp_path / "nh.yaml").elements.law) == {1}
    result = cli(*common, "--elements", "springs", "--law", "neo-hookean",
                 "--out", tmp_path / "springs.yaml")
    assert result.returncode == 2 and "--law" in result.stderr
    assert not (tmp_path / "springs.yaml").exists()


def test_the_uniaxial_curves_and_the_report_section():
    """The report's curve of the neo-Hookean law is the closed form (another implementation,
    in principal stretches) to round-off; SVK has slope E at rest and softens under strong
    compression; a fit report of a neo-Hookean model has its section."""
    from neurofuzzy.forces.laws import uniaxial_stress as curve
    from neurofuzzy.report.html import pyplot
    from neurofuzzy.report.laws import law_section

    stretches = np.array([0.65, 0.7, 0.9, 1.1, 1.25])
    closed = uniaxial_stress(NeoHookean(E, NU), stretches).nominal_stress
    assert np.allclose(curve("neo-hookean", E, NU, stretches), closed, rtol=1e-10)
    slope = np.diff(curve("st-venant-kirchhoff", E, NU, [0.9999, 1.0001]))[0] / 2e-4
    assert slope == pytest.approx(E, rel=1e-3)
    svk = curve("st-venant-kirchhoff", E, NU, [0.7, 0.65])
    assert abs(svk[1]) < abs(closed[0]) / 2                    # far softer at 35 %
    title, text = law_section(pyplot(), _block("neo-hookean"))
    assert title == "Material law" and "neo-hookean" in text and "<img" in text
    assert law_section(pyplot(), Model.uniform(
        _block("neo-hookean").mesh, stiffness=1.0, damping=0.0, total_mass=1.0)) is None
