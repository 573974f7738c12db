"""Tetrahedral finite elements, checked against code nobody here wrote (scikit-fem's linear
elasticity), closed-form solutions, and their own finite differences."""

import numpy as np
import pytest
from helpers import assert_gradient_exact

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError
from neurofuzzy.forces import Springs
from neurofuzzy.io import load_model, save_model
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.simulation import simulate, stability_limit

import numpy_reference as reference

E, NU, ETA, RHO = 6000.0, 0.45, 2.0, 1000.0


def block(shape=(2, 2, 2), spacing=0.01, jitter=0.0, seed=0):
    points, tetrahedra = kuhn_block(shape, spacing)
    if jitter:
        rng = np.random.default_rng(seed)
        inner = np.all((points > 0) & (points < np.array(shape) * spacing), axis=1)
        points[inner] += rng.uniform(-jitter, jitter, (inner.sum(), 3)) * spacing
    return from_tetra(points, tetrahedra)


def continuum(mesh, **options):
    values = dict(youngs_modulus=E, poisson_ratio=NU, viscosity=ETA, density=RHO)
    values.update(options)
    return Model.continuum(mesh, **values)


def state(model, seed, size=1e-3, speed=1e-2):
    rng = np.random.default_rng(seed)
    p = model.mesh.rest_positions + rng.normal(0, size, (model.n_nodes, 3))
    return p, rng.normal(0, speed, (model.n_nodes, 3))


def test_stiffness_at_rest_is_scikit_fem_linear_elasticity_to_round_off():
    skfem = pytest.importorskip("skfem")
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = block((3, 2, 2), jitter=0.2)
    rng = np.random.default_rng(1)
    moduli, ratios = rng.uniform(2e3, 2e4, mesh.n_tetrahedra), rng.uniform(0.1, 0.49,
                                                                           mesh.n_tetrahedra)
    model = continuum(mesh, youngs_modulus=moduli, poisson_ratio=ratios, volumetric="element")
    stiffness, _ = model.elements.rest_matrices(model)
    fem = skfem.MeshTet(mesh.rest_positions.T.copy(), mesh.tetrahedra.T.copy())
    basis = skfem.Basis(fem, skfem.ElementVector(skfem.ElementTetP1()))
    reference = None
    for k in range(mesh.n_tetrahedra):        # per-element materials: one element at a time
        one = basis.with_elements(np.array([k]))
        part = skfem.asm(linear_elasticity(*lame_parameters(moduli[k], ratios[k])), one)
        reference = part if reference is None else reference + part
    ours = np.empty(3 * mesh.n_nodes, int)
    ours[basis.nodal_dofs.T.ravel()] = np.arange(3 * mesh.n_nodes)   # skfem dof -> 3 node + axis
    ours_in_skfem_order = stiffness.toarray()[np.ix_(ours.argsort(), ours.argsort())]
    scale = np.abs(reference.toarray()).max()
    assert np.abs(ours_in_skfem_order - reference.toarray()).max() < 1e-10 * scale


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_uniaxial_stress_with_lateral_contraction_is_exact(volumetric):
    """u = ε (x, -ν y, -ν z): no force inside or on the free faces, σ = E ε on the end (for
    the nodal volumetric form too: averaging a homogeneous strain changes nothing)."""
    mesh = block((3, 2, 2), spacing=0.01, jitter=0.2)
    model = continuum(mesh, volumetric=volumetric)
    strain = 1e-7
    x = mesh.rest_positions
    displaced = x + strain * x * np.array([1.0, -NU, -NU])
    force = model.elements.force(model, displaced, np.zeros_like(x))
    end = np.isclose(x[:, 0], 0.03)
    start = np.isclose(x[:, 0], 0.0)
    area = 0.02 * 0.02
    assert force[end, 0].sum() == pytest.approx(-E * strain * area, rel=1e-5)
    assert force[start, 0].sum() == pytest.approx(E * strain * area, rel=1e-5)
    elsewhere = ~(end | start)
    assert np.abs(force[elsewhere]).max() < 1e-5 * E * strain * area
    assert np.abs(force[:, 1:]).max() < 1e-5 * E * strain * area      # no lateral stress


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_rigid_motion_gives_no_force_and_rotated_states_rotated_forces(volumetric):
    model = continuum(block(jitter=0.2), volumetric=volumetric)
    x = model.mesh.rest_positions
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                         [0, 0, 1.0]])
    moved = x @ rotation.T + [0.3, -0.1, 0.2]
    assert np.abs(model.elements.force(model, moved, np.zeros_like(x))).max() < 1e-9
    p, v = state(model, 2)
    rotated = model.elements.force(model, p @ rotation.T, v @ rotation.T)
    assert np.allclose(rotated, model.elements.force(model, p, v) @ rotation.T, atol=1e-12)


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_forces_balance_and_state_derivatives_are_exact(volumetric):
    model = continuum(block(jitter=0.2), volumetric=volumetric)
    p, v = state(model, 3)
    force = model.elements.force(model, p, v)
    assert np.allclose(force.sum(axis=0), 0.0, atol=1e-12 * np.abs(force).max())
    rng = np.random.default_rng(4)
    dp, dv = rng.normal(size=(2, model.n_nodes, 2, 3))
    jvp = model.elements.state_jvp(model, p, v, dp, dv)
    eps = 1e-7
    for k in range(2):
        numeric = (model.elements.force(model, p + eps * dp[:, k], v + eps * dv[:, k])
                   - model.elements.force(model, p - eps * dp[:, k], v - eps * dv[:, k])) / (2 * eps)
        assert np.abs(jvp[:, k] - numeric).max() <= 1e-6 * np.abs(numeric).max()
    cotangent = rng.normal(size=(model.n_nodes, 3))
    lam_p, lam_v = model.elements.state_vjp(model, p, v, cotangent)
    forward = np.sum(jvp[:, 0] * cotangent)
    assert forward == pytest.approx(np.sum(lam_p * dp[:, 0]) + np.sum(lam_v * dv[:, 0]),
                                    rel=1e-10)


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_parameter_derivatives_match_finite_differences(volumetric):
    """parameter_jvp along single elements' E, ν, η equals central differences of the force
    (the nodal form moves the neighbours' nodes too, the per-element form only the element's
    own), and parameter_vjp is its adjoint."""
    import scipy.sparse as sp

    mesh = block(jitter=0.2)
    k = mesh.n_tetrahedra
    rng = np.random.default_rng(9)
    model = continuum(mesh, youngs_modulus=rng.uniform(3e3, 9e3, k),
                      poisson_ratio=rng.uniform(0.3, 0.48, k), viscosity=rng.uniform(1, 5, k),
                      volumetric=volumetric)
    p, v = state(model, 5)
    chosen = [0, 7, k - 1]
    unit = sp.csr_matrix((np.ones(3), (chosen, range(3))), shape=(k, 3))
    zero = sp.csr_matrix((k, 3))
    for name, step in (("youngs_modulus", 1.0), ("poisson_ratio", 1e-6), ("viscosity", 1e-4)):
        directions = {other: (unit if other == name else zero)
                      for other in ("youngs_modulus", "poisson_ratio", "viscosity")}
        jvp = model.elements.parameter_jvp(model, p, v, directions)
        assert jvp.shape == (model.n_nodes, 3, 3)
        for column, element in enumerate(chosen):
            values = getattr(model.elements, name).copy()
            plus, minus = values.copy(), values.copy()
            plus[element] += step
            minus[element] -= step
            above = model.with_elements(**{name: plus})
            below = model.with_elements(**{name: minus})
            numeric = (above.elements.force(above, p, v)
                       - below.elements.force(below, p, v)) / (2 * step)
            assert np.allclose(jvp[:, column], numeric, rtol=1e-5,
                               atol=1e-7 * np.abs(numeric).max())
            outside = ~np.isin(np.arange(model.n_nodes), mesh.tetrahedra[element])
            moved_outside = np.abs(numeric[outside]).max() / np.abs(numeric).max()
            if volumetric == "element":
                assert moved_outside < 1e-9
            else:
                assert moved_outside > 1e-3          # the node averages reach the neighbours
    cotangent = rng.normal(size=(model.n_nodes, 3))
    gradients = model.elements.parameter_vjp(model, p, v, cotangent)
    directions = {name: rng.normal(size=(k, 2)) for name in gradients}
    forward = np.einsum("npk,nk->p", model.elements.parameter_jvp(model, p, v, directions),
                        cotangent)
    backward = sum(directions[name].T @ gradients[name] for name in gradients)
    assert np.allclose(forward, backward, rtol=1e-10)


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_stiffness_at_rest_is_the_force_derivative(volumetric):
    """The assembled rest matrices (used for the stability bound) are -∂f/∂x and -∂f/∂v at
    rest, for the non-local nodal form too."""
    model = continuum(block(jitter=0.2), volumetric=volumetric)
    stiffness, damping = model.elements.rest_matrices(model)
    rng = np.random.default_rng(10)
    dp, dv = rng.normal(size=(2, model.n_nodes, 1, 3))
    rest, still = model.mesh.rest_positions, np.zeros((model.n_nodes, 3))
    jvp = model.elements.state_jvp(model, rest, still, dp, np.zeros_like(dv))[:, 0].ravel()
    assert np.allclose(-stiffness @ dp[:, 0].ravel(), jvp, atol=1e-12 * np.abs(jvp).max())
    jvp = model.elements.state_jvp(model, rest, still, np.zeros_like(dp), dv)[:, 0].ravel()
    assert np.allclose(-damping @ dv[:, 0].ravel(), jvp, atol=1e-12 * np.abs(jvp).max())
    assert abs(stiffness - stiffness.T).max() < 1e-12 * abs(stiffness).max()   # an energy


def test_a_damped_block_settles_at_scikit_fem_static_solution():
    """Dynamic simulation of the element model (our stepper) ends where scikit-fem's static
    linear-elasticity solve puts it."""
    skfem = pytest.importorskip("skfem")
    from scipy.sparse.linalg import spsolve
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = block((2, 2, 3), spacing=0.01)
    x = mesh.rest_positions
    mesh = mesh.with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = continuum(mesh, viscosity=100.0, volumetric="element")   # settles within 0.4 s
    load = np.zeros((mesh.n_nodes, 3))
    top = np.flatnonzero(np.isclose(x[:, 2], 0.03))
    load[top, 2] = -1e-3 / len(top)
    dt = 1e-3
    steps = int(np.ceil(dt / stability_limit(model).max_step))
    final = simulate(model, dt=dt, n_frames=400, external_forces=load,
                     substeps=steps).positions[-1]

    fem = skfem.MeshTet(x.T.copy(), mesh.tetrahedra.T.copy())
    basis = skfem.Basis(fem, skfem.ElementVector(skfem.ElementTetP1()))
    K = skfem.asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    f = np.zeros(3 * mesh.n_nodes)
    f[basis.nodal_dofs[2, top]] = load[top, 2]
    fixed = basis.nodal_dofs[:, mesh.fixed].ravel()
    free = np.setdiff1d(np.arange(3 * mesh.n_nodes), fixed)
    u = np.zeros(3 * mesh.n_nodes)
    u[free] = spsolve(K[free][:, free].tocsc(), f[free])
    expected = u[basis.nodal_dofs].T
    displacement = final - x
    assert np.abs(displacement - expected).max() < 0.01 * np.abs(expected).max()


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_fast_steppers_step_elements_as_the_reference_step(backend, volumetric):
    """Both steppers (numba's compiled element loop included) reproduce
    :func:`~neurofuzzy.simulation.step`, which sums the force terms one by one."""
    from neurofuzzy.simulation import step

    mesh = block((2, 2, 2), jitter=0.2, seed=3).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    rng = np.random.default_rng(4)
    k = mesh.n_tetrahedra
    model = continuum(mesh, youngs_modulus=rng.uniform(3e3, 9e3, k),
                      poisson_ratio=rng.uniform(0.2, 0.48, k), viscosity=rng.uniform(1, 5, k),
                      volumetric=volumetric)
    model = model.with_term(Springs(stiffness=np.where(np.arange(mesh.n_springs) % 3 == 0, 5.0,
                                                       0.0), damping=0.0))
    loads = rng.normal(0, 1e-3, (20, mesh.n_nodes, 3))
    dt, substeps = 2e-4, 3
    fast = reference.simulate(model, dt=dt, n_frames=20, external_forces=loads,
                              substeps=substeps, backend=backend)
    p, v = mesh.rest_positions.copy(), np.zeros((mesh.n_nodes, 3))
    for t in range(1, 20):
        for _ in range(substeps):
            p, v = step(model, p, v, dt / substeps, loads[t - 1])
        assert np.allclose(fast.positions[t], p, rtol=0, atol=1e-13)
        assert np.allclose(fast.velocities[t], v, rtol=0, atol=1e-9)
    assert np.abs(fast.positions[-1] - mesh.rest_positions).max() > 1e-6   # it moved


def test_element_models_round_trip_and_bad_values_are_refused(tmp_path):
    model = continuum(block(), youngs_modulus=np.linspace(1e3, 2e3, 48))
    loaded = load_model(save_model(model, tmp_path / "m.yaml"))
    assert loaded.elements is not None and loaded.elements.volumetric == "nodal"
    assert np.array_equal(loaded.elements.youngs_modulus, model.elements.youngs_modulus)
    assert np.allclose(loaded.elements.force(loaded, *state(model, 6)),
                       model.elements.force(model, *state(model, 6)))
    with pytest.raises(InputError, match=r"element_poisson_ratio: element 0 has Poisson's ratio "
                                         r"0.5; it must lie in \(0, 0.5\), strictly"):
        model.with_elements(poisson_ratio=np.full(48, 0.5))
    with pytest.raises(InputError, match="all three"):
        model.with_elements(viscosity=None)
    with pytest.raises(InputError, match="did you mean 'nodal'"):
        model.with_elements(volumetric="nodes")


def _element_data(truth, frames=80):
    x = truth.mesh.rest_positions
    top = np.flatnonzero(np.isclose(x[:, 2], x[:, 2].max()))
    steps = int(np.ceil(1e-3 / stability_limit(truth).max_step))
    experiments = []
    for direction in ((0, 0, -1e-3), (1e-3, 0, 0)):
        load = np.zeros((truth.n_nodes, 3))
        load[top] = np.array(direction) / len(top)
        experiments.append(simulate_experiment(truth, dt=1e-3, n_frames=frames,
                                               external_forces=load, substeps=steps))
    return experiments, steps


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_element_parameter_gradients_are_exact(volumetric):
    from neurofuzzy.learn import Parameterization, Sensitivity

    mesh = block((1, 1, 2)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = continuum(mesh, viscosity=20.0, volumetric=volumetric)
    (data, _), steps = _element_data(truth, frames=12)
    rng = np.random.default_rng(8)
    start = truth.with_elements(youngs_modulus=truth.elements.youngs_modulus * 1.2,
                                poisson_ratio=np.full(mesh.n_tetrahedra, 0.4),
                                tie=rng.integers(0, 2, mesh.n_tetrahedra))
    parameters = Parameterization(start)
    assert parameters.names() == [f"{q}[element group {k}]" for q in
                                  ("youngs_modulus", "poisson_ratio", "viscosity")
                                  for k in (0, 1)]
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial()
    assert np.allclose(parameters.model(theta).elements.poisson_ratio, 0.4)
    assert_gradient_exact(sensitivity, theta, data, steps)


@pytest.mark.slow
def test_gradient_learner_recovers_youngs_modulus_poisson_ratio_and_viscosity():
    from neurofuzzy.learn import GradientLearner

    mesh = block((2, 2, 2)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = continuum(mesh, viscosity=20.0)
    experiments, steps = _element_data(truth)
    start = continuum(mesh, youngs_modulus=3000.0, poisson_ratio=0.3, viscosity=40.0)
    learner = GradientLearner(substeps=steps).fit(start, experiments)
    fitted = learner.model_
    assert fitted.elements.youngs_modulus == pytest.approx(E, rel=1e-6)
    assert fitted.elements.poisson_ratio == pytest.approx(NU, rel=1e-6)
    assert fitted.elements.viscosity == pytest.approx(20.0, rel=1e-5)
    assert learner.parameter_names_[0] == "youngs_modulus[all elements]"


@pytest.mark.slow
def test_element_model_from_words_mesh_command_and_fit_start(tmp_path, capsys):
    """mesh --elements tetra -> fit --start: the learned numbers are the tissue's E, ν, η,
    and the words come back from them directly."""
    import json

    from helpers import write_gmsh

    from neurofuzzy.cli import main
    from neurofuzzy.io import save_experiment
    from neurofuzzy.mesh import read_mesh
    from neurofuzzy.rules import load_rules, shipped
    from neurofuzzy.tissues import initialize, materials

    points, tetrahedra = kuhn_block((2, 2, 2), 0.01)
    path = write_gmsh(tmp_path / "block.msh", points, tetrahedra,
                      np.ones(len(tetrahedra), int), {1: "block"})
    assert main(["mesh", str(path), "--rules", "liver", "--tissue", "liver", "--elements",
                 "tetra", "--fix-below", "0.001", "--out", str(tmp_path / "block.yaml")]) == 0
    model = load_model(tmp_path / "block.yaml")
    rules = load_rules(shipped("liver"))
    assert model.elements is not None and model.elements.youngs_modulus == pytest.approx(
        rules.tissue("liver")["youngs_modulus"])
    mesh = read_mesh(path).mesh.with_fixed(where=lambda p: p[:, 2] <= 0.001)
    truth = initialize(rules, mesh, "fibrotic_liver", elements=True)
    experiments, steps = _element_data(truth)
    files = [str(save_experiment(e, tmp_path / f"case{i}.npz")) for i, e in
             enumerate(experiments)]
    capsys.readouterr()
    assert main(["fit", *files, "--start", str(tmp_path / "block.yaml"), "--rules", "liver",
                 "--substeps", str(steps), "--json", "--quiet"]) == 0
    found = json.loads(capsys.readouterr().out)["materials"]["liver"]
    expected = materials(truth, rules)["fibrotic_liver"]
    for key in ("youngs_modulus", "poisson_ratio", "viscosity", "density"):
        assert found[key] == pytest.approx(expected[key], rel=1e-5), key
    assert found["labels"]["youngs_modulus"] == "hard"
