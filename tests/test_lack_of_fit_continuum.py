"""What the toolkit says when its model cannot fit the data: continuum data from a solver
nobody here wrote (scikit-fem's quadratic tetrahedra on 5 mm Kuhn cells), fitted on a mesh a
user would build (7.5 mm voxels, split differently), with 5 µm marker noise, so that the
homogeneous model stays well above the noise from discretisation alone. Slow: each test fits
or diagnoses a 180-node model several times."""

import numpy as np
import pytest

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.learn import GradientLearner, Parameterization
from neurofuzzy.learn.mesh_check import mesh_check
from neurofuzzy.learn.prior import FuzzyPrior
from neurofuzzy.rules import resolve

skfem = pytest.importorskip("skfem")

from neurofuzzy.validation.probed_block import (BLOCK, Inclusion, block_experiment,  # noqa: E402
                                       block_model, probed_block)

PITCH = 0.0075
TRUTH = {"youngs_modulus[all elements]": BLOCK["youngs_modulus"],
         "poisson_ratio[all elements]": 0.45, "viscosity[all elements]": BLOCK["viscosity"]}


@pytest.fixture(scope="module")
def plain():
    start = block_model(pitch=PITCH)
    return start, block_experiment(probed_block(noise=5e-6, seed=3, rest_frames=20, frames=70),
                                   start.mesh)


@pytest.fixture(scope="module")
def inclusion():
    start = block_model(pitch=PITCH)
    return start, block_experiment(probed_block(noise=5e-6, seed=4, inclusion=Inclusion(),
                                                rest_frames=20, frames=70), start.mesh)


@pytest.mark.slow
def test_a_mismatched_mesh_is_said_to_miss_and_its_intervals_hold_the_truth(plain):
    """The homogeneous fit stays above the noise and says so; with the mesh check (one
    Gauss-Newton step on the mesh refined once), the 95 % intervals hold the continuum's E, ν
    and η, and the step says what the refit says: the RMS on the refined mesh within 2 %."""
    start, experiment = plain
    fitted = GradientLearner(substeps="auto", mesh_check="step").fit(start.tied("global"),
                                                                     experiment)
    check = fitted.mesh_check_
    assert "too far" not in check.how and "Gauss-Newton step" in check.how
    parameters = Parameterization(fitted.model_)
    refit = mesh_check(fitted, [experiment], parameters, parameters.initial())
    assert abs(check.rms_refined / refit.rms_refined - 1.0) < 0.02
    moved, moved_refit = check.theta_refined - check.theta, refit.theta_refined - refit.theta
    assert np.all(np.sign(moved) == np.sign(moved_refit))
    assert np.all((np.abs(moved) > 0.6 * np.abs(moved_refit))
                  & (np.abs(moved) < 1.5 * np.abs(moved_refit)))
    assert not fitted.lack_of_fit_.explained and fitted.lack_of_fit_.ratio > 1.4
    assert "misses something" in fitted.lack_of_fit_.verdict
    for name, value in TRUTH.items():
        low, high = fitted.intervals_[name]
        assert low < value < high, (name, low, high)


@pytest.mark.slow
def test_the_diagnosis_of_a_homogeneous_block_says_unexplained_and_blames_the_mesh(plain):
    start, experiment = plain
    result = diagnose(start.tied("global"), experiment)
    assert result.names == ["unexplained"] and result.effects == []
    assert result.mesh["explains"] > 0.5 and result.mesh["ratio"] < result.lack_of_fit.ratio
    assert "nothing in the catalogue explains it" in result.verdict


@pytest.mark.slow
def test_the_prior_finds_no_region_in_a_homogeneous_block(plain):
    start, experiment = plain
    per_element = start.tied("none")
    fitted = GradientLearner(substeps="auto",
                             prior=FuzzyPrior(resolve("liver"), per_element,
                                              tissue="liver")).fit(
        per_element, experiment)
    assert fitted.regions_["regions"] == []
    assert all(entry["evidence"]["kept"] is False for entry in fitted.regions_["rejected"]
               if entry["evidence"]["tested"])


@pytest.mark.slow
def test_a_5x_stiffer_inclusion_is_named_and_located_item_by_item(inclusion):
    """diagnose --localise: the inclusion is named, its centroid within 5 mm of the sphere's,
    and the fit of every element with the prior finds it as one harder region, nothing
    else."""
    start, experiment = inclusion
    centre = np.array(Inclusion().centre)
    model = start.tied("global")
    result = diagnose(model, experiment, max_effects=1,        # the first effect is the test
                      prior=FuzzyPrior(resolve("liver"), model, tissue="liver"), mesh_check=False)
    assert result.names[0] == "stiff_inclusion"
    assert np.linalg.norm(np.array(result.effects[0].centroid) - centre) < 0.005
    regions = result.localisation.regions
    assert len(regions) == 1 and regions[0]["label"] in ("hard", "very_hard")
    assert np.linalg.norm(np.array(regions[0]["centroid"]) - centre) < 0.005
