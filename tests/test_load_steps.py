"""Load steps (scans of a specimen between plates at a few compressions) and the fit of E and
ν from them: what the data identify, what they cannot, registration of the scans, held-out
steps, and data from scikit-fem's quadratic tetrahedra that our linear ones cannot fit
exactly."""

import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.learn.load_step_fit import fit_load_steps
from neurofuzzy.load_steps import DrivenPath, LoadSteps, simulate_load_steps
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points

SIZE = 0.02
E, NU = 6000.0, 0.45
STRAINS = (0.05, 0.125, 0.18)


def _mesh(cells=3):
    points, tetrahedra = kuhn_block((cells,) * 3, SIZE / cells)
    return from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)


def _top(mesh):
    return np.flatnonzero(np.isclose(mesh.rest_positions[:, 2], SIZE))


def _plate(mesh, strains=STRAINS):
    return DrivenPath(_top(mesh), np.array([[0.0, 0.0, -s * SIZE] for s in strains]),
                      name="top plate")


def _markers(mesh, n=60, steps=len(STRAINS), seed=1):
    points = np.random.default_rng(seed).uniform(0.1 * SIZE, 0.9 * SIZE, size=(n, 3))
    nodes, weights, _ = embed_points(mesh, points)
    return EmbeddedMarkers(nodes, weights, np.zeros((steps + 1, n, 3)))


def _start(mesh):
    return Model.continuum(mesh, youngs_modulus=3000.0, poisson_ratio=0.3, viscosity=1.0,
                           density=1000.0, law="neo-hookean")


@pytest.fixture(scope="module")
def gel():
    """A neo-Hookean gel (E 6 kPa, ν 0.45) compressed 5 / 12.5 / 18 % between bonded
    plates, 60 embedded markers with 20 µm noise, a load cell with 1 mN noise."""
    mesh = _mesh()
    truth = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    return simulate_load_steps(truth, [_plate(mesh)], _markers(mesh), marker_noise=20e-6,
                               force_noise=1e-3, seed=3)


def _without_force(data):
    return LoadSteps(data.mesh, data.driven, data.markers, None, data.truth)


def test_without_a_force_poisson_is_found_and_youngs_modulus_is_said_unidentifiable(gel):
    fit = fit_load_steps(_start(gel.mesh), _without_force(gel), validate_on=[3])
    assert fit.poisson_ratio_ == pytest.approx(NU, abs=0.01)
    assert fit.unidentifiable_ == ("youngs_modulus", "viscosity", "density")
    assert fit.youngs_modulus_ == pytest.approx(3000.0)          # kept, not made up
    assert "youngs_modulus" not in fit.standard_errors_
    assert "not identifiable" in fit.summary() and "load cell" in " ".join(fit.notes_)
    # the held-out deepest step is predicted to the noise (markers: √3 σ per marker)
    assert fit.validation_["steps"] == [3]
    assert fit.validation_["rms_error"] < 1.2 * np.sqrt(3) * 20e-6
    assert fit.marker_noise_ == pytest.approx(20e-6, rel=0.25)


def test_with_a_load_cell_youngs_modulus_is_found_too(gel):
    fit = fit_load_steps(_start(gel.mesh), gel)
    assert fit.unidentifiable_ == ("viscosity", "density")
    assert fit.youngs_modulus_ == pytest.approx(E, rel=0.03)
    assert fit.poisson_ratio_ == pytest.approx(NU, abs=0.01)
    # the interval holds the truth and is not vacuous
    half = 1.96 * fit.standard_errors_["youngs_modulus"]
    assert abs(fit.youngs_modulus_ - E) <= half < 0.05 * E
    assert fit.force_noise_ == pytest.approx(1e-3, rel=0.6)


def test_nf_fit_fits_load_steps_as_the_command_does(gel, tmp_path):
    """``nf.fit`` is the one fit of Python for lab experiments too: load steps (an object or
    a file) go to the command's load-step fit, with its record; the learners' options that
    mean nothing there are refused by name, and a lab experiment beside others."""
    import neurofuzzy as nf
    from neurofuzzy.io import save_load_steps, save_model
    from neurofuzzy.pipeline.load_steps import LoadStepOutcome, fit_load_step_file

    start = save_model(_start(gel.mesh), tmp_path / "start.yaml")
    outcome = nf.fit(gel, start=start, validate_on=[3], mesh_check=False)
    assert isinstance(outcome, LoadStepOutcome) and outcome.record["kind"] == "load steps"
    assert outcome.record["youngs_modulus"] == pytest.approx(E, rel=0.03)
    assert outcome.record["validation"]["steps"] == [3]
    path = save_load_steps(gel, tmp_path / "steps.npz")
    direct = fit_load_step_file(path, start=start, validate_on=[3], mesh_check=False)
    assert nf.fit(path, start=start, validate_on=[3], mesh_check=False).record[
        "youngs_modulus"] == pytest.approx(direct.record["youngs_modulus"], rel=1e-9)
    for keywords, name in (({"tie": "global"}, "tie"), ({"cycles": 3}, "cycles"),
                           ({"method": "paper"}, "method"), ({"substeps": 2}, "substeps"),
                           ({"validate_on": 0.5}, "validate_on")):
        with pytest.raises(InputError, match=name):
            nf.fit(gel, start=start, **keywords)
    with pytest.raises(InputError, match="fitted on its own"):
        nf.fit([gel, gel], start=start)
    # and the diagnosis from data: the time series' options refused by name, before any work
    for keywords, name in (({"localise": True}, "localise"), ({"max_time": 5.0}, "max_time"),
                           ({"window": 40}, "window"), ({"substeps": 2}, "substeps")):
        with pytest.raises(InputError, match=f"^{name}: "):
            nf.diagnose_data(gel, start=start, **keywords)


def test_scans_out_of_register_are_registered_per_step(gel):
    """Each scan moved by its own rigid transform (a few degrees, a millimetre): with the
    registration the fit is as good as on registered scans; without it, it is not."""
    rng = np.random.default_rng(7)
    scans = gel.markers.positions.copy()
    for k in range(1, len(scans)):
        angle = np.radians(rng.uniform(-3, 3, 3))
        cx, cy, cz = np.cos(angle)
        sx, sy, sz = np.sin(angle)
        R = (np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
             @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
             @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]))
        scans[k] = scans[k] @ R.T + rng.uniform(-1e-3, 1e-3, 3)
    moved = LoadSteps(gel.mesh, gel.driven, EmbeddedMarkers(
        gel.markers.nodes, gel.markers.weights, scans), None)
    registered = fit_load_steps(_start(gel.mesh), moved)
    assert registered.poisson_ratio_ == pytest.approx(NU, abs=0.01)
    assert registered.marker_rms_ < 1.3 * np.sqrt(3) * 20e-6
    assert not np.allclose(registered.registration_[1], np.eye(4), atol=1e-4)
    plain = fit_load_steps(_start(gel.mesh), moved, register=False, max_iterations=5)
    assert plain.marker_rms_ > 10 * registered.marker_rms_
    # the registration's freedom is in the Jacobian (variable projection): as few iterations
    # as the scans in register take, to the same ν (alternating, it crept on for 20 or more)
    aligned = fit_load_steps(_start(gel.mesh), _without_force(gel), register=False)
    assert registered.iterations_ <= aligned.iterations_ + 2
    assert registered.poisson_ratio_ == pytest.approx(aligned.poisson_ratio_, abs=2e-4)


def test_what_the_registration_follows_is_taken_out_of_the_markers_derivative():
    """``beyond_rigid``: a rigid motion of the markers leaves nothing; what it leaves of any
    change is orthogonal to every rigid motion, and taken out twice is taken out once."""
    from neurofuzzy.learn._load_step_noise import beyond_rigid

    rng = np.random.default_rng(2)
    points = rng.uniform(0, 0.02, size=(12, 3))
    spin, shift = rng.normal(size=3), rng.normal(size=3)
    rigid = shift + np.cross(spin, points - points.mean(axis=0))
    np.testing.assert_allclose(beyond_rigid(points, rigid), 0.0, atol=1e-12)
    change = rng.normal(size=(2, 12, 3))
    left = beyond_rigid(points, change)
    np.testing.assert_allclose(beyond_rigid(points, left), left, atol=1e-12)
    for motion in (np.tile(np.eye(3)[1], (12, 1)), np.cross(spin, points - 0.01)):
        np.testing.assert_allclose(np.einsum("kij,ij->k", left, motion), 0.0, atol=1e-12)


def test_bad_load_steps_are_refused_with_what_is_wrong():
    mesh = _mesh(2)
    markers = _markers(mesh, n=5)
    with pytest.raises(InputError, match=r"3 load steps, so expected \(3, 3\)"):
        LoadSteps(mesh, (_plate(mesh, (0.1, 0.2)),), markers)
    with pytest.raises(InputError, match="overlaps the fixed nodes"):
        LoadSteps(mesh, (DrivenPath(mesh.fixed, np.zeros((3, 3))),), markers)
    with pytest.raises(InputError, match="empty"):
        LoadSteps(mesh, (DrivenPath(np.array([], int), np.zeros((3, 3))),), markers)
    with pytest.raises(InputError, match="DrivenPath"):
        LoadSteps(mesh, (), markers)
    with pytest.raises(InputError, match="one force per load step"):
        LoadSteps(mesh, (_plate(mesh),), markers, reaction=np.zeros((2, 3)))
    data = LoadSteps(mesh, (_plate(mesh),), markers)
    with pytest.raises(InputError, match="validate_on"):
        fit_load_steps(_start(mesh), data, validate_on=[1, 2, 3])
    with pytest.raises(InputError, match="validate_on"):
        fit_load_steps(_start(mesh), data, validate_on=[4])


@pytest.mark.slow
@pytest.mark.parametrize("nu, tolerance", [(0.45, 0.01), (0.499, 0.02)])
def test_data_from_scikit_fems_quadratic_tetrahedra(nu, tolerance):
    """Bonded compression of 0.5 / 1 / 1.5 % computed by scikit-fem (quadratic tetrahedra,
    linear elasticity), 343 markers with 2 µm noise and a load cell with 1 % noise, fitted
    with our linear tetrahedra (the nodal volumetric form) on the same 4³ cells: what the
    other discretisation leaves is absorbed by E (a few per cent) and ν (within the
    tolerance), and the held-out step is predicted within 1.6x the noise."""
    from neurofuzzy.validation.continuum import ContinuumSolver

    rng = np.random.default_rng(0)
    points, tetrahedra = kuhn_block((4,) * 3, SIZE / 4)
    solver = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=nu,
                             viscosity=1.0, density=1000.0, fixed=lambda x: x[2] < 1e-9)
    marker_points = rng.uniform(0.1 * SIZE, 0.9 * SIZE, size=(343, 3))
    strains = (0.005, 0.01, 0.015)
    scans, forces = [marker_points], []
    for strain in strains:
        u, force = solver.displaced(lambda x: x[2] > SIZE - 1e-9, (0, 0, -strain * SIZE))
        scans.append(marker_points + solver.at(u, marker_points))
        forces.append(force)
    scans = np.array(scans)
    scans[1:] += rng.normal(scale=2e-6, size=scans[1:].shape)
    forces = np.array(forces) * (1 + 0.01 * rng.normal(size=(len(strains), 3)))
    mesh = _mesh(4)
    nodes, weights, _ = embed_points(mesh, marker_points)
    data = LoadSteps(mesh, (_plate(mesh, strains),), EmbeddedMarkers(nodes, weights, scans),
                     forces)
    fit = fit_load_steps(_start(mesh).with_elements(law="st-venant-kirchhoff"), data,
                         validate_on=[3])
    assert fit.poisson_ratio_ == pytest.approx(nu, abs=tolerance)
    assert fit.youngs_modulus_ == pytest.approx(E, rel=0.1)
    assert fit.validation_["rms_error"] < 1.6 * fit.marker_scale


def test_the_equilibriums_sensitivities_are_its_central_differences(gel):
    """The fit's Jacobian (markers and the load cell's force by log E and ν's logit, from
    K_ff⁻¹ ∂F/∂θ with ∂F/∂θ from the force per unit 2μ and λ) against central differences
    of the solved equilibria."""
    from neurofuzzy.learn.load_step_fit import _forward

    model = _start(gel.mesh)
    theta = np.array([np.log(5000.0), np.log(0.4 / 0.1)])
    _, markers, reactions, d_markers, d_reactions, *_ = _forward(model, gel, theta,
                                                                 [1, 2, 3], True)
    eps = 1e-5
    for j in range(2):
        step = np.zeros(2)
        step[j] = eps
        plus = _forward(model, gel, theta + step, [1, 2, 3], False)
        minus = _forward(model, gel, theta - step, [1, 2, 3], False)
        for k in range(3):
            difference = (plus[1][k] - minus[1][k]) / (2 * eps)
            assert np.abs(d_markers[k][j] - difference).max() <= 1e-5 * np.abs(
                difference).max() + 1e-12
            difference = (plus[2][k] - minus[2][k]) / (2 * eps)
            assert np.abs(d_reactions[k][j] - difference).max() <= 1e-5 * np.abs(
                difference).max() + 1e-12
    assert np.abs(d_markers[2][0]).max() < 1e-9 * np.abs(d_markers[2][1]).max()   # E: none


@pytest.mark.slow
@pytest.mark.parametrize("plate, answer", [("z", ["plate_slip", "hyperelasticity (neo-hookean)"]),
                                           ("xyz", ["hyperelasticity (neo-hookean)"])])
def test_the_diagnosis_names_plate_slip_and_the_law(plate, answer):
    """A neo-Hookean gel compressed to 18 % on a plate it slides on (or is bonded to),
    started as bonded St. Venant–Kirchhoff: the diagnosis names what the set-up's model
    lacks and the misfit falls to the noise; it names nothing that is not there."""
    from neurofuzzy.diagnosis import diagnose_data

    mesh = _mesh()
    truth = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    path = _plate(mesh)
    data = simulate_load_steps(truth, [DrivenPath(path.nodes, path.displacement, plate)],
                               _markers(mesh), marker_noise=20e-6, force_noise=1e-3, seed=3)
    bonded = LoadSteps(mesh, (DrivenPath(path.nodes, path.displacement, "xyz"),),
                       data.markers, data.reaction)
    start = _start(mesh).with_elements(law="st-venant-kirchhoff")
    result = diagnose_data(bonded, start=start)        # the command's route to the diagnosis
    assert result.names == answer
    assert result.after.marker_rms_ < 1.2 * np.sqrt(3) * 20e-6 < result.before.marker_rms_
    assert result.to_dict()["plate"] == plate and result.to_dict()["law"] == "neo-hookean"
    assert result.after.youngs_modulus_ == pytest.approx(E, rel=0.03)


def test_a_force_curve_alone_fits_youngs_modulus_with_poisson_held(gel):
    """No scans, only the load cell: E is fitted with ν held at the start's (said so), and
    it is right when that ν is the tissue's; a wrong ν biases E, which is why it is said."""
    data = LoadSteps(gel.mesh, gel.driven, None, gel.reaction)
    start = _start(gel.mesh).with_elements(poisson_ratio=NU)
    fit = fit_load_steps(start, data)
    assert fit.fixed_ == ("poisson_ratio",) and fit.poisson_ratio_ == pytest.approx(NU)
    assert fit.youngs_modulus_ == pytest.approx(E, rel=0.03)
    assert fit.marker_rms_ is None and "fixed" in fit.summary()
    assert any("no markers" in note for note in fit.notes_)
    wrong = fit_load_steps(_start(gel.mesh), data)            # ν 0.3 for the gel's 0.45
    assert abs(wrong.youngs_modulus_ / E - 1) > 0.03
    with pytest.raises(InputError, match="nothing to fit"):
        LoadSteps(gel.mesh, gel.driven, None, None)


def test_a_noisy_reference_scan_is_estimated_with_reference_noise(gel):
    """A lab's reference scan is as noisy as the others and the markers are embedded where it
    saw them, so a perfect model's residuals carry the noise twice (√2 σ). With
    ``reference_noise`` each marker's rest point is estimated from every fitted scan: the
    fitted residual falls to √(S/(S+1)) of the noise (S = 2 fitted steps) and the held-out
    step is predicted to √(1 + 1/(S+1)) ≈ 1.15 of it, ν unchanged."""
    rng = np.random.default_rng(7)
    scans = gel.markers.positions.copy()
    scans[0] += rng.normal(scale=20e-6, size=scans[0].shape)
    nodes, weights, _ = embed_points(gel.mesh, scans[0])         # as 'import' embeds them
    data = LoadSteps(gel.mesh, gel.driven, EmbeddedMarkers(nodes, weights, scans), None)
    plain = fit_load_steps(_start(gel.mesh), data, marker_noise=20e-6, validate_on=[3])
    refined = fit_load_steps(_start(gel.mesh), data, marker_noise=20e-6, validate_on=[3],
                             reference_noise=True)
    ratio = {name: (fit.marker_rms_ / fit.marker_scale,
                    fit.validation_["rms_error"] / fit.marker_scale)
             for name, fit in (("plain", plain), ("refined", refined))}
    assert ratio["plain"][0] > 1.2 and ratio["plain"][1] > ratio["refined"][1] + 0.05
    assert 0.7 < ratio["refined"][0] < 0.95 and ratio["refined"][1] < 1.25
    assert refined.poisson_ratio_ == pytest.approx(NU, abs=0.01)
    # the model's markers are the predictions from the estimated rest points
    moved = refined.registered_ - refined.markers_
    assert np.sqrt(np.mean(np.sum(moved[:2] ** 2, -1))) == pytest.approx(refined.marker_rms_)


def test_markers_on_a_tilted_plate_drive_the_boundary_they_saw():
    """The stage's plate tilted as it pressed (its top face's nodes moved unevenly): a model
    of a level plate misses the scans, while the top face driven along the markers that sat
    on it (measured boundary data) fits them and finds ν."""
    mesh = _mesh()
    truth = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    top = _top(mesh)
    x = mesh.rest_positions[top, 0] / SIZE
    tilted = [DrivenPath(np.array([node]), np.array([[0.0, 0.0, -s * SIZE * (0.6 + 0.8 * xi)]
                                                     for s in STRAINS]), name=f"n{node}")
              for node, xi in zip(top, x)]
    inside = _markers(mesh)
    on_top = EmbeddedMarkers(np.repeat(top[:, None], 4, axis=1),
                             np.tile([1.0, 0.0, 0.0, 0.0], (len(top), 1)),
                             np.zeros((len(STRAINS) + 1, len(top), 3)))
    both = EmbeddedMarkers(np.vstack([inside.nodes, on_top.nodes]),
                           np.vstack([inside.weights, on_top.weights]),
                           np.zeros((len(STRAINS) + 1, 60 + len(top), 3)),
                           tuple(f"bead{i}" for i in range(60))
                           + tuple(f"top{i}" for i in range(len(top))))
    data = simulate_load_steps(truth, tilted, both, marker_noise=20e-6, load_cell=False,
                               seed=4)
    level = LoadSteps(mesh, (_plate(mesh),), data.markers)
    driven = level.drive_markers([f"top{i}" for i in range(len(top))], replace=True)
    assert len(driven.driven) == len(top) and driven.markers.positions.shape[1] == 60
    assert np.allclose(driven.driven[-1].displacement,
                       data.markers.positions[1:, -1] - data.markers.positions[0, -1])
    wrong = fit_load_steps(_start(mesh), level, marker_noise=20e-6)
    right = fit_load_steps(_start(mesh), driven, marker_noise=20e-6)
    assert right.marker_rms_ < 1.3 * right.marker_scale < wrong.marker_rms_ / 3
    assert right.poisson_ratio_ == pytest.approx(NU, abs=0.01)
    with pytest.raises(InputError, match="driven already"):
        level.drive_markers(["top0"])
    with pytest.raises(InputError, match="no marker 'nope'"):
        level.drive_markers(["nope"])
    with pytest.raises(InputError, match="load cell reads"):
        LoadSteps(mesh, (_plate(mesh),), data.markers, np.zeros((3, 3))).drive_markers(
            ["top0"], replace=True)


def test_marker_gradients_are_the_deformation_gradient_and_identity_when_glued():
    """Each marker's tetrahedron's F under a homogeneous deformation is that deformation;
    a marker whose four corners are one node moves with it (F = I), never a singular
    matrix."""
    from neurofuzzy.learn._reference_scan import MarkerGradients

    mesh = _mesh(2)
    deformation = np.array([[1.1, 0.05, 0.0], [0.0, 0.9, 0.02], [0.01, 0.0, 1.05]])
    nodes = np.vstack([mesh.tetrahedra[:5], [[7, 7, 7, 7]]])
    F = MarkerGradients(mesh.rest_positions, nodes).at(mesh.rest_positions @ deformation.T)
    assert np.allclose(F[:5], deformation) and np.allclose(F[5], np.eye(3))
