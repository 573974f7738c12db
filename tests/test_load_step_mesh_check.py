"""The mesh check of a fit from load steps, on data from a solver nobody here wrote: FElupe's
converged compression of a neo-Hookean gel between bonded plates (``tests/data/plates_nu*``,
:mod:`neurofuzzy.validation.plates`). A coarse block of linear tetrahedra reads the gel as
stiffer than it is, so its E comes out low by far more than its standard error; the mesh
check must see that, widen the intervals to hold the truth, and extrapolate near it."""

from pathlib import Path

import numpy as np
import pytest

from neurofuzzy.learn import load_step_mesh_check as check_module
from neurofuzzy.learn.load_step_fit import fit_load_steps
from neurofuzzy.learn.load_step_mesh_check import refine_load_steps, with_mesh_check
from neurofuzzy.learn.mesh_check import refine_model
from neurofuzzy.load_steps import DrivenPath, LoadSteps
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points

SIZE, E = 0.02, 6000.0
DATA = Path(__file__).parent / "data"


def _lab(nu, cells, load_cell=True, seed=0):
    """The recording at ``nu`` as a lab has it (every scan with 20 µm noise, a load cell
    with 1 %), on a Kuhn block of ``cells``³ started at E 4 kPa, ν 0.3."""
    recorded = np.load(DATA / f"plates_nu{nu}.npz")
    points, tetrahedra = kuhn_block((cells,) * 3, SIZE / cells)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=4000.0, poisson_ratio=0.3, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    rng = np.random.default_rng(seed)
    scans = np.concatenate([recorded["beads"][None],
                            recorded["beads"] + recorded["displacements"]])
    scans = scans + rng.normal(scale=20e-6, size=scans.shape)
    nodes, weights, _ = embed_points(mesh, scans[0])
    force = recorded["force"]
    reaction = force + 0.01 * np.abs(force[:, 2:]) * rng.normal(size=force.shape)
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    plate = DrivenPath(top, np.array([[0, 0, -s * SIZE] for s in recorded["strains"]]))
    data = LoadSteps(mesh, (plate,), EmbeddedMarkers(nodes, weights, scans),
                     reaction if load_cell else None)
    return model, data


@pytest.mark.parametrize("nu", [0.45, 0.499])
def test_the_mesh_check_holds_the_truth_the_noise_misses(nu):
    model, data = _lab(nu, 4)
    fit = fit_load_steps(model, data, validate_on=(3,))
    noise_only = 1.96 * fit.standard_errors_["youngs_modulus"]
    assert abs(fit.youngs_modulus_ - E) > 3 * noise_only     # 4³ cells: 13-17 % low
    checked = with_mesh_check(fit, data, validate_on=(3,))
    assert checked.youngs_modulus_ == fit.youngs_modulus_    # the mesh's value is kept
    values = checked.mesh_check_.values
    assert values["youngs_modulus"]["refined"] > fit.youngs_modulus_
    assert abs(checked.youngs_modulus_ - E) < checked.interval("youngs_modulus")
    # Richardson's extrapolation from the 4³ and 8³ blocks: within 3 % and 0.01 of FElupe's
    assert checked.extrapolated("youngs_modulus") == pytest.approx(E, rel=0.03)
    assert checked.extrapolated("poisson_ratio") == pytest.approx(nu, abs=0.01)
    text = checked.summary()
    assert "the noise and the mesh: on the mesh refined once (3072 tetrahedra)" in text
    assert "extrapolated to a mesh fine enough" in text
    assert "the noise alone" in fit.summary()


@pytest.mark.slow
def test_the_step_is_near_the_refit():
    model, data = _lab(0.499, 4)
    fit = fit_load_steps(model, data, validate_on=(3,))
    step = with_mesh_check(fit, data, validate_on=(3,)).mesh_check_.values
    refit = with_mesh_check(fit, data, how="refit", validate_on=(3,)).mesh_check_.values
    for name, tolerance in (("youngs_modulus", 0.01 * E), ("poisson_ratio", 0.002)):
        assert step[name]["refined"] == pytest.approx(refit[name]["refined"], abs=tolerance)


def test_without_a_force_only_poissons_ratio_moves():
    model, data = _lab(0.49, 3, load_cell=False)
    checked = with_mesh_check(fit_load_steps(model, data), data)
    assert list(checked.mesh_check_.values) == ["poisson_ratio"]
    assert checked.interval("youngs_modulus") is None
    assert checked.extrapolated("youngs_modulus") is None
    assert "not identifiable" in checked.summary()


def test_refined_load_steps_keep_the_plate_whole_and_the_beads_in_place():
    model, data = _lab(0.45, 3)
    fine, refinement = refine_model(model)
    refined = refine_load_steps(data, fine.mesh, refinement)
    plate = np.asarray(refined.driven[0].nodes)
    top = np.flatnonzero(np.isclose(fine.mesh.rest_positions[:, 2], SIZE))
    assert sorted(plate) == sorted(top)                       # every node of the top face
    before = np.einsum("mk,mkj->mj", data.markers.weights,
                       data.mesh.rest_positions[data.markers.nodes])
    after = np.einsum("mk,mkj->mj", refined.markers.weights,
                      fine.mesh.rest_positions[refined.markers.nodes])
    np.testing.assert_allclose(after, before, atol=1e-12)
    bottom = np.flatnonzero(np.isclose(fine.mesh.rest_positions[:, 2], 0.0))
    assert set(bottom) <= set(np.asarray(fine.mesh.fixed).tolist())


def test_auto_leaves_a_large_mesh_unchecked_and_says_why(monkeypatch):
    model, data = _lab(0.45, 3)
    fit = fit_load_steps(model, data)
    monkeypatch.setattr(check_module, "AUTO_TETRAHEDRA", 1000)
    skipped = with_mesh_check(fit, data, how="auto")
    assert skipped.mesh_check_ is None
    assert "1296 tetrahedra, more than the 1000" in skipped.intervals_hold
    assert skipped.interval("youngs_modulus") == pytest.approx(
        1.96 * fit.standard_errors_["youngs_modulus"])
    with pytest.raises(Exception, match="expected 'auto' or one of"):
        with_mesh_check(fit, data, how="finer")
