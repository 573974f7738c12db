"""MuJoCo export, verified by running it: the exported MJCF, simulated by MuJoCo under the same
load at the same time step, reproduces neurofuzzy's own simulation."""

import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import neurofuzzy as nf
from neurofuzzy.datasets import kuhn_block, paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.export.mujoco import simulate_mujoco

mujoco = pytest.importorskip("mujoco")

#: MuJoCo against our stepper on the textbook element (the issue asks for 1 µm; measured
#: 2e-9 m: the only difference is MuJoCo's backward-difference strain rate, h l̇²)
ELEMENT_TOLERANCE = 1e-7


def rms(a, b, free):
    return float(np.sqrt(np.mean(np.sum((a[:, free] - b[:, free]) ** 2, axis=-1))))


def block_model(volumetric="element", regions=False, nu=0.35):
    """A 3 × 3 × 2 cm Kuhn block, bottom fixed; with ``regions``, a stiffer, more viscous
    'tumour' half with another Poisson's ratio."""
    points, tetrahedra = kuhn_block((3, 3, 2), 0.01)
    mesh = nf.from_tetra(points, tetrahedra).with_fixed(where=nf.bottom_layer)
    model = nf.Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=nu,
                               viscosity=2.0, density=1050.0, volumetric=volumetric)
    if regions:
        inside = points[tetrahedra].mean(axis=1)[:, 0] > 0.015
        node_region = np.zeros(mesh.n_nodes, int)
        node_region[np.unique(tetrahedra[inside])] = 1
        elements = model.elements.replace(region=inside.astype(int),
                                          youngs_modulus=np.where(inside, 24000.0, 6000.0),
                                          poisson_ratio=np.where(inside, 0.45, nu),
                                          viscosity=np.where(inside, 12.0, 2.0))
        model = model.replace(region_names=("liver", "tumour"),
                              region_tissues=("liver", "tumour"), node_region=node_region,
                              terms=(elements,))
    return model


def probe(model, n_frames=60, dt=1e-3, touch=5):
    """A push on the top face from frame ``touch`` on."""
    points = model.mesh.rest_positions
    top = np.flatnonzero(np.isclose(points[:, 2], points[:, 2].max()))
    forces = np.zeros((n_frames, model.n_nodes, 3))
    forces[touch:, top] = (0.01 / len(top), 0.0, -0.05 / len(top))
    return forces


def test_a_fitted_element_model_runs_in_mujoco_as_in_neurofuzzy(tmp_path):
    """The issue's check: fit, save with the fit's record, export the file, run MuJoCo."""
    from neurofuzzy.pipeline.learners import fit_record

    truth = block_model()
    data = nf.simulate_experiment(truth, dt=1e-3, n_frames=60, external_forces=probe(truth),
                                  substeps="auto", noise=2e-6, seed=1, source="trial.npz")
    start = truth.with_elements(youngs_modulus=truth.elements.youngs_modulus * 0.7)
    learner = nf.GradientLearner(substeps="auto").fit(start, data)
    assert learner.lack_of_fit_.explained
    nf.save_model(learner.model_, tmp_path / "fitted.yaml", fit=fit_record(learner, ["trial.npz"]))

    exported = nf.export(tmp_path / "fitted.yaml", to="mujoco", path=tmp_path / "fitted.xml",
                         experiment=data)
    text = exported.path.read_text()
    timestep = float(re.search(r'timestep="([^"]+)"', text).group(1))
    steps = round(data.dt / timestep)
    assert steps * timestep == pytest.approx(data.dt)
    ours = nf.simulate_like(learner.model_, data, steps)
    theirs = simulate_mujoco(exported.path, data)
    free = truth.mesh.free
    assert rms(theirs, ours, free) < ELEMENT_TOLERANCE
    assert np.abs(ours[:, free] - truth.mesh.rest_positions[free]).max() > 1e-4  # it moved
    assert "lack of fit: explained to the noise" in text


def test_regions_keep_their_materials_as_one_flex_each():
    model = block_model(regions=True)
    data = nf.simulate_experiment(model, dt=1e-3, n_frames=40, external_forces=probe(model, 40),
                                  substeps=4)
    text, notes = _mjcf(model, data, substeps=4)
    flexes = ET.fromstring(text).findall("./deformable/flex")
    assert sorted(f.get("name") for f in flexes) == ["liver", "tumour"]
    tumour = next(f for f in flexes if f.get("name") == "tumour").find("elasticity")
    assert float(tumour.get("young")) == 24000.0 and float(tumour.get("poisson")) == 0.45
    assert float(tumour.get("damping")) == pytest.approx(12.0 / 24000.0)
    assert any("one per region" in note for note in notes)
    theirs = simulate_mujoco(text, data)
    assert rms(theirs, data.positions, model.mesh.free) < ELEMENT_TOLERANCE


def test_the_nodal_form_differs_by_what_the_header_states():
    """MuJoCo runs the textbook element; the export measures the difference to the nodal form
    with our own stepper and says it, and MuJoCo shows exactly that difference."""
    model = block_model("nodal", nu=0.45)
    data = nf.simulate_experiment(model, dt=1e-3, n_frames=60, external_forces=probe(model),
                                  substeps="auto")
    text, notes = _mjcf(model, data)
    stated = float(re.search(r"differ by ([0-9.e+-]+) m RMS", " ".join(notes)).group(1))
    steps = round(data.dt / float(re.search(r'timestep="([^"]+)"', text).group(1)))
    free = model.mesh.free
    theirs = simulate_mujoco(text, data)
    measured = rms(theirs, nf.simulate_like(model, data, steps), free)
    assert measured == pytest.approx(stated, rel=5e-3)          # the header's 3 digits
    element = nf.simulate_like(model.with_elements(volumetric="element"), data, steps)
    assert rms(theirs, element, free) < ELEMENT_TOLERANCE
    assert measured > 10 * ELEMENT_TOLERANCE                     # a real difference at ν 0.45


def test_a_spring_network_runs_as_tendons():
    cube = paper_cube_model()
    data = paper_cube_experiment(cube, n_frames=80)
    text, notes = _mjcf(cube, data, substeps=1)
    root = ET.fromstring(text)
    assert len(root.findall("./tendon/spatial")) == cube.n_springs
    assert root.find("./deformable") is None and notes == []
    theirs = simulate_mujoco(text, data)
    assert rms(theirs, nf.simulate_like(cube, data), cube.mesh.free) < 1e-12


def test_gravity_and_an_inclusion_are_folded_into_the_export():
    model = block_model()
    inclusion = nf.StiffInclusion.of_elements(model, np.arange(12), extra=9000.0)
    model = model.with_effects(nf.Gravity([0.0, 0.0, -9.81]), inclusion)
    data = nf.simulate_experiment(model, dt=1e-3, n_frames=40, substeps=2)
    text, notes = _mjcf(model, data, substeps=2)
    assert 'gravity="0.0 0.0 -9.81"' in text
    assert any("folded into their Young's modulus" in note for note in notes)
    assert rms(simulate_mujoco(text, data), data.positions, model.mesh.free) < ELEMENT_TOLERANCE


def test_more_materials_than_allowed_are_binned_and_said():
    model = block_model()
    rng = np.random.default_rng(0)
    model = model.with_elements(youngs_modulus=rng.uniform(4000, 8000, model.mesh.n_tetrahedra))
    data = nf.simulate_experiment(model, dt=1e-3, n_frames=30, external_forces=probe(model, 30),
                                  substeps=2)
    text, notes = _mjcf(model, data, substeps=2, max_materials=4)
    assert len(ET.fromstring(text).findall("./deformable/flex")) == 4
    merged = next(note for note in notes if "merged into 4 groups" in note)
    assert "108 distinct element materials" in merged
    moved = rms(simulate_mujoco(text, data), data.positions, model.mesh.free)
    assert ELEMENT_TOLERANCE < moved < 0.1 * np.abs(data.positions - data.positions[0]).max()


def test_every_file_says_what_made_it_and_how_well_it_fitted(tmp_path):
    model = block_model(regions=True)
    exported = nf.export(model, to="mujoco", path=tmp_path / "m.xml")
    root = ET.parse(exported.path).getroot()
    block = json.loads(root.find("./custom/text").get("data"))
    assert block["generator"].startswith("neurofuzzy ") and block["lack_of_fit"] == "not recorded"
    assert block["regions"]["tumour"]["youngs_modulus_Pa"] == 24000.0
    assert block["regions"]["liver"]["viscosity_Pa_s"] == 2.0
    text = exported.path.read_text()
    assert "lack of fit: not recorded" in text and "Units: SI" in text
    handle = mujoco.MjModel.from_xml_path(str(exported.path))
    assert handle.nflex == 2 and handle.opt.timestep > 0
    record = {"lack_of_fit": {"rms": 4.1e-5, "noise": 3.5e-5, "ratio": 1.17,
                              "verdict": "explained to the noise (1.17x)"}}
    exported = nf.export(model, to="mujoco", path=tmp_path / "m.xml", fit=record)
    assert "lack of fit: explained to the noise (1.17x) (RMS error 4.1e-05 m per marker" in \
        exported.path.read_text()


def test_mujoco_needs_whole_steps_per_frame(tmp_path):
    cube = paper_cube_model()
    data = paper_cube_experiment(cube, n_frames=10)
    text, _ = _mjcf(cube, data, substeps=1)
    with pytest.raises(InputError, match="not a whole number"):
        simulate_mujoco(text, data.replace(dt=data.dt * 1.5))


def _mjcf(model, experiment, **options):
    from neurofuzzy.export.mujoco import mjcf

    return mjcf(model, experiment=experiment, **options)
