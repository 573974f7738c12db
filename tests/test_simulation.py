import numpy as np
import pytest

from neurofuzzy.errors import InputError, UnstableTimeStepError
from neurofuzzy.mesh import Mesh, lattice
from neurofuzzy.forces import Springs
from neurofuzzy.model import Model
from neurofuzzy.simulation import simulate, stability_limit, step, internal_forces

import numpy_reference as reference


def one_spring(stiffness=50.0, damping=0.0, mass=2.0):
    mesh = Mesh(np.array([[0.0, 0, 0], [1.0, 0, 0]]), np.array([[0, 1]])).with_fixed([0])
    return Model(mesh, [1.0, mass], (Springs(stiffness=[stiffness], damping=[damping]),))


def upward_crossings(x):
    """Fractional indices where x crosses zero upwards (linear interpolation)."""
    i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    return i + x[i] / (x[i] - x[i + 1])


def test_one_spring_oscillates_at_sqrt_s_over_m():
    model = one_spring(stiffness=50.0, mass=2.0)
    dt = 0.002                                            # h·ω = 0.01
    run = simulate(model, dt=dt, n_frames=20000, initial_positions=[[0, 0, 0], [1.1, 0, 0]])
    x = run.positions[:, 1, 0] - 1.0
    period = np.mean(np.diff(upward_crossings(x))) * dt
    assert 2 * np.pi / period == pytest.approx(np.sqrt(50.0 / 2.0), rel=0.01)
    assert np.abs(run.positions[:, 0]).max() == 0.0      # the fixed node never moves


def test_damped_spring_decays_at_the_analytic_rate():
    stiffness, damping, mass = 50.0, 0.4, 2.0
    model = one_spring(stiffness, damping, mass)
    dt = 0.001
    run = simulate(model, dt=dt, n_frames=8000, initial_positions=[[0, 0, 0], [1.1, 0, 0]])
    x = run.positions[:, 1, 0] - 1.0
    peaks = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])) + 1
    rate = -np.polyfit(peaks * dt, np.log(x[peaks]), 1)[0]
    assert rate == pytest.approx(damping / (2 * mass), rel=0.02)
    omega_d = 2 * np.pi / (np.mean(np.diff(peaks)) * dt)
    assert omega_d == pytest.approx(np.sqrt(stiffness / mass - (damping / (2 * mass)) ** 2),
                                    rel=0.01)


def test_hanging_chain_settles_at_the_static_displacement():
    n, stiffness, load = 6, 20.0, 0.5
    rest = np.zeros((n + 1, 3))
    rest[:, 2] = -np.arange(n + 1) * 0.1
    mesh = Mesh(rest, np.stack([np.arange(n), np.arange(1, n + 1)], axis=1)).with_fixed([0])
    model = Model(mesh, 0.01, (Springs(stiffness=stiffness, damping=2.0),))
    forces = np.zeros((n + 1, 3))
    forces[1:, 2] = -load                                 # the same load on every hanging node
    run = simulate(model, dt=0.001, n_frames=6000, external_forces=forces, substeps="auto")
    displacement = rest[:, 2] - run.positions[-1, :, 2]
    # spring k carries the load of the n - k nodes below it
    carried = load * (n - np.arange(n))
    expected = np.concatenate([[0.0], np.cumsum(carried / stiffness)])
    assert np.allclose(displacement, expected, rtol=1e-6, atol=1e-9)
    assert np.allclose(run.positions[-1, :, :2], 0.0)


def test_momentum_is_conserved_without_external_forces(rng):
    mesh = lattice((3, 3, 2), 0.1)
    model = Model(mesh, rng.uniform(0.5, 2.0, mesh.n_nodes),
                  (Springs(stiffness=rng.uniform(10, 30, mesh.n_springs),
                           damping=rng.uniform(0.0, 0.1, mesh.n_springs)),))
    start = mesh.rest_positions + rng.normal(0, 0.01, (mesh.n_nodes, 3))
    run = simulate(model, dt=0.002, n_frames=300, initial_positions=start,
                   initial_velocities=rng.normal(0, 0.1, (mesh.n_nodes, 3)))
    momentum = np.einsum("i,tij->tj", model.node_mass, run.velocities)
    assert np.allclose(momentum, momentum[0], atol=1e-12)


def test_energy_does_not_grow_without_input(rng):
    mesh = lattice((3, 3, 3), 0.1).with_fixed(np.arange(9))
    model = Model(mesh, 0.01, (Springs(stiffness=rng.uniform(10, 30, 86), damping=0.05),))
    start = mesh.rest_positions + rng.normal(0, 0.01, (27, 3))
    start[mesh.fixed] = mesh.rest_positions[mesh.fixed]
    run = simulate(model, dt=0.001, n_frames=2000, initial_positions=start)
    a, b = mesh.springs.T
    stretch = np.linalg.norm(run.positions[:, b] - run.positions[:, a], axis=2) - \
        model.springs.rest_length
    energy = (0.5 * (stretch**2 * model.springs.stiffness).sum(1)
              + 0.5 * np.einsum("i,tij,tij->t", model.node_mass, run.velocities, run.velocities))
    # symplectic Euler's energy oscillates by O(h); it must not grow over a period
    window = 200
    assert energy[-window:].max() < energy[:window].max()
    assert energy[-1] < 0.5 * energy[0]


def test_integrator_is_first_order():
    model = one_spring(stiffness=50.0, damping=0.2, mass=2.0)
    start = [[0, 0, 0], [1.1, 0, 0]]
    fine = simulate(model, dt=0.5, n_frames=3, initial_positions=start, substeps=4096)
    errors = [abs(simulate(model, dt=0.5, n_frames=3, initial_positions=start,
                           substeps=k).positions[-1, 1, 0] - fine.positions[-1, 1, 0])
              for k in (64, 128, 256)]
    order = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.allclose(order, 1.0, atol=0.15)


def test_unstable_step_is_refused_and_auto_substeps_fix_it():
    model = one_spring(stiffness=50.0, mass=2.0)          # ω = 5
    limit = stability_limit(model)
    assert limit.omega_max == pytest.approx(5.0)
    with pytest.raises(UnstableTimeStepError, match=r"substeps >= \d+"):
        simulate(model, dt=0.5, n_frames=10)
    run = simulate(model, dt=0.5, n_frames=10, substeps="auto",
                   initial_positions=[[0, 0, 0], [1.1, 0, 0]])
    assert run.substeps >= 2 and np.all(np.isfinite(run.positions))
    assert 0.5 / run.substeps <= limit.max_step


def test_stability_bound_is_tight_for_the_cube():
    model = Model.uniform(lattice((3, 3, 3), 0.01).with_fixed(np.arange(0, 27, 3)),
                          stiffness=50.0, damping=0.02, total_mass=0.008)
    limit = stability_limit(model)
    start = model.mesh.rest_positions + np.random.default_rng(0).normal(0, 1e-4, (27, 3))
    start[model.mesh.fixed] = model.mesh.rest_positions[model.mesh.fixed]
    ok = simulate(model, dt=0.95 * limit.max_step, n_frames=3000, initial_positions=start,
                  check_stability=False)
    assert np.abs(ok.positions[-1] - model.mesh.rest_positions).max() < 1e-4
    with pytest.raises(UnstableTimeStepError, match="diverged"):
        simulate(model, dt=1.2 * limit.max_step / 0.9, n_frames=3000, initial_positions=start,
                 check_stability=False)


def test_step_matches_simulate_and_forces_are_antisymmetric(cube_model, rng):
    p = cube_model.mesh.rest_positions + rng.normal(0, 1e-3, (27, 3))
    v = rng.normal(0, 1e-2, (27, 3))
    v[cube_model.mesh.fixed] = 0.0
    force = internal_forces(cube_model, p, v)
    assert np.allclose(force.sum(axis=0), 0.0, atol=1e-12)   # Newton's third law
    p1, v1 = step(cube_model, p, v.copy(), 1e-4)
    run = simulate(cube_model, dt=1e-4, n_frames=2, initial_positions=p, initial_velocities=v)
    assert np.allclose(run.positions[1], p1) and np.allclose(run.velocities[1], v1)


def test_bad_simulation_input():
    model = one_spring()
    with pytest.raises(InputError, match=r"external_forces.*expected \(n_nodes, 3\)"):
        simulate(model, dt=0.01, n_frames=3, external_forces=np.zeros((3, 3)))
    with pytest.raises(InputError, match="dt"):
        simulate(model, dt=-1.0, n_frames=3)
    with pytest.raises(InputError, match="NaN"):
        simulate(model, dt=0.01, n_frames=3, initial_positions=[[0, 0, 0], [np.nan, 0, 0]])


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_fast_steppers_equal_the_reference_step(backend, rng):
    mesh = lattice((4, 3, 3), 0.01).with_fixed(np.arange(0, 36, 3))
    model = Model(mesh, rng.uniform(1e-4, 3e-4, mesh.n_nodes),
                  (Springs(stiffness=rng.uniform(20, 60, mesh.n_springs),
                           damping=rng.uniform(0.005, 0.02, mesh.n_springs)),))
    loads = rng.normal(0, 0.05, (40, mesh.n_nodes, 3))
    fast = reference.simulate(model, dt=5e-4, n_frames=40, external_forces=loads,
                              substeps=2, backend=backend)
    p, v = mesh.rest_positions.copy(), np.zeros((mesh.n_nodes, 3))
    for t in range(1, 40):
        for _ in range(2):
            p, v = step(model, p, v, 2.5e-4, loads[t - 1])
        assert np.allclose(fast.positions[t], p, rtol=0, atol=1e-14)
        assert np.allclose(fast.velocities[t], v, rtol=0, atol=1e-11)


def test_float32_path_stays_close(cube_model, cube_experiment):
    single = simulate(cube_model, dt=cube_experiment.dt, n_frames=cube_experiment.n_frames,
                      external_forces=cube_experiment.external_forces, dtype=np.float32)
    error = np.abs(single.positions - cube_experiment.positions).max()
    assert 0 < error < 1e-6 * 0.01 * 100          # within 1e-4 edge lengths


def test_the_compiled_stepper_computes_the_kernels_effects_as_the_numpy_one():
    """Gravity, a node drag, an unmodeled load, an inclusion of elements and their strain
    stiffening (:mod:`neurofuzzy.effects.compiled`) in the compiled loop: the trajectory of
    the numpy stepper, for both volumetric forms."""
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.effects import (Gravity, NodeDrag, NonlinearStiffening, StiffInclusion,
                                    UnmodeledLoad)
    from neurofuzzy.mesh import from_tetra

    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    for volumetric in ("nodal", "element"):
        model = Model.continuum(mesh, youngs_modulus=5000.0, poisson_ratio=0.4,
                                viscosity=1.0, density=1000.0,
                                volumetric=volumetric).with_effects(
            Gravity([0.0, 0.0, -9.81]), NodeDrag([0.01]), UnmodeledLoad([0.0, 0.02, 0.0],
                                                                        node=mesh.n_nodes - 1),
            StiffInclusion([3000.0], elements=[0, 1, 2, 3], poisson_ratio=0.45),
            NonlinearStiffening([2000.0], on="elements"))
        runs = [reference.simulate(model, dt=2e-3, n_frames=30, substeps="auto",
                                   backend=backend) for backend in ("numpy", "numba")]
        assert np.abs(runs[0].positions - mesh.rest_positions).max() > 1e-4      # it moved
        np.testing.assert_allclose(runs[1].positions, runs[0].positions, rtol=0, atol=1e-13)
        np.testing.assert_allclose(runs[1].velocities, runs[0].velocities, rtol=0, atol=1e-10)


def test_the_compiled_stepper_computes_spring_effects_as_the_numpy_one(rng):
    """Spring inclusions (extra stiffness, also on springs with none of their own) and spring
    stiffening per group in the compiled loop: the trajectory of the numpy stepper."""
    from neurofuzzy.effects import NonlinearStiffening, SoftInclusion, StiffInclusion

    mesh = lattice((4, 3, 3), 0.01).with_fixed(np.arange(0, 36, 3))
    stiffness = rng.uniform(20, 60, mesh.n_springs)
    stiffness[:5] = 0.0                    # springs that only the inclusion makes pull
    base = Model(mesh, rng.uniform(1e-4, 3e-4, mesh.n_nodes),
                 (Springs(stiffness=stiffness,
                          damping=rng.uniform(0.005, 0.02, mesh.n_springs)),))
    n_groups = len(np.unique(mesh.spring_group))
    model = base.with_effects(
        StiffInclusion.for_model(base, 15.0, springs=np.arange(12)),
        SoftInclusion.for_model(base, -5.0, springs=np.arange(30, 40)),
        NonlinearStiffening.for_model(base, rng.uniform(2e3, 5e3, n_groups)))
    loads = rng.normal(0, 0.2, (40, mesh.n_nodes, 3))
    runs = [reference.simulate(model, dt=5e-4, n_frames=40, external_forces=loads,
                               substeps=2, backend=backend) for backend in ("numpy", "numba")]
    plain = simulate(base, dt=5e-4, n_frames=40, external_forces=loads, substeps=2)
    assert np.abs(runs[0].positions - plain.positions).max() > 1e-5   # the effects act
    np.testing.assert_allclose(runs[1].positions, runs[0].positions, rtol=0, atol=1e-14)
    np.testing.assert_allclose(runs[1].velocities, runs[0].velocities, rtol=0, atol=1e-11)


def test_the_numpy_reference_steps_by_its_own_loop_and_the_package_by_the_kernel(monkeypatch):
    """``simulate`` has one inner loop, the compiled one (the paper cube and a 288-element
    block with a drag alike); the tests' numpy reference steps the same call by numpy, so the
    comparisons above compare two loops, not one loop with itself."""
    import neurofuzzy.simulation.integration as integration
    from neurofuzzy.datasets import kuhn_block, paper_cube_model
    from neurofuzzy.effects import NodeDrag
    from neurofuzzy.mesh import from_tetra

    mesh = from_tetra(*kuhn_block((4, 4, 3), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    block = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.3,
                            viscosity=2.0, density=1050.0).with_effects(NodeDrag([0.03]))
    made = []

    def spy(kind):
        def make(*args):
            made.append(kind.__name__)
            return kind(*args)
        return make

    monkeypatch.setattr(reference, "NumpyStepper", spy(reference.NumpyStepper))
    monkeypatch.setattr(integration, "NumbaStepper", spy(integration.NumbaStepper))
    for model in (block, paper_cube_model()):
        simulate(model, dt=1e-3, n_frames=2, substeps="auto")
        reference.simulate(model, dt=1e-3, n_frames=2, substeps="auto", backend="numpy")
    assert made == ["NumbaStepper", "NumpyStepper"] * 2


def _relaxing_block():
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra

    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=5e3, poisson_ratio=0.45,
                            viscosity=1.0, density=1000.0)
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0.0, 0.0, -0.05)
    return model.with_elements(relaxation_moduli=[0.5], relaxation_times=[0.02]), load


@pytest.mark.parametrize("relaxes", [True, False])
def test_a_run_continued_from_its_final_state_is_the_run_through(cube_model, relaxes):
    """A run in two halves, the second from the first's ``final_state``, equals the whole
    run (bit for bit: the same steps). For a relaxing model the internal variables are part
    of the state: continuing from positions and velocities alone restarts the relaxation and
    moves the loaded corner by more than a tenth of its motion."""
    from neurofuzzy.simulation import State

    if relaxes:
        model, load = _relaxing_block()
        options = dict(dt=1e-3, external_forces=load, substeps="auto")
    else:
        model, load = cube_model, np.zeros((cube_model.n_nodes, 3))
        load[13] = (0.0, 0.0, -0.05)
        options = dict(dt=0.01, external_forces=load, substeps="auto")
    whole = simulate(model, n_frames=41, **options)
    first = simulate(model, n_frames=21, **options)
    second = simulate(model, n_frames=21, initial_state=first.final_state, **options)
    np.testing.assert_array_equal(second.positions, whole.positions[20:])
    np.testing.assert_array_equal(second.final_internal, whole.final_internal)
    assert isinstance(first.final_state, State)
    if relaxes:
        assert np.abs(whole.final_internal).max() > 100.0          # Pa: the terms relaxed
        forgetful = simulate(model, n_frames=21, initial_positions=first.positions[-1],
                             initial_velocities=first.velocities[-1], **options)
        motion = np.abs(whole.positions[-1] - model.mesh.rest_positions).max()
        assert np.abs(forgetful.positions[-1] - whole.positions[-1]).max() > 0.1 * motion
        at_rest = State.at_rest(model)
        np.testing.assert_array_equal(simulate(model, n_frames=5, initial_state=at_rest,
                                               **options).positions,
                                      simulate(model, n_frames=5, **options).positions)
    else:
        assert whole.final_internal.size == 0


def test_a_state_of_another_model_or_a_step_without_one_is_refused(cube_model):
    from neurofuzzy.simulation import State
    from neurofuzzy.validation.integrators import reference_simulate

    model, load = _relaxing_block()
    state = State.at_rest(model)
    with pytest.raises(InputError, match="not both"):
        simulate(model, dt=1e-3, n_frames=3, initial_state=state,
                 initial_positions=model.mesh.rest_positions)
    wrong = State(state.positions, state.velocities, np.zeros((model.mesh.n_tetrahedra, 2, 6)))
    with pytest.raises(InputError, match=r"needs \(48, 1, 6\).*another model"):
        simulate(model, dt=1e-3, n_frames=3, initial_state=wrong, substeps="auto")
    bad = State(state.positions, state.velocities, np.full_like(state.internal, np.nan))
    with pytest.raises(InputError, match="NaN"):
        simulate(model, dt=1e-3, n_frames=3, initial_state=bad, substeps="auto")
    with pytest.raises(InputError, match="expected a State"):
        simulate(model, dt=1e-3, n_frames=3, initial_state=(state.positions, state.velocities))
    with pytest.raises(InputError, match=r"needs \(0, 0, 6\).*another model"):
        simulate(cube_model, dt=0.01, n_frames=3, initial_state=state, substeps="auto")
    elsewhere = State(state.positions[:-1], state.velocities[:-1], state.internal)
    with pytest.raises(InputError, match="initial_state.positions.*expected \\(n_nodes, 3\\)"):
        simulate(model, dt=1e-3, n_frames=3, initial_state=elsewhere, substeps="auto")
    with pytest.raises(InputError, match="relax.*initial_state"):
        step(model, state.positions, state.velocities, 1e-4)
    other = reference_simulate(cube_model, dt=0.01, n_frames=3)
    with pytest.raises(InputError, match="internal variables"):
        other.final_state


def test_steppers_of_one_model_share_its_constants_not_their_scratch_space():
    """simulate prepares a model's kernel arrays once per step length (a run continued in
    pieces, or a real-time loop, calls it on one model again and again: the cube's call went
    from 34 to 27 µs); every stepper keeps its own force, nodal strains and internal
    variables, so two runs of one relaxing model in threads equal the runs one after the
    other, and a changed model gets its own arrays."""
    from concurrent.futures import ThreadPoolExecutor

    from neurofuzzy.simulation.steppers import NumbaStepper

    model, load = _relaxing_block()
    one, two = NumbaStepper(model, 1e-4), NumbaStepper(model, 1e-4)
    assert one.springs[2] is two.springs[2] and one.elements.shear is two.elements.shear
    assert one.history is not two.history and one.force is not two.force
    assert one.node_strain is not two.node_strain
    stiffer = model.with_elements(youngs_modulus=2 * model.elements.youngs_modulus)
    assert NumbaStepper(stiffer, 1e-4).elements.shear is not one.elements.shear
    assert NumbaStepper(model, 5e-5).relaxation[1] is not one.relaxation[1]   # decay per step

    def run(scale):
        return simulate(model, dt=1e-3, n_frames=30, external_forces=scale * load,
                        substeps="auto")

    alone = [run(scale) for scale in (1.0, 0.5)]
    with ThreadPoolExecutor(2) as pool:
        together = list(pool.map(run, (1.0, 0.5)))
    for a, b in zip(alone, together):
        np.testing.assert_array_equal(a.positions, b.positions)
        np.testing.assert_array_equal(a.final_internal, b.final_internal)
