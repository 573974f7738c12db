"""Markers anywhere in the object: embedded in the tetrahedron that contains them and observed
by barycentric interpolation, through the import, the files, the learner and its exact
gradients."""

import numpy as np
import pytest
from helpers import assert_gradient_exact

from neurofuzzy.datasets import kuhn_block, paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.experiment import rms_error, simulate_experiment
from neurofuzzy.io import load_experiment, save_experiment
from neurofuzzy.markers import MarkerData, markers_to_experiment
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.observation import embed_points
from neurofuzzy.simulation import stability_limit

E, NU, ETA, RHO = 6000.0, 0.45, 20.0, 1000.0


def element_block(shape=(1, 1, 2)):
    points, tetrahedra = kuhn_block(shape, 0.01)
    rng = np.random.default_rng(2)
    inner = np.all((points > 0) & (points < np.array(shape) * 0.01), axis=1)
    points[inner] += rng.uniform(-0.002, 0.002, (inner.sum(), 3))
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=ETA,
                           density=RHO)


def record(truth, frames=40, dt=2e-4):
    """Node trajectories of ``truth`` under a push on its top, and the frame count."""
    top = truth.mesh.rest_positions[:, 2] > truth.mesh.rest_positions[:, 2].max() - 1e-9
    load = np.zeros((truth.n_nodes, 3))
    load[top] = (2e-3, 0.0, -4e-3)
    steps = int(np.ceil(dt / stability_limit(truth).max_step))
    return simulate_experiment(truth, dt=dt, n_frames=frames, external_forces=load,
                               substeps=steps), steps


def interior_points(mesh, n, seed=0):
    """``n`` random points inside the tetrahedra, and their tetrahedra and weights."""
    rng = np.random.default_rng(seed)
    tets = mesh.tetrahedra[rng.integers(0, mesh.n_tetrahedra, n)]
    weights = rng.dirichlet(np.ones(4), n)
    return tets, weights


def as_recording(nodes, weights, data, noise=0.0, seed=1):
    positions = np.einsum("mk,tmkj->tmj", weights, data.positions[:, nodes])
    if noise:
        positions = positions + np.random.default_rng(seed).normal(0, noise, positions.shape)
    return MarkerData(names=tuple(f"M{i}" for i in range(len(nodes))),
                      times=np.arange(data.n_frames) * data.dt, positions=positions,
                      source="markers.csv")


def test_embedding_finds_the_containing_tetrahedron_and_its_weights():
    truth = element_block((2, 2, 2))
    nodes, weights = interior_points(truth.mesh, 50)
    points = np.einsum("mk,mkj->mj", weights, truth.mesh.rest_positions[nodes])
    found_nodes, found_weights, distance = embed_points(truth.mesh, points)
    assert np.all(distance < 1e-12)
    assert np.all(found_weights >= 0) and np.allclose(found_weights.sum(axis=1), 1.0)
    # the same point: the same weights per node (a point on a shared face may pick the
    # neighbour, whose weight on the far corner is then zero)
    rest = truth.mesh.rest_positions
    assert np.allclose(np.einsum("mk,mkj->mj", found_weights, rest[found_nodes]), points,
                       atol=1e-15)
    inside = np.all(weights > 1e-6, axis=1)
    assert np.array_equal(np.sort(found_nodes[inside], axis=1), np.sort(nodes[inside], axis=1))
    # a point 1 mm above the top face goes onto it, 1 mm away
    above = np.array([0.007, 0.012, rest[:, 2].max() + 0.001])
    found_nodes, w, d = embed_points(truth.mesh, above[None])
    assert d[0] == pytest.approx(0.001, rel=1e-6) and np.all(w >= 0)
    assert np.allclose(w[0] @ rest[found_nodes[0]], above - [0, 0, 0.001], atol=1e-9)


def test_import_embeds_markers_and_the_files_keep_them(tmp_path):
    truth = element_block()
    data, _ = record(truth)
    nodes, weights = interior_points(truth.mesh, 12)
    imported = markers_to_experiment(as_recording(nodes, weights, data), truth.mesh,
                                     forces=data.forces_per_frame())
    experiment = imported.experiment
    assert imported.summary["attach"] == "embed" and imported.summary["offset_markers"] == 0
    assert experiment.markers.n_markers == 12 and not experiment.observed.any()
    observation = experiment.observation
    assert np.allclose(observation.frames(data.positions), observation.values, atol=1e-15)
    assert rms_error(truth, experiment, substeps=int(data.dt / stability_limit(truth).max_step)
                     + 1) < 1e-9
    again = load_experiment(save_experiment(experiment, tmp_path / "embedded.npz"))
    assert np.array_equal(again.markers.nodes, experiment.markers.nodes)
    assert np.array_equal(again.markers.weights, experiment.markers.weights)
    assert np.array_equal(again.markers.positions, experiment.markers.positions)
    assert again.markers.names == experiment.markers.names
    # the paper's learner says why it cannot take them; the diagnosis takes them (in
    # trajectory space) and finds nothing missing in clean data of the model itself
    from neurofuzzy import PaperLearner, diagnose

    spring_truth = paper_cube_model()
    spring_data = paper_cube_experiment(spring_truth)
    lattice_markers = markers_to_experiment(
        as_recording(*interior_points(from_tetra(spring_truth.mesh.rest_positions,
                                                 _kuhn(spring_truth)), 5), spring_data),
        spring_truth.mesh, forces=spring_data.forces_per_frame()).experiment
    with pytest.raises(InputError, match="teacher-forces measured node positions"):
        PaperLearner(cycles=1).fit(spring_truth, lattice_markers)
    assert diagnose(spring_truth.tied("global"), lattice_markers).names == ["none"]


def _kuhn(model):
    from neurofuzzy.mesh import lattice_to_tetra

    return lattice_to_tetra(model.mesh).tetrahedra


def test_gradients_through_embedded_markers_are_exact():
    """The observation operator enters the forward sensitivities (H J) and the adjoint's
    seed (Hᵀ r): both equal central differences of the loss."""
    from neurofuzzy.learn import Parameterization, Sensitivity

    truth = element_block()
    data, steps = record(truth, frames=25)
    nodes, weights = interior_points(truth.mesh, 8, seed=3)
    experiment = markers_to_experiment(as_recording(nodes, weights, data, noise=1e-6),
                                       truth.mesh, forces=data.forces_per_frame()).experiment
    start = truth.with_elements(youngs_modulus=np.full(truth.mesh.n_tetrahedra, 1.3 * E),
                                poisson_ratio=np.full(truth.mesh.n_tetrahedra, 0.35))
    parameters = Parameterization(start)
    sensitivity = Sensitivity(parameters, 0.01)
    _, _, run = assert_gradient_exact(sensitivity, parameters.initial(), experiment, steps)
    assert run.residuals.shape == (24, 8, 3)                     # one row per marker


def test_the_learner_recovers_the_material_from_markers_between_nodes():
    from neurofuzzy.learn import GradientLearner

    truth = element_block()
    data, steps = record(truth, frames=40)
    nodes, weights = interior_points(truth.mesh, 10, seed=4)
    experiment = markers_to_experiment(as_recording(nodes, weights, data), truth.mesh,
                                       forces=data.forces_per_frame()).experiment
    start = Model.continuum(truth.mesh, youngs_modulus=3000.0, poisson_ratio=0.3,
                            viscosity=40.0, density=RHO)
    fitted = GradientLearner(substeps=steps).fit(start, experiment).model_
    assert fitted.elements.youngs_modulus == pytest.approx(E, rel=1e-5)
    assert fitted.elements.poisson_ratio == pytest.approx(NU, rel=1e-5)
    assert fitted.elements.viscosity == pytest.approx(ETA, rel=1e-4)


def test_no_frame_zero_bias_and_offsets_only_for_markers_outside():
    """Noise at frame 0 is not turned into a constant bias (the embedded marker is compared
    with its measurement as it is); a marker glued 1.5 mm off the surface carries the offset
    estimated from the frames before the load starts."""
    truth = paper_cube_model()
    load = paper_cube_experiment(truth).forces_per_frame()[:120].copy()
    load[:20] = 0.0                                              # 20 frames at rest first
    data = simulate_experiment(truth, dt=5e-4, n_frames=120, external_forces=load)
    rest = truth.mesh.rest_positions
    surface = [n for n in range(27) if n != 13 and n not in truth.mesh.fixed]
    noise = 20e-6
    recording = as_recording(np.array([[n] * 4 for n in surface]),
                             np.full((len(surface), 4), 0.25), data, noise=noise, seed=5)
    node = markers_to_experiment(recording, truth.mesh, forces=load, attach="node").experiment
    embedded = markers_to_experiment(recording, truth.mesh, forces=load).experiment
    per_coordinate = noise * np.sqrt(3)
    assert rms_error(truth, embedded) == pytest.approx(per_coordinate, rel=0.1)
    assert rms_error(truth, node) > 1.25 * rms_error(truth, embedded)  # frame 0's noise twice

    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    lifted = as_recording(np.array([[n] * 4 for n in top]), np.full((len(top), 4), 0.25),
                          data, noise=noise, seed=6)
    lifted = MarkerData(lifted.names, lifted.times, lifted.positions + [0, 0, 0.0015],
                        source=lifted.source)
    result = markers_to_experiment(lifted, truth.mesh, forces=load)
    assert result.summary["offset_markers"] == len(top) and result.summary["rest_frames"] == 21
    observation = result.experiment.observation
    bias = (observation.values - observation.frames(data.positions))[1:].mean(axis=0)
    assert np.abs(bias).max() < 3 * noise / np.sqrt(21)
    with pytest.raises(InputError, match="outside the mesh"):
        markers_to_experiment(lifted, truth.mesh, forces=load, max_distance=0.001)
