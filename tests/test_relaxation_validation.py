"""Relaxation against data of a solver nobody here wrote: sfepy's neo-Hookean block with one
Prony term (FEBio's convention: g = 0.5 of the long-term E = 6 kPa, τ = 50 ms; quadratic
tetrahedra on 5 mm Kuhn cells, Newmark, Kelvin–Voigt η = 2 Pa·s), pressed by the probe with a
held 0.12 N (4 % strain) for 0.3 s and recorded with 20 µm marker noise; stored in
``tests/data/relaxing_block.npz`` (``nonlinear_reference.recordings.relaxing_block(frames=301)``)
and fitted on voxel meshes split six to a cube (not the reference's mesh)."""

from pathlib import Path

import numpy as np
import pytest

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.learn import GradientLearner
from neurofuzzy.validation.nonlinear.recordings import stored
from neurofuzzy.validation.probed_block import block_experiment, block_model

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def recording():
    return stored(DATA / "relaxing_block.npz")


def test_the_stored_recording_relaxes(recording):
    assert recording.truth["prony"] == {"relative_moduli": [0.5], "times": [0.05]}
    assert recording.truth["solver"] == "sfepy" and recording.markers.positions.shape[0] == 331
    assert 0.03 < recording.truth["compressive_strain_peak"] < 0.06


@pytest.mark.slow
def test_a_prony_term_recovers_the_relaxation_where_kelvin_voigt_buys_stiffness(recording):
    """Without relaxation the fit buys the creep with E about 50 % too high and η about twice
    the truth (7.5 mm voxels; the words would say "hard" and "high"); with one Prony term
    (5 mm voxels, the default SVK elements, started at g = 0.5, τ = 60 ms) it recovers E
    within 6 % (measured +4.9 %: SVK against neo-Hookean data), ν within 0.03, g within 0.06
    (measured 0.451) and τ within 15 % (measured +3.6 %), and meets the data at about the
    noise (1.04 times; ``benchmarks/relaxation.py`` has the whole table)."""
    truth = recording.truth
    coarse = block_model(pitch=0.0075).tied("global")
    # the values are the test, not their intervals: no mesh check (on the 5 mm mesh with
    # relaxation its step took 50 s alone, the fit 38 s)
    plain = GradientLearner(substeps="auto", mesh_check=False).fit(
        coarse, block_experiment(recording, coarse.mesh))
    assert plain.model_.elements.youngs_modulus[0] > 1.3 * truth["youngs_modulus"]
    assert plain.model_.elements.viscosity[0] > 1.5 * truth["viscosity"]
    start = block_model(pitch=0.005).tied("global").with_elements(
        relaxation_moduli=[0.5], relaxation_times=[0.06])
    fitted = GradientLearner(substeps="auto", mesh_check=False).fit(
        start, block_experiment(recording, start.mesh))
    model = fitted.model_
    assert model.elements.youngs_modulus[0] == pytest.approx(truth["youngs_modulus"], rel=0.06)
    assert abs(model.elements.poisson_ratio[0] - truth["poisson_ratio"]) < 0.03
    assert model.elements.relaxation_moduli[0, 0] == pytest.approx(0.5, abs=0.06)
    assert model.elements.relaxation_times[0, 0] == pytest.approx(0.05, rel=0.15)
    assert fitted.lack_of_fit_.ratio < 1.1 < plain.lack_of_fit_.ratio


@pytest.mark.slow
def test_the_diagnosis_names_relaxation_and_the_gap_shrinks(recording):
    """7.5 mm voxels: the diagnosis of the plain start names ``relaxation``, gives the elements
    a Prony term (no effect added) and shrinks the gap above the noise."""
    start = block_model(pitch=0.0075).tied("global")
    result = diagnose(start, block_experiment(recording, start.mesh), mesh_check=False,
                      max_effects=1)
    assert result.names == ["relaxation"]
    assert result.model_.n_relaxation_terms == 1 and not result.model_.effects
    assert result.rms_after < result.rms_before
    g, tau = (float(result.model_.elements.relaxation_moduli[0, 0]),
              float(result.model_.elements.relaxation_times[0, 0]))
    assert 0.3 < g < 0.7 and 0.035 < tau < 0.07
    assert np.isfinite(result.rms_after)
