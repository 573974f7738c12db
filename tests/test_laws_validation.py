"""The material laws against data of a solver nobody here wrote: sfepy's total-Lagrangian
neo-Hookean block (quadratic tetrahedra on 5 mm Kuhn cells, 20 µm marker noise), stored in
``tests/data`` by :func:`neurofuzzy.validation.nonlinear.recordings.store`, fitted on 7.5 mm
voxels split six to a cube (not the reference's mesh). ``benchmarks/laws.py`` measures the same
on finer meshes and runs the whole diagnosis (the README's table)."""

from pathlib import Path

import numpy as np
import pytest

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.diagnosis.candidates import propose_candidates
from neurofuzzy.diagnosis.loop import MIN_SHRINK, gap
from neurofuzzy.diagnosis.refits import confirm, refit_candidate, to_refit
from neurofuzzy.diagnosis.trajectory import TrajectoryEvidence
from neurofuzzy.learn import GradientLearner
from neurofuzzy.validation.nonlinear.recordings import stored
from neurofuzzy.validation.probed_block import (BLOCK, block_experiment, block_model,
                                               graded_block)

DATA = Path(__file__).parent / "data"


def _moduli(model, recording):
    """Errors of E and μ (relative) and ν (absolute) of a globally tied element model."""
    E, nu = float(model.elements.youngs_modulus[0]), float(model.elements.poisson_ratio[0])
    return {"E": E / recording.truth["youngs_modulus"] - 1,
            "mu": E / (2 * (1 + nu)) / recording.truth["shear_modulus"] - 1,
            "nu": nu - recording.truth["poisson_ratio"]}


@pytest.fixture(scope="module")
def start():
    return block_model(pitch=0.0075).tied("global")


def test_the_stored_recordings_are_the_probed_block_at_large_and_small_strain():
    large = stored(DATA / "neo_hookean_block_large_strain.npz")
    small = stored(DATA / "neo_hookean_block_small_strain.npz")
    assert large.truth["solver"] == "sfepy" and large.truth["law"] == "neo-Hookean"
    assert 0.3 < large.truth["compressive_strain_peak"] < 0.4
    assert 0.04 < small.truth["compressive_strain_peak"] < 0.07
    at_rest = large.markers.positions[:large.touch] - large.rest_points
    assert np.std(at_rest) == pytest.approx(large.truth["noise"], rel=0.05)


def test_the_graded_block_is_fine_under_the_probe_and_coarse_elsewhere():
    """The graded mesh of the probe benchmark: conforming Kuhn cells filling the block
    (volumes sum to it, none inverted), ``fine`` wide within 1 cm of the probe in x and y and
    in the top centimetre, never wider than 5 mm, and a start model of it with the bottom held."""
    from neurofuzzy.forces import tetrahedron_geometry
    from neurofuzzy.mesh import from_tetra

    points, tetrahedra = graded_block(0.0025)
    mesh = from_tetra(points, tetrahedra)
    volume = tetrahedron_geometry(mesh).volume
    assert volume.min() > 0 and volume.sum() == pytest.approx(np.prod(BLOCK["size"]))
    for axis, (low, high) in enumerate(((0.01, 0.03), (0.01, 0.03), (0.02, 0.03))):
        coordinates = np.unique(points[:, axis])
        widths, middle = np.diff(coordinates), coordinates[:-1]
        inside = (middle >= low - 1e-12) & (middle < high - 1e-12)
        assert np.allclose(widths[inside], 0.0025) and widths.max() <= 0.005 + 1e-12
        assert widths[~inside].min() > 0.0025
    model = block_model(graded=0.0025)
    assert model.mesh.n_tetrahedra == len(tetrahedra)
    assert np.all(model.mesh.rest_positions[model.mesh.fixed, 2] < 1e-9)
    assert (~model.mesh.free).sum() == len(np.unique(points[:, 0])) ** 2


@pytest.mark.slow
def test_at_large_strain_the_diagnosis_switches_to_neo_hookean_which_recovers_the_moduli(start):
    """27–35 % compression under the probe. SVK buys stiffness (E 40 % too high) and misses
    the data by far; the diagnosis' evidence puts ``hyperelasticity`` among the candidates it
    refits, and its refit, confirmed at two steps (what ``diagnose`` does when it wins: the
    elements become neo-Hookean, no effect is added) recovers the shear modulus within 3 %
    and E within 6 % (ν 0.06 low: the coarse mesh's share, see the README table) and shrinks
    the gap above the noise by more than the diagnosis asks (``MIN_SHRINK``). (The whole
    ``diagnose`` refits five candidates; ``benchmarks/laws.py`` runs it: hyperelasticity
    wins.)"""
    recording = stored(DATA / "neo_hookean_block_large_strain.npz")
    experiment = block_experiment(recording, start.mesh)
    svk = GradientLearner(substeps="auto").fit(start, experiment)
    verdict = svk.lack_of_fit_
    assert not verdict.explained and _moduli(svk.model_, recording)["E"] > 0.4
    evidence = TrajectoryEvidence.of(svk.model_, [experiment], svk.substeps_,
                                     verdict.noise_per_coordinate)
    ranked = evidence.score(propose_candidates(svk.model_, evidence))
    tried = to_refit(ranked, evidence, verdict, svk.rms_error_, lambda message: None)
    candidate = next(c for c in tried if c.name == "hyperelasticity")
    neo = confirm(refit_candidate(candidate, svk.model_, evidence, [experiment], "auto",
                                  staged=False), [experiment])
    assert set(neo.model_.elements.law) == {1} and not neo.model_.effects
    moduli = _moduli(neo.model_, recording)
    assert abs(moduli["mu"]) < 0.03 and abs(moduli["E"]) < 0.06 and abs(moduli["nu"]) < 0.08
    assert neo.lack_of_fit_.ratio < 0.5 * verdict.ratio
    assert gap(svk.rms_error_, verdict.noise) > MIN_SHRINK * gap(neo.rms_error_, verdict.noise)


@pytest.mark.slow
def test_at_small_strain_the_diagnosis_keeps_svk(start):
    """4–5 % compression: the SVK start's diagnosis names no law (the misfit it leaves, 1.3
    times the noise on this coarse mesh, is the mesh's) and its elements stay SVK."""
    recording = stored(DATA / "neo_hookean_block_small_strain.npz")
    result = diagnose(start, block_experiment(recording, start.mesh), mesh_check=False,
                      max_effects=1)
    assert "hyperelasticity" not in result.names
    assert set(result.model_.elements.law) == {0}
    assert result.lack_of_fit.ratio < 1.6


@pytest.mark.slow
def test_on_yeoh_data_yeoh_s_law_fits_best_and_is_the_stiffening_candidate(start):
    """sfepy's uncoupled Yeoh block (C20 = C10) pressed by 0.7 N (25 % compression at the
    peak), on the 7.5 mm voxels: Yeoh's elements recover E within 7 % and fit the markers
    better than neo-Hookean, which fits them far better than SVK (measured 5.9, 6.6 and 12.0
    times the noise; C20/C10 comes out 1.6 on this coarse mesh, 1.17 on 3.3 mm voxels: see
    docs/material-laws.md). From the neo-Hookean fit the diagnosis' evidence offers
    ``nonlinear_stiffening`` as the switch to Yeoh's law, and its refit is the Yeoh fit."""
    recording = stored(DATA / "stiffening_block.npz")
    assert recording.truth["law"] == "Yeoh" and recording.truth["c20"] == recording.truth["c10"]
    experiment = block_experiment(recording, start.mesh)
    fits = {law: GradientLearner(substeps="auto").fit(
                start.with_elements(law=law), experiment)
            for law in ("st-venant-kirchhoff", "neo-hookean", "yeoh")}
    ratios = {law: fit.lack_of_fit_.ratio for law, fit in fits.items()}
    assert ratios["yeoh"] < ratios["neo-hookean"] < 0.7 * ratios["st-venant-kirchhoff"]
    yeoh = fits["yeoh"].model_
    assert abs(_moduli(yeoh, recording)["E"]) < 0.07
    assert 1.0 < yeoh.elements.stiffening[0] < 2.0
    neo = fits["neo-hookean"]
    evidence = TrajectoryEvidence.of(neo.model_, [experiment], neo.substeps_,
                                     neo.lack_of_fit_.noise_per_coordinate)
    offered = [c.name for c in propose_candidates(neo.model_, evidence)]
    assert "nonlinear_stiffening" in offered and "hyperelasticity" not in offered
