"""Driven node sets and a rigid tool in the implicit run (``simulate_implicit(driven=...,
tool=...)``, :mod:`neurofuzzy.simulation.moving`): pushed slowly and held, the run settles
where the static solve puts the same boundary, to its force; while the plate moves, the
viscous gel pushes back harder than at rest; bad paths are refused."""

import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.load_steps import DrivenPath, ToolPath
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.simulation.contact import Sphere, contact_with
from neurofuzzy.simulation.implicit import simulate_implicit
from neurofuzzy.simulation.static import Driven, equilibrium

H, R, FRAMES = 0.02, 0.005, 60


@pytest.fixture(scope="module")
def gel():
    points, tetrahedra = kuhn_block((4, 4, 4), H / 4)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=5.0,
                           density=1000.0, law="neo-hookean")


def _top(model):
    return np.flatnonzero(np.isclose(model.mesh.rest_positions[:, 2], H))


def _ramp(amount):
    """Over 0.3 s to ``amount``, then held for 0.29 s (frames 10 ms apart)."""
    return np.minimum(np.arange(FRAMES) / 30, 1.0)[:, None] * np.asarray(amount, float)


def test_a_plate_ramped_and_held_settles_at_the_static_equilibrium(gel):
    top = _top(gel)
    run = simulate_implicit(gel, dt=0.01, n_frames=FRAMES, iterations=10,
                            driven=[DrivenPath(top, _ramp((0, 0, -0.1 * H)))])
    held = equilibrium(gel, driven=Driven(top, (0, 0, -0.1 * H)), increments=2)
    np.testing.assert_allclose(run.positions[-1], held.positions, atol=1e-9)
    assert run.reactions[-1, 0, 2] == pytest.approx(held.reaction_on(top)[2], rel=1e-6)
    np.testing.assert_allclose(run.positions[:, top, 2] - gel.mesh.rest_positions[top, 2],
                               np.repeat(_ramp((0, 0, -0.1 * H))[:, 2:], len(top), axis=1),
                               atol=1e-15)
    # half way down the ramp the viscous gel pushes back harder than at rest there, by a
    # force proportional to its viscosity (the plate's speed is steady there)
    half = equilibrium(gel, driven=Driven(top, (0, 0, -0.05 * H)), increments=2)
    excess = run.reactions[15, 0, 2] - half.reaction_on(top)[2]
    thicker = simulate_implicit(gel.with_elements(viscosity=10.0), dt=0.01, n_frames=16,
                                iterations=10,
                                driven=[DrivenPath(top, _ramp((0, 0, -0.1 * H))[:16])])
    assert excess < 0
    assert thicker.reactions[15, 0, 2] - half.reaction_on(top)[2] == pytest.approx(
        2 * excess, rel=0.05)


def test_a_sphere_pressed_and_held_settles_at_the_static_contact_force(gel):
    centre = np.array([H / 2, H / 2, H + R])
    path = centre + _ramp((0, 0, -1e-3))
    run = simulate_implicit(gel, dt=0.01, n_frames=FRAMES, tool=ToolPath(Sphere(R), path))
    held = equilibrium(gel, contact=contact_with(gel, Sphere(R), path[-1]), increments=4,
                       tool_start=centre)
    np.testing.assert_allclose(run.tool_forces[-1], held.contact_force, rtol=1e-4,
                               atol=1e-6 * abs(held.contact_force[2]))
    assert run.tool_forces[0, 2] == 0.0 and run.tool_forces[20, 2] < 0
    assert np.abs(run.positions[-1] - held.positions).max() < 1e-8


@pytest.mark.parametrize("case, words", [
    ("short", "needs one finite row per frame"),
    ("fixed", "overlaps the fixed nodes"),
    ("inside", "starts inside the body"),
    ("tool_short", "at each of the 60 frames"),
])
def test_bad_moving_boundaries_are_refused(gel, case, words):
    top = _top(gel)
    options = {}
    if case == "short":
        options["driven"] = [DrivenPath(top, _ramp((0, 0, -1e-3))[:10])]
    elif case == "fixed":
        options["driven"] = [DrivenPath(np.array([0, *top]), _ramp((0, 0, -1e-3)))]
    elif case == "inside":
        options["tool"] = ToolPath(Sphere(R), np.tile([H / 2, H / 2, H + R - 1e-3],
                                                      (FRAMES, 1)))
    else:
        options["tool"] = ToolPath(Sphere(R), np.tile([H / 2, H / 2, H + R], (10, 1)))
    with pytest.raises(InputError, match=words):
        simulate_implicit(gel, dt=0.01, n_frames=FRAMES, **options)


@pytest.mark.parametrize("boundary", ["plate", "tool"])
def test_the_derivatives_of_driven_and_touched_runs_are_central_differences(boundary):
    """``implicit_sensitivities(driven=…, tool=…, forces=True)``: the derivatives of the
    markers' positions and of the plate's reaction (or the sphere's force) by E, ν and η,
    through converged backward Euler steps, against central differences of the run
    (within 1e-5 of the largest)."""
    from neurofuzzy.simulation.implicit_derivatives import (PARAMETERS,
                                                            implicit_sensitivities)

    points, tetrahedra = kuhn_block((2, 2, 2), H / 2)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=5.0,
                            density=1000.0, law="neo-hookean")
    frames = 8
    path = np.minimum(np.arange(frames) / 4, 1.0)[:, None]
    if boundary == "plate":
        options = {"driven": [DrivenPath(_top(model), path * (0, 0, -0.1 * H))]}
    else:
        centre = np.array([H / 2, H / 2, H + R])
        options = {"tool": ToolPath(Sphere(R), centre + path * (0, 0, -1e-3))}

    def run(m):
        out = simulate_implicit(m, dt=0.01, n_frames=frames, iterations=50,
                                tolerance=1e-13, **options)
        force = out.reactions[:, 0] if boundary == "plate" else out.tool_forces
        return out.positions, force

    trajectory, derivatives, forces = implicit_sensitivities(
        model, dt=0.01, n_frames=frames, tolerance=1e-13, forces=True, **options)
    measured = (trajectory.reactions[:, 0] if boundary == "plate"
                else trajectory.tool_forces)
    assert np.allclose(measured, run(model)[1], rtol=1e-9, atol=1e-12)
    d_force = forces.reactions[:, :, 0] if boundary == "plate" else forces.tool_forces
    assert (forces.tool_forces is None) == (boundary == "plate")
    for k, name in enumerate(PARAMETERS):
        step = 1e-6 * getattr(model.elements, name)[0]
        (up_x, up_f), (down_x, down_f) = (
            run(model.with_elements(**{name: getattr(model.elements, name)[0] + s}))
            for s in (step, -step))
        for got, central in ((derivatives[:, k], (up_x - down_x) / (2 * step)),
                             (d_force[:, k], (up_f - down_f) / (2 * step))):
            assert np.abs(central).max() > 0
            assert np.abs(got - central).max() < 1e-5 * np.abs(central).max(), name


def _ramped_gel():
    """``(truth, data, σ_f)``: a neo-Hookean gel's top ramped 10 % down in 40 ms and held,
    40 frames 2 ms apart, its nodes with 2 µm noise and its load cell with σ_f, 1 % of the
    peak force."""
    from neurofuzzy.experiment import Experiment

    points, tetrahedra = kuhn_block((2, 2, 2), H / 2)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                            viscosity=20.0, density=1000.0, law="neo-hookean")
    frames = 40
    driven = [DrivenPath(_top(truth), np.minimum(np.arange(frames) / 20, 1.0)[:, None]
                         * (0, 0, -0.1 * H))]
    clean = simulate_implicit(truth, dt=0.002, n_frames=frames, iterations=50,
                              tolerance=1e-12, driven=driven, scheme="bdf2")
    rng = np.random.default_rng(1)
    sigma_f = 0.01 * np.abs(clean.reactions[:, 0]).max()
    positions = clean.positions + rng.normal(0.0, 2e-6, clean.positions.shape)
    positions[0] = clean.positions[0]
    reaction = clean.reactions[:, 0] + rng.normal(0.0, sigma_f, (frames, 3))
    return truth, Experiment(mesh=mesh, dt=0.002, positions=positions, driven=driven,
                             reaction=reaction), sigma_f


def test_a_fit_from_a_ramped_plate_and_its_load_cell_recovers_e_nu_eta_and_the_noise():
    """``fit_implicit(driven=…, reaction=…)``: a gel's top ramped 10 % down in 40 ms and held
    (frames 2 ms apart), its nodes with 2 µm noise and the load cell's with 1 % of its peak:
    from a start 33 % off in E, 0.05 in ν and half η, E, ν and η come back within 2 %, and
    the noise estimated from the residuals is the noise put in, within 15 % (measured:
    +0.19 %, -0.00001, +0.6 %; the noise -1.2 % and -0.3 %, from the residuals' third
    differences in time; their RMS gave +0.8 % and +4.8 %)."""
    from neurofuzzy.experiment import rms_error
    from neurofuzzy.learn.implicit_fit import fit_implicit

    truth, data, sigma_f = _ramped_gel()
    reaction = data.reaction
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0)
    fitted = fit_implicit(start, data, scheme="bdf2")
    assert fitted.values["youngs_modulus"][0] == pytest.approx(6000.0, rel=0.02)
    assert fitted.values["poisson_ratio"][0] == pytest.approx(0.45, abs=0.01)
    assert fitted.values["viscosity"][0] == pytest.approx(20.0, rel=0.02)
    assert fitted.estimated == ("markers", "force")
    assert fitted.marker_noise == pytest.approx(2e-6, rel=0.15)
    assert fitted.force_noise == pytest.approx(sigma_f, rel=0.15)
    with pytest.raises(InputError, match="one force per frame"):
        data.replace(reaction=reaction[:10])
    with pytest.raises(InputError, match="needs what it measures"):
        data.replace(driven=())
    with pytest.raises(InputError, match="40 frames, so expected"):
        data.replace(driven=[DrivenPath(_top(truth), np.zeros((10, 3)))])
    with pytest.raises(InputError, match="which implicit steps follow"):
        rms_error(truth, data)
    assert data.first_frames(10).reaction.shape == (10, 3)


def test_a_misfit_the_model_cannot_follow_does_not_become_the_load_cell_s_noise():
    """A load cell that reads 8 % of the peak force more in a smooth bump over the recording
    (a force no gel of this model makes: a misfit, not noise). The noise estimated from the
    residuals' third differences in time stays the 1 % put in (measured: 1.000×), while the
    force's residuals are 1.7× it: the RMS of the residuals, the estimate before, would have
    taken the misfit for noise and let the force lose its weight."""
    from neurofuzzy.learn.implicit_fit import fit_implicit

    truth, data, sigma_f = _ramped_gel()
    peak = np.abs(data.reaction).max()
    bump = 0.08 * peak * np.sin(np.pi * np.linspace(0.0, 1.0, data.n_frames))
    data = data.replace(reaction=data.reaction + bump[:, None] * (0.0, 0.0, 1.0))
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0)
    fitted = fit_implicit(start, data, scheme="bdf2")
    assert fitted.force_rms_error > 1.5 * sigma_f
    assert fitted.force_noise == pytest.approx(sigma_f, rel=0.15)
    assert fitted.marker_noise == pytest.approx(2e-6, rel=0.15)


@pytest.mark.slow
def test_the_mesh_check_of_a_time_fit_refits_on_the_refined_mesh():
    """``implicit_mesh_check``: beads in a gel made on a mesh refined once (each tetrahedron
    in eight), the plate ramped and its load cell read; the fit on the coarse mesh is biased
    by its elements, the refit on the refined one (the data's own) recovers E, ν and η within
    1 %, and the extrapolation moves each value on by as much again (measured: E 5,615 Pa on
    the coarse mesh, ν 0.422, η 13.4 Pa·s; refined 6,000, 0.450, 20.0)."""
    from neurofuzzy.experiment import Experiment
    from neurofuzzy.learn.implicit_fit import fit_implicit
    from neurofuzzy.learn.implicit_mesh_check import implicit_mesh_check
    from neurofuzzy.learn.mesh_check import refine_model
    from neurofuzzy.observation import EmbeddedMarkers, embed_points

    points, tetrahedra = kuhn_block((2, 2, 2), H / 2)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    coarse = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                             viscosity=20.0, density=1000.0, law="neo-hookean")
    truth, _ = refine_model(coarse)
    frames, dt = 30, 0.002
    path = np.minimum(np.arange(frames) / 15, 1.0)[:, None] * (0, 0, -0.1 * H)
    run = simulate_implicit(truth, dt=dt, n_frames=frames, iterations=50, tolerance=1e-12,
                            driven=[DrivenPath(_top(truth), path)], scheme="bdf2")
    beads = np.random.default_rng(2).uniform(0.2 * H, 0.8 * H, (30, 3))

    nodes, weights, _ = embed_points(truth.mesh, beads)
    seen = np.einsum("mk,fmkj->fmj", weights, run.positions[:, nodes])
    nodes, weights, _ = embed_points(coarse.mesh, beads)
    data = Experiment(mesh=coarse.mesh, dt=dt,
                      positions=np.full((frames, coarse.n_nodes, 3), np.nan),
                      observed=np.zeros(coarse.n_nodes, bool),
                      markers=EmbeddedMarkers(nodes, weights, seen),
                      driven=[DrivenPath(_top(coarse), path)], reaction=run.reactions[:, 0])
    options = {"scheme": "bdf2", "marker_noise": 1e-6, "force_noise": 1e-3}
    fitted = fit_implicit(coarse, data, **options)
    checked = implicit_mesh_check(fitted, data, **options)
    for name, true in (("youngs_modulus", 6000.0), ("poisson_ratio", 0.45),
                       ("viscosity", 20.0)):
        values = checked.mesh_check[name]
        assert values["refined"][0] == pytest.approx(true, rel=0.01), name
        assert values["extrapolated"][0] - values["refined"][0] == pytest.approx(
            values["refined"][0] - values["mesh"][0], rel=1e-9)
    assert abs(fitted.values["youngs_modulus"][0] / 6000.0 - 1) > 0.02
    assert checked.mesh_check["elements"] == (48, 384)


@pytest.mark.slow
def test_a_fit_from_a_sphere_pressed_in_time_recovers_e_nu_eta():
    """``fit_implicit`` of an experiment whose ``tool`` is a sphere pressed 1.5 mm into the
    gel along a path in time, its force read by a load cell, the top's nodes recorded (1 µm
    noise): from a start 33 % off in E, 0.05 in ν and half η, E, ν and η come back within
    3 %, 0.01 and 10 % (the contact's penalty scales with E as the derivatives have it)."""
    from neurofuzzy.experiment import Experiment
    from neurofuzzy.learn.implicit_fit import fit_implicit

    points, tetrahedra = kuhn_block((4, 4, 2), H / 4)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                            viscosity=20.0, density=1000.0, law="neo-hookean")
    frames = 30
    centre = np.array([H / 2, H / 2, H / 2 + R])
    tool = ToolPath(Sphere(R), centre + np.minimum(np.arange(frames) / 15, 1.0)[:, None]
                    * (0, 0, -1.5e-3))
    clean = simulate_implicit(truth, dt=0.002, n_frames=frames, tolerance=1e-12, tool=tool,
                              scheme="bdf2")
    rng = np.random.default_rng(5)
    positions = clean.positions + rng.normal(0.0, 1e-6, clean.positions.shape)
    positions[0] = clean.positions[0]
    reaction = clean.tool_forces + 0.01 * np.abs(clean.tool_forces).max() * rng.normal(
        size=(frames, 3))
    data = Experiment(mesh=mesh, dt=0.002, positions=positions, tool=tool,
                      reaction=reaction)
    assert np.abs(clean.tool_forces[-1, 2]) > 0.05          # the sphere presses
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0)
    fitted = fit_implicit(start, data, scheme="bdf2")
    assert fitted.values["youngs_modulus"][0] == pytest.approx(6000.0, rel=0.03)
    assert fitted.values["poisson_ratio"][0] == pytest.approx(0.45, abs=0.01)
    assert fitted.values["viscosity"][0] == pytest.approx(20.0, rel=0.1)
