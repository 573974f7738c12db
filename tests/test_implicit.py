"""Backward Euler steps (:func:`neurofuzzy.simulation.implicit.simulate_implicit`): first-order
convergence to SciPy's integrator of the same equations, stability at a simulator's 16 ms step
for every law at ν 0.499 (where the explicit step is refused) with the static equilibrium as
its end, MuJoCo's ``discrete`` integrator reproduced by the linearly implicit step, and bad
input."""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError, UnstableTimeStepError
from neurofuzzy.experiment import Experiment
from neurofuzzy.forces.laws import LAWS
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model
from neurofuzzy.simulation import ConvergenceError, equilibrium, simulate
from neurofuzzy.simulation.implicit import simulate_implicit


def _block(nu=0.45, law="neo-hookean", volumetric="nodal", cells=(3, 3, 2)):
    mesh = from_tetra(*kuhn_block(cells, 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=nu, viscosity=2.0,
                           density=1050.0, law=law, volumetric=volumetric)


def _push(model, n_frames=None, touch=0):
    """A push on the top face, down and a little sideways (from frame ``touch`` on)."""
    rest = model.mesh.rest_positions
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    load = np.zeros((model.n_nodes, 3))
    load[top] = (0.01 / len(top), 0.0, -0.05 / len(top))
    if n_frames is None:
        return load
    forces = np.zeros((n_frames, model.n_nodes, 3))
    forces[touch:] = load
    return forces


def test_it_converges_to_scipy_s_integrator_at_first_order():
    """The error against SciPy's DOP853 (to 1e-10) on the same equations halves with the
    step: backward Euler is first-order (measured 26.6, 14.2, 7.4 µm at 4, 8, 16 steps per
    millisecond on this block, whose top moves about 0.5 mm)."""
    from neurofuzzy.validation.integrators import reference_simulate

    model = _block(cells=(2, 2, 1))
    load = _push(model)
    reference = reference_simulate(model, dt=1e-3, n_frames=40, external_forces=load,
                                   method="DOP853").positions
    errors = [np.abs(simulate_implicit(model, dt=1e-3, n_frames=40, external_forces=load,
                                       substeps=k).positions - reference).max()
              for k in (4, 8, 16)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)


def test_bdf2_converges_at_second_order_and_beats_backward_euler():
    """``scheme="bdf2"`` against the same DOP853 reference: the error quarters with the step
    (measured 3.83, 0.98, 0.248 µm at 4, 8, 16 steps per millisecond, ratios 3.9 and 4.0),
    a tenth or less of backward Euler's at every step, and as much with one Newton iteration
    (the linearly implicit step) as with converged ones."""
    from neurofuzzy.validation.integrators import reference_simulate

    model = _block(cells=(2, 2, 1))
    load = _push(model)
    reference = reference_simulate(model, dt=1e-3, n_frames=40, external_forces=load,
                                   method="DOP853").positions

    def error(scheme, k, iterations=1):
        return np.abs(simulate_implicit(model, dt=1e-3, n_frames=40, external_forces=load,
                                        substeps=k, scheme=scheme, iterations=iterations,
                                        tolerance=1e-12).positions - reference).max()

    errors = np.array([error("bdf2", k) for k in (4, 8, 16)])
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 3.5) & (ratios < 4.5)), (errors, ratios)
    assert all(errors[i] < 0.1 * error("euler", k) for i, k in enumerate((4, 8, 16)))
    assert error("bdf2", 8, iterations=50) == pytest.approx(errors[1], rel=0.05)


@pytest.mark.parametrize("scheme", ["euler", "bdf2"])
@pytest.mark.parametrize("law", LAWS)
def test_a_16_ms_step_is_stable_at_nu_0_499_and_ends_at_the_equilibrium(law, scheme):
    """Where the explicit step needs about 1/100 of 16 ms (and is refused at 16 ms), the
    implicit step runs at 16 ms for every law at ν 0.499, both schemes, and under a held load
    it comes to rest at the static equilibrium (:func:`equilibrium`, Newton on the same
    forces)."""
    model = _block(nu=0.499, law=law)
    load = _push(model)
    with pytest.raises(UnstableTimeStepError):
        simulate(model, dt=0.016, n_frames=3, external_forces=load)
    # BDF2 damps the ringing less, so it takes longer to come to rest (measured 3e-6 of the
    # motion from the equilibrium after 60 frames)
    run = simulate_implicit(model, dt=0.016, n_frames=60 if scheme == "euler" else 100,
                            external_forces=load, scheme=scheme)
    rest = equilibrium(model, load=load, increments=2).positions
    moved = np.abs(rest - model.mesh.rest_positions).max()
    assert moved > 1e-4
    assert np.abs(run.positions[-1] - rest).max() < 1e-6 * moved
    assert np.abs(run.velocities[-1]).max() < 1e-6


def test_elements_that_relax_step_implicitly_to_the_long_time_equilibrium():
    """Prony terms (g = 1, τ = 50 ms) in the implicit step: at 16 ms under a held load the
    block first moves about half as far as at its relaxed equilibrium (the instantaneous
    modulus is twice the relaxed one; measured 0.57 after two frames) and comes to rest at
    the static equilibrium with the long-time modulus (measured within 6.8e-6 of the motion
    after 80 frames); at small steps the run converges at first order to the explicit
    stepper's (errors 33, 20, 11 µm at 4, 8, 16 steps a millisecond)."""
    model = _block(cells=(2, 2, 1)).with_elements(relaxation_moduli=1.0, relaxation_times=0.05)
    load = _push(model)
    rest = model.mesh.rest_positions
    run = simulate_implicit(model, dt=0.016, n_frames=80, external_forces=load)
    relaxed = equilibrium(model, load=load, increments=2).positions
    moved = np.abs(relaxed - rest).max()
    assert 0.4 < np.abs(run.positions[2] - rest).max() / moved < 0.75
    assert np.abs(run.positions[-1] - relaxed).max() < 1e-4 * moved
    assert run.final_internal.shape == (model.mesh.n_tetrahedra, 1, 6)
    assert np.abs(run.final_internal).max() > 0
    explicit = simulate(model, dt=1e-3, n_frames=40, external_forces=load,
                        substeps=200).positions
    errors = np.array([np.abs(simulate_implicit(model, dt=1e-3, n_frames=40,
                                                external_forces=load,
                                                substeps=k).positions - explicit).max()
                       for k in (4, 8, 16)])
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 1.5) & (ratios < 2.3)), (errors, ratios)


def test_the_linearly_implicit_step_is_mujoco_s_discrete_integrator():
    """MuJoCo's ``discrete`` integrator (``M + hD + h²K``, its flex elasticity implicit) at a
    16 ms step against ours with one Newton iteration, on the textbook element (MuJoCo's flex):
    the first step with a load identical to MuJoCo's solver tolerance (measured 6.5e-13 m),
    every frame within 2 % of the motion (measured:
    4.3 µm of 395 µm at ν 0.35, 3.2 of 323 at 0.45; MuJoCo damps by a backward difference of
    squared edge lengths, we by the exact rate)."""
    mujoco = pytest.importorskip("mujoco")
    from neurofuzzy.export.mujoco import mjcf

    for nu in (0.35, 0.45):
        model = _block(nu=nu, law="st-venant-kirchhoff", volumetric="element")
        rest = model.mesh.rest_positions
        n, h = 30, 0.016
        forces = _push(model, n, touch=2)
        experiment = Experiment(mesh=model.mesh, dt=h, external_forces=forces,
                                positions=np.repeat(rest[None], n, axis=0))
        text = mjcf(model, experiment=experiment, substeps=1)[0]
        handle = mujoco.MjModel.from_xml_string(text.replace('integrator="Euler"',
                                                             'integrator="discrete"'))
        data = mujoco.MjData(handle)
        bodies = np.array([mujoco.mj_name2id(handle, mujoco.mjtObj.mjOBJ_BODY, f"node{i}")
                           for i in range(model.n_nodes)])
        moving = np.flatnonzero(bodies >= 0)
        address = handle.jnt_qposadr[handle.body_jntadr[bodies[moving]]]
        qpos = (address[:, None] + np.arange(3)).ravel()
        theirs = np.repeat(rest[None], n, axis=0)
        for frame in range(1, n):
            data.xfrc_applied[bodies[moving], :3] = forces[frame - 1, moving]
            mujoco.mj_step(handle, data)
            theirs[frame, moving] = rest[moving] + data.qpos[qpos].reshape(-1, 3)
        ours = simulate_implicit(model, dt=h, n_frames=n, external_forces=forces).positions
        motion = np.abs(theirs - rest).max()
        assert motion > 2e-4
        assert np.abs(ours[3] - theirs[3]).max() < 1e-7 * motion
        assert np.abs(ours - theirs).max() < 0.02 * motion


def test_the_derivatives_solve_with_the_step_solver_s_factorisation(monkeypatch):
    """The derivatives' pass (``implicit_sensitivities``) preconditions its solves with the
    step solver's kept factorisation: over 30 BDF2 steps of a pushed block it factorises
    nothing of its own, and the derivatives equal those made with a factorisation of their
    own (the old way: one, kept until GMRES fails) to the solves' tolerance."""
    from neurofuzzy.simulation import implicit_derivatives as derivatives_module
    from neurofuzzy.simulation.implicit_derivatives import implicit_sensitivities

    model = _block()
    arguments = dict(dt=0.004, n_frames=31, external_forces=_push(model), scheme="bdf2")
    made = []
    factor = derivatives_module._factor
    monkeypatch.setattr(derivatives_module, "_factor",
                        lambda matrix: made.append(1) or factor(matrix))
    shared = implicit_sensitivities(model, **arguments)[1]
    assert made == []
    own = {}

    def solve_alone(matrix, right, kept):     # a factorisation of the derivatives' own
        if "factor" not in own:
            own["factor"] = factor(matrix)
        return derivatives_module.gmres(
            matrix.dot, right, 1e-12 * np.linalg.norm(right),
            precondition=own["factor"].solve, restart=20, cycles=50).x, kept

    monkeypatch.setattr(derivatives_module, "_solve_step", solve_alone)
    alone = implicit_sensitivities(model, **arguments)[1]
    assert np.abs(shared).max() > 0
    assert np.allclose(shared, alone, rtol=0, atol=1e-7 * np.abs(alone).max())


def test_bad_input_is_refused_with_the_key_named():
    from neurofuzzy.simulation.implicit_derivatives import implicit_sensitivities

    model = _block(cells=(2, 2, 1))
    for options, key in (({"substeps": 0}, "substeps"), ({"iterations": 1.5}, "iterations"),
                         ({"dt": -1.0}, "dt"), ({"scheme": "rk4"}, "scheme")):
        arguments = {"dt": 0.016, "n_frames": 3, **options}
        with pytest.raises(InputError, match=key):
            simulate_implicit(model, **arguments)
        if key != "iterations":              # the derivatives' run takes the same checks
            with pytest.raises(InputError, match=key):
                implicit_sensitivities(model, **arguments)
    with pytest.raises(ConvergenceError, match="did not converge"):
        simulate_implicit(model, dt=0.016, n_frames=3, external_forces=_push(model),
                          iterations=2, tolerance=0.0)


def test_the_simulate_command_steps_implicitly_at_16_ms(tmp_path):
    """``neurofuzzy simulate MODEL --integrator implicit --dt 0.016`` writes the experiment
    where the explicit step at 16 ms exits with status 2 and says why; ``--integrator bdf2``
    writes BDF2's run."""
    from helpers import cli
    from neurofuzzy.io import load_experiment, save_model

    model = _block(nu=0.49, cells=(2, 2, 1))
    path = save_model(model, tmp_path / "block.yaml")
    top = int(np.argmax(model.mesh.rest_positions[:, 2]))
    common = ("simulate", path, "--dt", "0.016", "--frames", "20", "--force", str(top), "0",
              "0", "-0.05")
    explicit = cli(*common, "--out", tmp_path / "explicit.npz")
    assert explicit.returncode == 2 and "Traceback" not in explicit.stderr
    assert not (tmp_path / "explicit.npz").exists()
    implicit = cli(*common, "--integrator", "implicit", "--out", tmp_path / "implicit.npz")
    assert implicit.returncode == 0, implicit.stderr
    data = load_experiment(tmp_path / "implicit.npz")
    assert data.n_frames == 20 and np.all(np.isfinite(data.positions))
    assert data.positions[-1, top, 2] < model.mesh.rest_positions[top, 2] - 1e-5
    bdf2 = cli(*common, "--integrator", "bdf2", "--out", tmp_path / "bdf2.npz")
    assert bdf2.returncode == 0, bdf2.stderr
    second = load_experiment(tmp_path / "bdf2.npz").positions
    assert np.allclose(second, simulate_implicit(model, dt=0.016, n_frames=20,
                                                 external_forces=data.external_forces,
                                                 scheme="bdf2").positions, atol=1e-12)
    assert not np.allclose(second, data.positions, atol=1e-9)


@pytest.mark.parametrize("scheme", ["euler", "bdf2"])
@pytest.mark.parametrize("volumetric", ["nodal", "element"])
@pytest.mark.parametrize("law", LAWS)
def test_the_step_s_derivatives_by_e_nu_eta_are_central_differences(law, volumetric, scheme):
    """``implicit_sensitivities``: the derivatives of converged backward Euler (and BDF2)
    steps by each of two groups' E, ν and η against central differences of the simulation
    (measured: within 1e-7 of the largest, every law and form)."""
    from neurofuzzy.simulation.implicit_derivatives import PARAMETERS, implicit_sensitivities

    base = _block(cells=(2, 2, 1), law=law, volumetric=volumetric)
    groups = (base.mesh.rest_positions[base.mesh.tetrahedra].mean(axis=1)[:, 0]
              > 0.01).astype(int)
    model = base.with_elements(youngs_modulus=np.where(groups, 9000.0, 6000.0),
                               poisson_ratio=np.where(groups, 0.4, 0.45),
                               viscosity=np.where(groups, 8.0, 5.0))
    load = 2 * _push(model)
    run, derivatives = implicit_sensitivities(model, dt=0.004, n_frames=6,
                                              external_forces=load, groups=groups,
                                              tolerance=1e-13, scheme=scheme)

    def positions(name, group, change):
        values = getattr(model.elements, name) + change * (groups == group)
        return simulate_implicit(model.with_elements(**{name: values}), dt=0.004, n_frames=6,
                                 external_forces=load, iterations=50, tolerance=1e-13,
                                 scheme=scheme).positions

    assert np.array_equal(run.positions, positions("viscosity", 0, 0.0))
    for k, name in enumerate(PARAMETERS):
        for group in (0, 1):
            step = 1e-6 * getattr(model.elements, name)[groups == group][0]
            central = (positions(name, group, step) - positions(name, group, -step)) / (2 * step)
            assert np.abs(central).max() > 0
            got = derivatives[:, 2 * k + group]
            assert np.abs(got - central).max() < 1e-5 * np.abs(central).max(), (name, group)


@pytest.mark.parametrize("scheme", ["euler", "bdf2"])
def test_a_fit_through_implicit_steps_recovers_e_nu_eta_of_its_own_data(scheme):
    """Markers made by converged backward Euler (or BDF2) steps of 4 ms (a neo-Hookean block
    pushed and let go, 2 µm noise): from a start 33 % off in E, 0.05 in ν and half η, the
    fit through the same scheme returns them within 1 % (measured on the 2 × 2 × 1 block,
    backward Euler 0.006 %, 0.013 %, 0.15 %; BDF2 0.004 %, 0.008 %, 0.29 %) and ends at the
    noise (√3 × 2 µm per marker)."""
    from neurofuzzy.learn.implicit_fit import fit_implicit

    truth = _block(cells=(2, 2, 1)).with_elements(viscosity=10.0)
    n, h = 30, 0.004
    forces = _push(truth, n, touch=2) * 2
    forces[15:] = 0.0
    clean = simulate_implicit(truth, dt=h, n_frames=n, external_forces=forces, iterations=50,
                              tolerance=1e-12, scheme=scheme).positions
    noisy = clean + np.random.default_rng(0).normal(0.0, 2e-6, clean.shape)
    noisy[:, truth.mesh.fixed] = clean[:, truth.mesh.fixed]
    noisy[0] = clean[0]
    data = Experiment(mesh=truth.mesh, dt=h, positions=noisy, external_forces=forces)
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=5.0)
    fitted = fit_implicit(start, data, scheme=scheme)
    assert fitted.values["youngs_modulus"][0] == pytest.approx(6000.0, rel=0.01)
    assert fitted.values["poisson_ratio"][0] == pytest.approx(0.45, rel=0.01)
    assert fitted.values["viscosity"][0] == pytest.approx(10.0, rel=0.01)
    assert fitted.rms_error == pytest.approx(np.sqrt(3) * 2e-6, rel=0.15)
    assert np.allclose(fitted.model.elements.youngs_modulus, fitted.values["youngs_modulus"])


def _relaxing_plate(law, volumetric, groups=None):
    """The 2 × 2 × 2 block with two Prony terms (g 0.5 and 0.3, τ 4 and 20 ms), its top
    driven down 15 % and sideways 3 % over 24 ms and held: ``(model, simulation keywords)``."""
    from neurofuzzy.paths import DrivenPath

    model = _block(cells=(2, 2, 2), law=law, volumetric=volumetric).with_elements(
        relaxation_moduli=[0.5, 0.3], relaxation_times=[0.004, 0.02])
    rest = model.mesh.rest_positions
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    path = np.zeros((10, 3))
    path[:, 2] = -0.15 * 0.02 * np.minimum(np.arange(10) / 6, 1.0)
    path[:, 0] = 0.2 * path[:, 2]
    return model, {"dt": 0.004, "n_frames": 10, "driven": [DrivenPath(top, path, "xyz")]}


@pytest.mark.parametrize("law, volumetric, scheme, substeps",
                         [(law, ("element", "nodal")[k % 2], ("bdf2", "euler")[k // 2 % 2],
                           1 + k % 2) for k, law in enumerate(LAWS)])
def test_the_derivatives_through_relaxing_steps_are_central_differences(law, volumetric,
                                                                        scheme, substeps):
    """Elements with Prony terms: the internal variables' own derivatives carried through the
    steps (:mod:`neurofuzzy.simulation.implicit_relaxation`) make the positions' and the
    plate's force's derivatives by two groups' E, ν and η central differences of the
    simulation, every law (measured: within 5e-8 of the largest; without the internal
    variables' part they were 2 to 40 % off)."""
    from neurofuzzy.simulation.implicit_derivatives import PARAMETERS, implicit_sensitivities

    base, keywords = _relaxing_plate(law, volumetric)
    groups = (base.mesh.rest_positions[base.mesh.tetrahedra].mean(axis=1)[:, 0]
              > 0.01).astype(int)
    model = base.with_elements(youngs_modulus=np.where(groups, 9000.0, 6000.0),
                               poisson_ratio=np.where(groups, 0.4, 0.45),
                               viscosity=np.where(groups, 8.0, 5.0))
    keywords.update(scheme=scheme, substeps=substeps, tolerance=1e-13)
    run, derivatives, forces = implicit_sensitivities(model, groups=groups, forces=True,
                                                      **keywords)

    def simulated(name, group, change):
        values = getattr(model.elements, name) + change * (groups == group)
        return simulate_implicit(model.with_elements(**{name: values}), iterations=50,
                                 **keywords)

    for k, name in enumerate(PARAMETERS):
        for group in (0, 1):
            step = 1e-6 * getattr(model.elements, name)[groups == group][0]
            ahead, back = simulated(name, group, step), simulated(name, group, -step)
            for got, value in ((derivatives, "positions"), (forces.reactions, "reactions")):
                central = (getattr(ahead, value) - getattr(back, value)) / (2 * step)
                assert np.abs(central).max() > 0
                error = np.abs(got[:, 2 * k + group] - central).max()
                assert error < 1e-5 * np.abs(central).max(), (name, group, value)


def test_a_fit_through_relaxing_implicit_steps_recovers_e_nu_eta():
    """Markers and the plate's force made by BDF2 steps of the relaxing block (1 µm noise,
    the force's 1 % of its peak): from E 33 % off, ν 0.05 and η half, the fit through the same
    steps returns them within 1 %, the Prony terms known (measured: E +0.06 %, ν +0.003 %,
    η +0.7 %, ten evaluations)."""
    from neurofuzzy.learn.implicit_fit import fit_implicit
    from neurofuzzy.observation import EmbeddedMarkers

    truth, keywords = _relaxing_plate("neo-hookean", "nodal")
    truth = truth.with_elements(viscosity=10.0)
    clean = simulate_implicit(truth, iterations=50, tolerance=1e-12, scheme="bdf2",
                              **keywords)
    rng = np.random.default_rng(3)
    inner = np.flatnonzero(~np.isin(np.arange(truth.n_nodes), truth.mesh.fixed))
    beads = clean.positions[:, inner] + rng.normal(0.0, 1e-6, clean.positions[:, inner].shape)
    beads[0] = clean.positions[0, inner]
    force = clean.reactions[:, 0]
    force = force + 0.01 * np.abs(force).max() * rng.normal(size=force.shape)
    weights = np.zeros((len(inner), 4))
    weights[:, 0] = 1.0
    nodes = np.repeat(inner[:, None], 4, axis=1)
    data = Experiment(mesh=truth.mesh, dt=keywords["dt"],
                      positions=np.full((keywords["n_frames"], truth.n_nodes, 3), np.nan),
                      observed=np.zeros(truth.n_nodes, bool),
                      markers=EmbeddedMarkers(nodes, weights, beads),
                      driven=tuple(keywords["driven"]), reaction=force)
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=5.0)
    fitted = fit_implicit(start, data, scheme="bdf2")
    assert fitted.values["youngs_modulus"][0] == pytest.approx(6000.0, rel=0.01)
    assert fitted.values["poisson_ratio"][0] == pytest.approx(0.45, rel=0.01)
    assert fitted.values["viscosity"][0] == pytest.approx(10.0, rel=0.01)


def test_the_derivatives_refuse_what_they_do_not_cover():
    from neurofuzzy.effects import Gravity
    from neurofuzzy.simulation.implicit_derivatives import implicit_sensitivities

    model = _block(cells=(2, 2, 1))
    with pytest.raises(InputError, match="without springs or effects"):
        implicit_sensitivities(model.with_effects(Gravity((0.0, 0.0, -9.81))), dt=0.01,
                               n_frames=2)
    mixed = model.with_elements(youngs_modulus=np.linspace(5e3, 7e3, model.mesh.n_tetrahedra))
    with pytest.raises(InputError, match="share their youngs_modulus"):
        implicit_sensitivities(mixed, dt=0.01, n_frames=2)


def _exact_steps(model, h, n_frames, load):
    """The oracle of the fast solve: backward Euler with one Newton iteration, ``A``
    assembled and solved directly at every step."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from neurofuzzy.simulation.tangents import tangents

    n = model.n_nodes
    free = np.ones(3 * n, bool)
    free[(3 * model.mesh.fixed[:, None] + np.arange(3)).ravel()] = False
    mass = np.repeat(model.node_mass, 3)[free]
    p, v = model.mesh.rest_positions.copy(), np.zeros((n, 3))
    positions = [p]
    for _ in range(1, n_frames):
        state = tangents(model, p + h * v, v)
        matrix = (sp.diags(mass) + h * state.damping[free][:, free]
                  + h * h * state.stiffness[free][:, free])
        w = v.ravel().copy()
        w[free] += spla.spsolve(matrix.tocsc(), h * (state.force.ravel() + load.ravel())[free])
        v = w.reshape(n, 3)
        p = p + h * v
        positions.append(p)
    return np.array(positions)


@pytest.mark.parametrize("law, volumetric", [("st-venant-kirchhoff", "element"),
                                             ("neo-hookean", "nodal")])
def test_the_kept_factorisation_gives_the_exact_step_with_few_factorisations(law, volumetric):
    """Each step's solve by a factorisation kept from an earlier step, corrected by GMRES
    whose products are differences of the compiled force (:mod:`~neurofuzzy.simulation.
    step_solve`): every frame is the step solved exactly (``A`` assembled and factorised at
    each step) to within 1e-5 of the motion, and the run factorises a few times, not at every
    step."""
    from neurofuzzy.simulation.step_solve import StepSolver

    model = _block(nu=0.49, law=law, volumetric=volumetric)
    load = _push(model)
    solvers = []

    class Counted(StepSolver):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            solvers.append(self)

    import neurofuzzy.simulation.implicit as implicit

    original, implicit.StepSolver = implicit.StepSolver, Counted
    try:
        ours = simulate_implicit(model, dt=0.016, n_frames=25, external_forces=load).positions
    finally:
        implicit.StepSolver = original
    exact = _exact_steps(model, 0.016, 25, load)
    motion = np.abs(exact - model.mesh.rest_positions).max()
    assert motion > 1e-4
    assert np.abs(ours - exact).max() < 1e-5 * motion
    counts = solvers[-1].counts
    assert counts["factorisations"] <= 3 and counts["iterations"] > 0, counts


def test_a_kept_factorisation_is_refreshed_once_it_has_cost_refresh_iterations(monkeypatch):
    """After :data:`~neurofuzzy.simulation.step_solve.REFRESH` GMRES iterations on one
    factorisation the next solve factorises afresh (here lowered to 10 on a run that takes
    more than that): fewer iterations in all, the same motion to 1e-5."""
    import neurofuzzy.simulation.step_solve as step_solve
    from neurofuzzy.simulation.step_solve import StepSolver

    model = _block(nu=0.45)
    load = _push(model)
    solvers, spent = [], []

    class Counted(StepSolver):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            solvers.append(self)

        def _factorise(self, x, v):
            spent.append(self._spent)
            super()._factorise(x, v)

    import neurofuzzy.simulation.implicit as implicit

    monkeypatch.setattr(implicit, "StepSolver", Counted)
    runs = {}
    for refresh in (10**9, 10):
        monkeypatch.setattr(step_solve, "REFRESH", refresh)
        spent.clear()
        positions = simulate_implicit(model, dt=0.016, n_frames=25,
                                      external_forces=load).positions
        runs[refresh] = positions, dict(solvers[-1].counts), list(spent)
    (kept, kept_counts, _), (fresh, fresh_counts, before) = runs[10**9], runs[10]
    assert kept_counts["factorisations"] == 1 and kept_counts["iterations"] > 20, kept_counts
    assert fresh_counts["factorisations"] >= 3, fresh_counts
    # each refresh came once the kept factorisation had cost 10 iterations, not before
    assert all(10 <= count < 10 + step_solve.RESTART for count in before[1:]), before
    assert fresh_counts["iterations"] < kept_counts["iterations"]
    motion = np.abs(kept - model.mesh.rest_positions).max()
    assert np.abs(fresh - kept).max() < 1e-5 * motion


def test_the_solve_s_product_is_the_assembled_matrix_s():
    """``A y`` by a forward difference of the compiled force equals the assembled
    ``(M + hC + h²K) y`` at a moving, deformed state, for every law (relative 1e-6)."""
    import scipy.sparse as sp

    from neurofuzzy.simulation.step_solve import BodyForce, StepSolver
    from neurofuzzy.simulation.tangents import tangents

    rng = np.random.default_rng(3)
    for law in LAWS:
        model = _block(nu=0.49, law=law)
        n, h = model.n_nodes, 0.016
        moving = np.ones(n, bool)
        moving[model.mesh.fixed] = False
        p = model.mesh.rest_positions + 2e-4 * rng.normal(size=(n, 3)) * moving[:, None]
        v = 1e-2 * rng.normal(size=(n, 3)) * moving[:, None]
        free = np.repeat(moving, 3)
        mass = np.repeat(model.node_mass, 3)[free]
        body = BodyForce(model)
        state = tangents(model, p, v)
        assert np.allclose(body(p, v), state.force.ravel(), rtol=0, atol=1e-12)
        matrix = (sp.diags(mass) + h * state.damping[free][:, free]
                  + h * h * state.stiffness[free][:, free])
        y = rng.normal(size=int(free.sum()))
        product = StepSolver(model, body, h, free, mass).product(y, p.ravel(), v.ravel(),
                                                                 body(p, v))
        assert np.linalg.norm(product - matrix @ y) < 1e-6 * np.linalg.norm(matrix @ y), law
