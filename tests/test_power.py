"""The region test's power (issue 48, item 1): how small a stiff lump the test would keep at
this noise and on this mesh, from a simulated check, and that the check says what the test
itself then does."""

import numpy as np
import pytest

from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.power import LumpCheck, describe_power, detection_limit
from neurofuzzy.learn.region_test import homogeneous_fit, supported_regions

from test_prior import FIRM, block, continuum, load_cases


@pytest.fixture(scope="module")
def homogeneous():
    """A homogeneous block's noisy data (three load cases) and its homogeneous fit."""
    mesh = block((3, 3, 2))
    data, substeps = load_cases(continuum(mesh, FIRM), noise=1e-5, frames=21)
    learner = GradientLearner(substeps=substeps, windows=(), max_iterations=40)
    return mesh, data, substeps, homogeneous_fit(learner, continuum(mesh).tied("none"), data)


def _lump(mesh, fraction, place):
    """The elements nearest ``place`` filling ``fraction`` of the volume (as the check
    builds its lumps)."""
    centroids = mesh.rest_positions[mesh.tetrahedra].mean(axis=1)
    nearest = np.argsort(np.linalg.norm(centroids - place, axis=1))
    return np.sort(nearest[:max(1, round(fraction * mesh.n_tetrahedra))])


def _region_test(mesh, substeps, members, contrast):
    """The region test's verdict on data of the block with ``members`` ``contrast`` times
    stiffer, the lump's own elements given as the one candidate region."""
    modulus = np.full(mesh.n_tetrahedra, FIRM)
    modulus[members] *= contrast
    data, _ = load_cases(continuum(mesh, modulus), noise=1e-5, frames=21)
    learner = GradientLearner(substeps=substeps, windows=(), max_iterations=40)
    fitted = homogeneous_fit(learner, continuum(mesh).tied("none"), data)
    region = {"elements": members.tolist(), "label": "hard", "quantity": "youngs_modulus",
              "size": int(members.size)}
    tested = supported_regions({"regions": [region], "rest": {}}, fitted, data)
    return bool(tested["regions"])


def test_the_power_is_measured_per_size_and_place(homogeneous):
    mesh, data, _, fitted = homogeneous
    power = detection_limit(fitted, data)
    assert power["places"] == 27 and [s["fraction"] for s in power["sizes"]] == [
        0.01, 0.03, 0.08, 0.2]
    # every node tracked, at the noise: a 5x stiffer lump of a few elements shows anywhere
    assert power["smallest"] == 0.01 and all(s["kept"] >= 0.9 * s["of"] for s in power["sizes"])
    elements = [s["elements"] for s in power["sizes"]]
    assert elements == sorted(elements) and elements[-1] >= 0.2 * mesh.n_tetrahedra
    words = describe_power(power)
    assert words.startswith("the region test's power here: a lump 5x stiffer would be kept")
    assert "(the smallest found: 1 % of the volume)" in words
    # a lump 2 % stiffer shows only where it is large and the markers see it well
    faint = detection_limit(fitted, data, contrast=1.02)
    assert [s["kept"] for s in faint["sizes"][:3]] == [0, 0, 0]
    assert 0 < faint["sizes"][3]["kept"] < faint["sizes"][3]["of"]
    assert faint["smallest"] == 0.2
    # and 0.5 % stiffer nowhere
    fainter = detection_limit(fitted, data, contrast=1.005)
    assert fainter["smallest"] is None and all(s["kept"] == 0 for s in fainter["sizes"])
    assert "none up to 20 % of the volume" in describe_power(fainter)


def test_the_check_says_what_the_region_test_then_does(homogeneous):
    """Where the check says a lump is kept, the region test, refitting on data that hold it,
    keeps it; where it says not, the test rejects it."""
    mesh, data, substeps, fitted = homogeneous
    check = LumpCheck(fitted, data)
    members = _lump(mesh, 0.03, mesh.rest_positions.mean(axis=0))
    assert check.kept(members, 5.0) and _region_test(mesh, substeps, members, 5.0)
    assert not check.kept(members, 1.02) and not _region_test(mesh, substeps, members, 1.02)
