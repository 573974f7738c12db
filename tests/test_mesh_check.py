"""The mesh check: a model refined once (every tetrahedron in eight) keeps its mass, volume,
materials, loads and markers, converges towards the continuum, and widens a fit's intervals by
how far its values move."""

import numpy as np
import pytest
from helpers import cli
from test_markers_embedded import as_recording, element_block, interior_points, record

from neurofuzzy.validation.continuum import ContinuumSolver
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.effects import Gravity
from neurofuzzy.errors import InputError
from neurofuzzy.forces import tetrahedron_geometry
from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.mesh_check import refine_experiment, refine_model
from neurofuzzy.markers import markers_to_experiment
from neurofuzzy.mesh import from_tetra
from neurofuzzy.mesh.refine import refine
from neurofuzzy.model import Model
from neurofuzzy.simulation import simulate


def test_refinement_splits_every_tetrahedron_into_eight_of_the_same_volume():
    points, tetrahedra = kuhn_block((2, 2, 1), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    refined = refine(mesh)
    coarse, fine = tetrahedron_geometry(mesh), tetrahedron_geometry(refined.mesh)
    assert refined.mesh.n_tetrahedra == 8 * mesh.n_tetrahedra
    assert np.all(fine.volume > 0)
    assert np.allclose(np.bincount(refined.parent, fine.volume), coarse.volume)
    assert np.array_equal(refined.mesh.rest_positions[:mesh.n_nodes], mesh.rest_positions)
    # midpoints of edges between two held nodes are held, no others
    held = np.isin(np.arange(refined.mesh.n_nodes), refined.mesh.fixed)
    assert np.array_equal(held[mesh.n_nodes:], np.isin(refined.edge_nodes, mesh.fixed).all(1))
    assert np.allclose(refined.mesh.rest_positions[refined.mesh.fixed][:, 2], 0.0)


def test_a_refined_model_keeps_mass_materials_regions_and_markers():
    model = element_block((2, 2, 2))
    model = model.with_elements(youngs_modulus=np.linspace(5e3, 7e3, model.mesh.n_tetrahedra),
                                law=np.arange(model.mesh.n_tetrahedra) % 2)
    fine, refinement = refine_model(model)
    assert np.array_equal(fine.elements.law, model.elements.law[refinement.parent])
    assert fine.node_mass.sum() == pytest.approx(model.node_mass.sum(), rel=1e-12)
    assert np.array_equal(fine.elements.youngs_modulus,
                          model.elements.youngs_modulus[refinement.parent])
    assert fine.elements.n_ties == model.elements.n_ties
    data, _ = record(model, frames=10)
    nodes, weights = interior_points(model.mesh, 6, seed=2)
    experiment = markers_to_experiment(as_recording(nodes, weights, data), model.mesh,
                                       forces=data.forces_per_frame()).experiment
    moved = refine_experiment(experiment, fine.mesh, refinement)
    rest = np.einsum("mk,mkj->mj", experiment.markers.weights,
                     model.mesh.rest_positions[experiment.markers.nodes])
    again = np.einsum("mk,mkj->mj", moved.markers.weights,
                      fine.mesh.rest_positions[moved.markers.nodes])
    assert np.allclose(rest, again, atol=1e-12)
    assert np.array_equal(moved.forces_per_frame()[:, :model.n_nodes],
                          experiment.forces_per_frame())
    assert not moved.forces_per_frame()[:, model.n_nodes:].any()


def test_refinement_converges_towards_scikit_fems_quadratic_elements():
    """Static sag of a block under its own weight: the refined linear model is closer to
    scikit-fem's quadratic tetrahedra than the coarse one (code nobody here wrote)."""
    points, tetrahedra = kuhn_block((2, 2, 2), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    coarse = Model.continuum(mesh, youngs_modulus=60000.0, poisson_ratio=0.3,
                             viscosity=2.0, density=1000.0, volumetric="element")
    solver = ContinuumSolver(points, tetrahedra, youngs_modulus=60000.0, poisson_ratio=0.3,
                             viscosity=2.0, density=1000.0, fixed=lambda x: x[2] < 1e-9)
    top = np.array([[0.01, 0.01, 0.02]])
    reference = solver.at(solver.static(solver.gravity_load((0.0, 0.0, -9.81))), top)[0, 2]
    errors = []
    for model in (coarse, refine_model(coarse)[0]):
        heavy = model.with_effects(Gravity((0.0, 0.0, -9.81)))
        settled = simulate(heavy, dt=2e-3, n_frames=600, substeps="auto").positions[-1]
        centre = np.argmin(np.linalg.norm(model.mesh.rest_positions - top, axis=1))
        errors.append(abs(settled[centre, 2] - 0.02 - reference))
    assert errors[1] < 0.5 * errors[0] and errors[1] < 0.05 * abs(reference)


def test_the_mesh_check_widens_the_intervals_by_the_move_on_the_refined_mesh():
    truth = element_block((2, 2, 2))
    data, steps = record(truth, frames=30)
    nodes, weights = interior_points(truth.mesh, 20, seed=3)
    experiment = markers_to_experiment(as_recording(nodes, weights, data, noise=2e-6),
                                       truth.mesh, forces=data.forces_per_frame()).experiment
    plain = GradientLearner(substeps=steps, mesh_check=False).fit(truth, experiment)
    assert plain.mesh_check_ is None and plain.intervals_hold_.startswith(
        "the noise alone: no mesh check (mesh_check=False")
    checked = GradientLearner(substeps=steps, mesh_check=True).fit(truth, experiment)
    check = checked.mesh_check_
    assert check.elements == (truth.mesh.n_tetrahedra, 8 * truth.mesh.n_tetrahedra)
    assert np.all(check.change > 0)
    for name, (low, high) in checked.intervals_.items():
        low0, high0 = plain.intervals_[name]
        assert low <= low0 <= high0 <= high
        assert high - low > high0 - low0
    # the data of the coarse model itself: its values lie in the intervals
    values = {"youngs_modulus[all elements]": 6000.0, "poisson_ratio[all elements]": 0.45,
              "viscosity[all elements]": 20.0}
    for name, value in values.items():
        low, high = checked.intervals_[name]
        assert low < value < high
    assert checked.to_dict()["mesh_check"]["refined_elements"] == 8 * truth.mesh.n_tetrahedra
    # two cells of 1 cm: one Gauss-Newton step on the refined mesh moves E too far to be
    # trusted (by a factor of seven, where the refit moves it three times), so it is refitted
    step = GradientLearner(substeps=steps, mesh_check="step").fit(truth, experiment)
    assert "too far to trust" in step.to_dict()["mesh_check"]["how"]
    assert np.allclose(step.mesh_check_.theta_refined, check.theta_refined)
    assert step.intervals_ == checked.intervals_
    # by default the step is kept and said to be untrusted (the refit would cost sixteen
    # fits): the intervals still hold the mesh's move, wider than the noise's
    auto = GradientLearner(substeps=steps).fit(truth, experiment)
    assert "too far to trust" in auto.mesh_check_.how
    assert "mesh_check='refit'" in auto.mesh_check_.how
    assert auto.intervals_hold_.startswith("the noise and the mesh: on the mesh refined once")
    for name, (low, high) in auto.intervals_.items():
        low0, high0 = plain.intervals_[name]
        assert low < low0 <= high0 < high
    # every element its own E, nu and eta (144 parameters): the refit, not 144 refined tangents
    each = GradientLearner(substeps=steps, mesh_check="step", max_iterations=3).fit(
        truth.tied("none"), experiment)
    assert "144 parameters: more than 64 columns" in each.mesh_check_.how
    assert each.mesh_check_.change.shape == (144,)
    # ... and by default none, said plainly
    each = GradientLearner(substeps=steps, max_iterations=3).fit(truth.tied("none"), experiment)
    assert each.mesh_check_ is None
    assert each.intervals_hold_.startswith("the noise alone: a fit of 144 parameters is not "
                                           "checked by default")
    # a fit the check cannot take (learned node masses) is fitted and says why it has none;
    # asked for explicitly, the check refuses
    masses = GradientLearner(substeps=steps, learn_masses=True, max_iterations=3).fit(
        truth, experiment)
    assert masses.mesh_check_ is None and "learned node masses" in masses.intervals_hold_
    with pytest.raises(InputError, match="learned node masses"):
        GradientLearner(substeps=steps, learn_masses=True, max_iterations=3,
                        mesh_check="step").fit(truth, experiment)


def test_the_mesh_check_needs_elements(tmp_path, cube_model, cube_experiment):
    with pytest.raises(InputError, match="mesh check"):
        GradientLearner(mesh_check=True).fit(cube_model, cube_experiment)
    with pytest.raises(InputError, match="'auto', 'step', 'refit' or False"):
        GradientLearner(mesh_check="refined").fit(cube_model, cube_experiment)
    from neurofuzzy.io import save_experiment

    path = save_experiment(cube_experiment, tmp_path / "cube.npz")
    done = cli("fit", path, "--mesh-check")
    assert done.returncode == 2 and "--mesh-check" in done.stderr
    assert "Traceback" not in done.stderr


def test_fit_says_what_its_intervals_hold(tmp_path):
    """By default an element model's intervals hold the noise and the mesh (one Gauss-Newton
    step on the refined mesh), and the text, the report and the JSON say so; with
    ``--no-mesh-check`` they are said to hold the noise alone; ``--mesh-check-refit`` refits
    there."""
    import json

    from neurofuzzy.io import save_experiment, save_model

    truth = element_block((2, 2, 2))
    data, steps = record(truth, frames=20)
    nodes, weights = interior_points(truth.mesh, 20, seed=3)
    experiment = markers_to_experiment(as_recording(nodes, weights, data, noise=2e-6),
                                       truth.mesh, forces=data.forces_per_frame()).experiment
    path = save_experiment(experiment, tmp_path / "block.npz")
    model = save_model(truth.tied("global"), tmp_path / "block.yaml")
    plain = cli("fit", path, "--start", model, "--substeps", str(steps), "--no-mesh-check",
                "--report", tmp_path / "plain.html")
    assert plain.returncode == 0, plain.stderr
    assert "(they hold the noise alone: no mesh check" in plain.stdout
    assert "--no-mesh-check" in plain.stdout
    assert "These intervals hold the noise alone" in (tmp_path / "plain.html").read_text()
    checked = cli("fit", path, "--start", model, "--substeps", str(steps), "--report",
                  tmp_path / "checked.html")
    assert checked.returncode == 0, checked.stderr
    assert ("(they hold the noise and the mesh: on the mesh refined once (384 tetrahedra), "
            "youngs modulus") in checked.stdout
    page = (tmp_path / "checked.html").read_text()
    assert "95 % interval" in page and "hold the noise and the mesh" in page
    assert "one Gauss-Newton step" in page
    summary = json.loads((tmp_path / "checked.json").read_text())
    assert summary["intervals_hold"].startswith("the noise and the mesh")
    refit = cli("fit", path, "--start", model, "--substeps", str(steps), "--mesh-check-refit",
                "--json")
    assert refit.returncode == 0, refit.stderr
    summary = json.loads(refit.stdout)
    assert summary["mesh_check"]["how"].startswith("refit on the mesh")
    assert "twice the change on the refined mesh" in summary["intervals_how"]
    assert summary["intervals_hold"].startswith("the noise and the mesh")
