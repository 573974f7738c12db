"""The compiled forward sensitivities compute what the numpy reference path computes."""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block, paper_cube_experiment, paper_cube_model
from neurofuzzy.effects import (Gravity, NodeDrag, NonlinearStiffening, SoftInclusion,
                                StiffInclusion, UnmodeledLoad)
from neurofuzzy.experiment import Experiment, simulate_experiment
from neurofuzzy.learn import Parameterization, Sensitivity
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from neurofuzzy.simulation import stability_limit

# numba is a core dependency: a missing numba fails these tests, it does not skip them
import numba  # noqa: E402, F401

import numpy_reference as reference


def both(start, data, substeps, starts=(0,), shift=0.01, learn_masses=False):
    parameters = Parameterization(start, learn_masses=learn_masses)
    theta = parameters.initial() + shift
    return [reference.sensitivity(parameters, 0.01, backend=backend).run(
        theta, data, substeps=substeps, starts=starts, tangents=True)
        for backend in ("numpy", "numba")]


def assert_same(reference, compiled):
    assert np.allclose(compiled.positions, reference.positions, rtol=0, atol=1e-15)
    assert np.allclose(compiled.residuals, reference.residuals, rtol=0, atol=1e-13)
    scale = np.abs(reference.jacobian).max()
    assert scale > 0
    assert np.abs(compiled.jacobian - reference.jacobian).max() < 1e-12 * scale
    assert compiled.n_measured == reference.n_measured


@pytest.mark.parametrize("starts", [(0,), (0, 20, 40)], ids=["whole", "windows"])
def test_springs_with_tie_groups(starts):
    model = paper_cube_model(tie="groups")
    assert_same(*both(model, paper_cube_experiment(model), 2, starts))


def _laws(name, rng, n):
    """One law for all elements, or a random one per element ("mixed")."""
    return (rng.choice(["st-venant-kirchhoff", "neo-hookean", "yeoh"], n) if name == "mixed"
            else name)


LAWS = ["st-venant-kirchhoff", "neo-hookean", "yeoh", "mixed"]


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_elements_in_tie_groups_seen_through_embedded_markers(volumetric, law):
    mesh = from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    rng = np.random.default_rng(0)
    truth = Model.continuum(
        mesh, youngs_modulus=rng.uniform(4e3, 8e3, mesh.n_tetrahedra), poisson_ratio=0.45,
        viscosity=2.0, density=1000.0, volumetric=volumetric,
        law=_laws(law, rng, mesh.n_tetrahedra),
        stiffening=rng.uniform(0.5, 2.0, mesh.n_tetrahedra)).with_elements(
        tie=rng.integers(0, 3, mesh.n_tetrahedra))
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0.0, 0.01, -0.05)
    steps = int(np.ceil(1e-3 / stability_limit(truth).max_step))
    nodes = simulate_experiment(truth, dt=1e-3, n_frames=30, external_forces=load,
                                substeps=steps)
    assert_same(*both(truth, nodes, steps))
    points = rng.uniform((0.002, 0.002, 0.005), (0.028, 0.028, 0.02), (12, 3))
    corners, weights, _ = embed_points(mesh, points)
    seen = np.einsum("mk,tmkj->tmj", weights, nodes.positions[:, corners])
    seen[5:8, 3] = np.nan                                             # a gap
    positions = np.full_like(nodes.positions, np.nan)
    positions[0] = mesh.rest_positions
    markers = Experiment(mesh=mesh, dt=1e-3, positions=positions, external_forces=load,
                         node_mass=truth.node_mass, observed=np.zeros(mesh.n_nodes, bool),
                         markers=EmbeddedMarkers(corners, weights, seen))
    assert_same(*both(truth, markers, steps))


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_learned_effects_of_element_models(volumetric):
    """Gravity, an unmodeled load, a node drag, an inclusion of elements and their strain
    stiffening, all learned with the elements' own parameters: the kernel's effect columns
    equal the numpy path's."""
    mesh = from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                            viscosity=2.0, density=1000.0, volumetric=volumetric)
    model = model.with_effects(Gravity([0.1, 0.0, -9.81]), UnmodeledLoad([0.0, 0.002, 0.0],
                                                                       node=mesh.n_nodes - 2),
                               NodeDrag([0.05]),
                               StiffInclusion([4000.0], elements=[3, 4, 10, 11, 12],
                                              poisson_ratio=0.4),
                               NonlinearStiffening([5e4], on="elements"))
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0.0, 0.01, -0.05)
    steps = int(np.ceil(1e-3 / stability_limit(model).max_step))
    data = simulate_experiment(model, dt=1e-3, n_frames=25, external_forces=load,
                               substeps=steps)
    numpy_run, compiled_run = both(model, data, steps)
    assert_same(numpy_run, compiled_run)
    assert compiled_run.jacobian.shape[-1] == 3 + 3 + 3 + 1 + 1 + 1
    assert_split_equal(model, data, steps)


@pytest.mark.parametrize("kind", ["springs", "elements"])
def test_learned_masses_with_gravity(kind):
    """Node masses learned with the springs' or the elements' constants, under gravity (a force
    per unit mass, which the masses' columns leave out): the kernel's mass columns equal the
    numpy path's, split over threads too, and so does the compiled adjoint's gradient."""
    if kind == "springs":
        model = paper_cube_model(tie="groups")
        data = paper_cube_experiment(model)
        steps = 2
    else:
        mesh = from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(
            where=lambda p: p[:, 2] < 1e-9)
        model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                                viscosity=2.0, density=1000.0)
        load = np.zeros((mesh.n_nodes, 3))
        load[-1] = (0.0, 0.01, -0.05)
        steps = int(np.ceil(1e-3 / stability_limit(model).max_step))
        data = simulate_experiment(model, dt=1e-3, n_frames=25, external_forces=load,
                                   substeps=steps)
    model = model.with_effects(Gravity([0.0, 0.5, -9.81]))
    numpy_run, compiled_run = both(model, data, steps, learn_masses=True)
    assert_same(numpy_run, compiled_run)
    parameters = Parameterization(model, learn_masses=True)
    masses = parameters.blocks["log_mass"].slice
    assert np.abs(compiled_run.jacobian[..., masses]).max() > 0
    parameters = Parameterization(model, learn_masses=True, learn_effects=False)
    masses = parameters.blocks["log_mass"].slice
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial() + np.random.default_rng(5).normal(0, 0.02, parameters.size)
    whole = sensitivity.run(theta, data, substeps=steps, tangents=True)
    split = sensitivity.run(theta, data, substeps=steps, tangents=True, threads=3)
    assert np.array_equal(split.jacobian, whole.jacobian)
    numpy_path, compiled = (reference.sensitivity(parameters, 0.01, backend).gradient(
        theta, data, substeps=steps) for backend in ("numpy", "numba"))
    assert compiled[0] == pytest.approx(numpy_path[0], rel=1e-12)
    scale = np.abs(numpy_path[1][masses]).max()
    assert scale > 0
    assert np.abs(compiled[1] - numpy_path[1]).max() < 1e-10 * np.abs(numpy_path[1]).max()
    assert np.abs(compiled[1][masses] - numpy_path[1][masses]).max() < 1e-10 * scale


def assert_split_equal(model, data, steps, shift=0.01):
    """Columns split over threads (uneven shares, the effects' and the element constants'
    columns in different shares) give the Jacobian of one thread, bit for bit."""
    parameters = Parameterization(model)
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial() + shift
    whole = sensitivity.run(theta, data, substeps=steps, tangents=True)
    for threads in (2, 5):
        split = sensitivity.run(theta, data, substeps=steps, tangents=True, threads=threads)
        assert np.array_equal(split.jacobian, whole.jacobian)
        assert np.array_equal(split.positions, whole.positions)


@pytest.mark.parametrize("relaxation", [None, ((0.5, 0.02),)])
def test_windows_split_over_threads_give_the_jacobian_of_one_thread(relaxation):
    """With windows (multiple shooting) each thread takes a run of whole windows with every
    column, bit for bit the one thread's Jacobian; elements that relax carry their internal
    variables from one window to the next, so they keep the split by columns (equal too)."""
    from neurofuzzy.learn._sensitivity import _window_spans

    assert _window_spans([0, 25], 41, 2) == [(0, 25), (25, 41)]
    assert _window_spans([0, 10, 20, 30, 40], 41, 2) == [(0, 20), (20, 41)]
    assert _window_spans([0], 41, 2) == [(0, 41)]
    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0, relaxation=relaxation)
    load = np.zeros((mesh.n_nodes, 3))
    load[mesh.rest_positions[:, 2] > 0.02 - 1e-9, 2] = -0.02
    data = simulate_experiment(model, dt=2e-3, n_frames=31, external_forces=load, substeps=4)
    parameters = Parameterization(model)
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial() + 0.02
    for starts in ((0, 10, 20), (0, 16)):
        whole = sensitivity.run(theta, data, substeps=4, starts=starts, tangents=True)
        for threads in (2, 3):
            split = sensitivity.run(theta, data, substeps=4, starts=starts, tangents=True,
                                    threads=threads)
            assert np.array_equal(split.jacobian, whole.jacobian)
            assert np.array_equal(split.positions, whole.positions)
            assert np.array_equal(split.residuals, whole.residuals)
        assert np.abs(whole.jacobian).max() > 0
        # a window's first frame is measured, not simulated: its row is zero
        assert not np.any(whole.jacobian[starts[1] - 1])


def test_split_columns_of_a_spring_model():
    model = paper_cube_model(tie="none").with_effects(NodeDrag([0.02]))
    assert_split_equal(model, paper_cube_experiment(paper_cube_model(tie="global")), 2)


def test_gravity_is_computed_by_the_kernel_as_by_numpy():
    gravity = paper_cube_model(tie="global").with_effects(Gravity([0.0, 0.0, -9.81]))
    assert_same(*both(gravity, paper_cube_experiment(gravity), 1))


@pytest.mark.parametrize("starts", [(0,), (0, 20, 40)], ids=["whole", "windows"])
def test_compiled_adjoint_of_springs_with_drag_and_gaps(starts):
    """The compiled adjoint (sweep and pull-back kernels) gives the numpy adjoint's cost and
    gradient: per-spring stiffness and damping, a fixed node drag and gravity, a gap in one
    node's track."""
    model = paper_cube_model(tie="none").with_effects(NodeDrag([0.03]),
                                                      Gravity([0.0, 0.0, -9.81]))
    data = paper_cube_experiment(model)
    if starts == (0,):                      # windows need every free node at every frame
        positions = data.positions.copy()
        positions[30:35, 13] = np.nan
        data = data.replace(positions=positions)
    parameters = Parameterization(model, learn_effects=False)
    assert not parameters.effects
    theta = parameters.initial() + np.random.default_rng(3).normal(0, 0.05, parameters.size)
    numpy_path, compiled = (reference.sensitivity(parameters, 0.01, backend).gradient(
        theta, data, substeps=2, starts=starts) for backend in ("numpy", "numba"))
    assert numpy_path[0] > 0
    assert compiled[0] == pytest.approx(numpy_path[0], rel=1e-12)
    scale = np.abs(numpy_path[1]).max()
    assert scale > 0
    assert np.abs(compiled[1] - numpy_path[1]).max() < 1e-10 * scale
    assert np.allclose(compiled[2].residuals, numpy_path[2].residuals, rtol=0, atol=1e-13)


def _spring_effects_model():
    """The cube in tie groups with a stiff inclusion, a soft one and strain stiffening per
    spring group (the spring candidates of the diagnosis), and a node drag."""
    base = paper_cube_model(tie="groups")
    n_groups = len(np.unique(base.mesh.spring_group))
    return base.with_effects(
        StiffInclusion.for_model(base, 20.0, springs=np.arange(0, 40, 3)),
        SoftInclusion.for_model(base, -8.0, springs=np.arange(50, 60)),
        NonlinearStiffening.for_model(base, np.linspace(300.0, 600.0, n_groups)),
        NodeDrag([0.02]))


@pytest.mark.parametrize("starts", [(0,), (0, 20, 40)], ids=["whole", "windows"])
def test_learned_spring_effects(starts):
    """Spring inclusions, spring stiffening and a node drag, their coefficients learned with
    the springs: the compiled Jacobian is the numpy one, and so is the compiled adjoint's
    gradient."""
    model = _spring_effects_model()
    data = paper_cube_experiment(model)
    assert_same(*both(model, data, 2, starts))
    parameters = Parameterization(model)
    assert len(parameters.effects) == 4
    theta = parameters.initial() + np.random.default_rng(5).normal(0, 0.02, parameters.size)
    sensitivities = [reference.sensitivity(parameters, 0.01, backend=backend)
                     for backend in ("numpy", "numba")]
    numpy_path, compiled = (s.gradient(theta, data, substeps=2, starts=starts)
                            for s in sensitivities)
    assert compiled[0] == pytest.approx(numpy_path[0], rel=1e-12)
    effects = slice(parameters.blocks["effect:0"].start, parameters.blocks["effect:3"].stop)
    assert np.abs(numpy_path[1][effects]).min() > 0    # every coefficient has a gradient
    scale = np.abs(numpy_path[1]).max()
    assert np.abs(compiled[1] - numpy_path[1]).max() < 1e-10 * scale


def test_stiffening_of_springs_learned_from_zero():
    """The diagnosis starts a spring stiffening at κ = 0: the kernels still compute its
    columns (the cubic basis), in the Jacobian and in the adjoint's gradient."""
    base = paper_cube_model(tie="global")
    model = base.with_effects(NonlinearStiffening.for_model(base, [0.0]))
    data = paper_cube_experiment(model)
    assert_same(*both(model, data, 2, shift=0.0))
    parameters = Parameterization(model)
    column = parameters.blocks["effect:0"].start
    theta = parameters.initial() + 0.05
    theta[column] = 0.0
    numpy_path, compiled = (reference.sensitivity(parameters, 0.01, backend).gradient(
        theta, data, substeps=2) for backend in ("numpy", "numba"))
    assert numpy_path[1][column] != 0
    assert compiled[1][column] == pytest.approx(numpy_path[1][column], rel=1e-10)


def _through_markers(model, nodes, load, points):
    """``nodes`` (an experiment of every node) seen only through markers embedded at
    ``points``, marker 3 missing in frames 5-7."""
    mesh = model.mesh
    corners, weights, _ = embed_points(mesh, points)
    seen = np.einsum("mk,tmkj->tmj", weights, nodes.positions[:, corners])
    seen[5:8, 3] = np.nan
    positions = np.full_like(nodes.positions, np.nan)
    positions[0] = mesh.rest_positions
    return Experiment(mesh=mesh, dt=nodes.dt, positions=positions, external_forces=load,
                      node_mass=model.node_mass, observed=np.zeros(mesh.n_nodes, bool),
                      markers=EmbeddedMarkers(corners, weights, seen))


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_compiled_adjoint_of_elements_with_an_inclusion_and_markers(volumetric, law):
    """The compiled adjoint of element models gives the numpy adjoint's cost and gradient:
    per-element E, ν and η in tie groups, an inclusion of elements (not learned), a node
    drag, seen through embedded markers with a gap."""
    mesh = from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    rng = np.random.default_rng(3)
    model = Model.continuum(
        mesh, youngs_modulus=rng.uniform(4e3, 8e3, mesh.n_tetrahedra),
        poisson_ratio=rng.uniform(0.3, 0.45, mesh.n_tetrahedra), viscosity=2.0,
        density=1000.0, volumetric=volumetric, law=_laws(law, rng, mesh.n_tetrahedra),
        stiffening=rng.uniform(0.5, 2.0, mesh.n_tetrahedra)).with_elements(
        tie=rng.integers(0, 4, mesh.n_tetrahedra)).with_effects(
        StiffInclusion([3000.0], elements=[3, 4, 10, 11], poisson_ratio=0.4),
        NodeDrag([0.05]))
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0.0, 0.01, -0.05)
    steps = int(np.ceil(1e-3 / stability_limit(model).max_step))
    nodes = simulate_experiment(model, dt=1e-3, n_frames=25, external_forces=load,
                                substeps=steps)
    markers = _through_markers(model, nodes, load, rng.uniform(
        (0.002, 0.002, 0.005), (0.028, 0.028, 0.02), (12, 3)))
    parameters = Parameterization(model, learn_effects=False)
    theta = parameters.initial() + rng.normal(0.0, 0.05, parameters.size)
    sensitivities = [reference.sensitivity(parameters, 0.01, backend=backend)
                     for backend in ("numpy", "numba")]
    for data, starts in ((markers, (0,)), (nodes, (0, 10, 20))):
        numpy_path, compiled = (s.gradient(theta, data, substeps=steps, starts=starts)
                                for s in sensitivities)
        assert compiled[0] == pytest.approx(numpy_path[0], rel=1e-12)
        scale = np.abs(numpy_path[1]).max()
        assert scale > 0
        assert np.abs(compiled[1] - numpy_path[1]).max() < 1e-10 * scale



@pytest.mark.parametrize("volumetric", ["nodal", "element"])
def test_the_adjoint_pulls_back_a_cotangent_of_one_s_own(volumetric):
    """``gradient(cotangent=v)`` is ``Jᵀ v`` of the forward Jacobian (the diagnosis scores
    every inclusion ball's ``cᵀ t`` in one backward sweep so), gaps left out; an inclusion's
    coefficient learned, seen through embedded markers."""
    mesh = from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    rng = np.random.default_rng(8)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0, volumetric=volumetric).with_effects(
        StiffInclusion([0.0], elements=[3, 4, 10, 11], poisson_ratio=0.45),
        StiffInclusion([0.0], elements=[20], poisson_ratio=0.45))
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0.0, 0.01, -0.05)
    steps = int(np.ceil(1e-3 / stability_limit(model).max_step))
    nodes = simulate_experiment(model, dt=1e-3, n_frames=20, external_forces=load,
                                substeps=steps)
    data = _through_markers(model, nodes, load, rng.uniform(0.002, 0.018, (10, 3)))
    parameters = Parameterization(model)
    sensitivity = Sensitivity(parameters, 0.01)
    theta = parameters.initial()
    run = sensitivity.run(theta, data, substeps=steps, tangents=True)
    cotangent = rng.normal(size=run.residuals.shape)
    pulled = sensitivity.gradient(theta, data, substeps=steps, cotangent=cotangent)[1]
    cotangent[4:7, 3] = 0.0                 # frames 5-7 of marker 3 are gaps
    expected = run.jacobian.reshape(-1, parameters.size).T @ cotangent.ravel()
    assert np.abs(expected).min() > 0
    assert np.abs(pulled - expected).max() < 1e-9 * np.abs(expected).max()
    with pytest.raises(ValueError, match="compiled"):
        reference.sensitivity(parameters, 0.01, backend="numpy").gradient(
            theta, data, substeps=steps, cotangent=cotangent)

def test_the_kernels_use_no_more_threads_than_numba_is_allowed(monkeypatch):
    """fit-many's workers set NUMBA_NUM_THREADS=1: load cases and Jacobian columns then run
    on one thread; without it every core is used, and nonsense falls back to the cores."""
    import os

    from neurofuzzy.learn._passes import cores

    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")
    assert cores() == 1
    monkeypatch.setenv("NUMBA_NUM_THREADS", "64")
    assert cores() == (os.cpu_count() or 1)
    monkeypatch.setenv("NUMBA_NUM_THREADS", "many")
    assert cores() == (os.cpu_count() or 1)
    monkeypatch.delenv("NUMBA_NUM_THREADS")
    assert cores() == (os.cpu_count() or 1)


def test_the_adjoints_forward_sweep_is_simulates_run():
    """The adjoint's forward sweep and a run without tangents are the stepper's own driver
    (``kernels.stepper.frames``, the first keeping every substep's state): from rest,
    without windows, their positions are those ``simulate`` computes for the same model, bit
    for bit, a relaxing element model (the internal variables) included."""
    from neurofuzzy.simulation import simulate

    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45,
                            viscosity=2.0, density=1000.0, law="neo-hookean",
                            relaxation=((0.5, 0.02),))
    top = mesh.rest_positions[:, 2] > 0.02 - 1e-9
    load = np.zeros((mesh.n_nodes, 3))
    load[top, 2] = -0.02 / top.sum()
    data = simulate_experiment(model, dt=2e-3, n_frames=30, external_forces=load, substeps=4)
    parameters = Parameterization(model)
    theta = parameters.initial() + 0.05
    loss, gradient, run = Sensitivity(parameters, 0.01).gradient(theta, data, substeps=4)
    assert loss > 0 and np.all(np.isfinite(gradient))
    reference = simulate(parameters.model(theta), dt=2e-3, n_frames=30, external_forces=load,
                         substeps=4)
    assert np.abs(reference.positions - reference.positions[0]).max() > 1e-4
    assert np.array_equal(run.positions, reference.positions)
    alone = Sensitivity(parameters, 0.01).run(theta, data, substeps=4)
    assert alone.jacobian is None
    assert np.array_equal(alone.positions, reference.positions)
    assert np.array_equal(alone.residuals, run.residuals)
    # and one compiled specialisation serves all three (a second one costs every process a
    # load of the driver's machine code, 30 ms on a cube fit; read-only or 3-d arrays where
    # another caller passes writable or 4-d ones would each make one); models without
    # elements have one of their own (elements None), and so have the large models' passes
    # on both cores (buffers an array, not None), which other tests in this process may have
    # compiled
    from neurofuzzy.kernels.stepper import frames

    kinds = [s for s in frames.signatures if str(s[0].types[0]) == "array(float64, 2d, C)"
             and str(s[2]) != "none" and str(s[-1].types[-1]) == "none"]
    assert len(kinds) == 1, [[(i, str(a), str(b)) for i, (a, b) in enumerate(zip(kinds[0], s))
                              if a != b] for s in kinds[1:]]
