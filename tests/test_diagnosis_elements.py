"""The diagnosis of element models from embedded surface markers: nothing, hidden gravity and a
hidden stiffer region of elements, in noisy data of our own simulator (the continuum data of
another solver are in tests/test_examples.py, marked slow)."""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.diagnosis import diagnose
from neurofuzzy.effects import Gravity, StiffInclusion
from neurofuzzy.experiment import Experiment, simulate_experiment
from neurofuzzy.mesh import from_tetra, patch_loads
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from neurofuzzy.simulation import stability_limit

E, NU, ETA, RHO = 6000.0, 0.3, 2.0, 1050.0
SHAPE, CELL = (4, 4, 3), 0.01
NOISE = 5e-6
DT, FRAMES = 1e-3, 61


def block(youngs_modulus=E):
    mesh = from_tetra(*kuhn_block(SHAPE, CELL)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=youngs_modulus, poisson_ratio=NU,
                           viscosity=ETA, density=RHO)


def surface_markers():
    """A 5 mm grid on the top and on the sides x = 0 and y = 0 (not on the held base)."""
    grid = np.arange(0.0025, 0.04, 0.005)
    heights = np.arange(0.0025, 0.03, 0.005)
    return np.array([(x, y, 0.03) for x in grid for y in grid]
                    + [(x, 0.0, z) for x in grid for z in heights]
                    + [(0.0, y, z) for y in grid for z in heights])


def measured(truth, seed=1, force=0.05):
    """Noisy embedded-marker data of ``truth`` pushed by a probe on its top."""
    load = patch_loads(truth.mesh, (0.02, 0.02, 0.03), 0.01, (0.0, 0.0, -force))
    steps = int(np.ceil(DT / stability_limit(truth).max_step))
    data = simulate_experiment(truth, dt=DT, n_frames=FRAMES, external_forces=load,
                               substeps=steps)
    nodes, weights, _ = embed_points(truth.mesh, surface_markers())
    seen = np.einsum("mk,tmkj->tmj", weights, data.positions[:, nodes])
    seen = seen + np.random.default_rng(seed).normal(0.0, NOISE, seen.shape)
    positions = np.full_like(data.positions, np.nan)
    positions[0] = truth.mesh.rest_positions
    return Experiment(mesh=truth.mesh, dt=DT, positions=positions,
                      external_forces=data.external_forces, node_mass=truth.node_mass,
                      markers=EmbeddedMarkers(nodes=nodes, weights=weights, positions=seen),
                      observed=np.zeros(truth.n_nodes, bool))


def start():
    """A start 30 % too soft, as a rule base's first guess might be."""
    return block(0.7 * E)


def region_centre(model, elements):
    corners = model.mesh.rest_positions[model.mesh.tetrahedra[elements]]
    return corners.mean(axis=(0, 1))


def test_nothing_hidden_answers_none(capsys, tmp_path):
    """At the noise with nothing significant left, the answer is none before any candidate
    is scored (their evidence, a scan of inclusion balls, is most of a diagnosis's time);
    the round keeps its residuals, which the report draws."""
    from neurofuzzy.report import diagnosis_report

    result = diagnose(start(), measured(block()), progress=True)
    assert result.names == ["none"]
    assert result.rms_after < 1.5 * result.noise_rms
    [round_info] = result.rounds
    assert round_info["candidates"] == [] and result.candidates == []
    said = capsys.readouterr().err
    assert "nothing left to explain, so no candidate scored" in said and "scoring" not in said
    diagnosis_report(result, tmp_path / "d.html")
    assert "none" in (tmp_path / "d.html").read_text()


@pytest.mark.slow
def test_hidden_gravity_is_named_and_measured():
    truth = block().with_effects(Gravity([0.0, 0.0, -9.81]))
    result = diagnose(start(), measured(truth))
    assert result.names[0] == "gravity"
    g = np.array(list(result.effects[0].parameters.values()))
    assert g[2] == pytest.approx(-9.81, rel=0.05) and np.abs(g[:2]).max() < 0.5
    assert result.effects[0].centroid is None
    assert result.rms_after < 1.5 * result.noise_rms < result.rms_before


@pytest.mark.slow
def test_hidden_stiff_region_is_found_with_its_centroid_inside():
    truth = block()
    geometry = truth.mesh.rest_positions[truth.mesh.tetrahedra].mean(axis=1)
    inside = np.flatnonzero(np.all(np.abs(geometry - (0.015, 0.02, 0.015)) < 0.01, axis=1))
    hidden = StiffInclusion.of_elements(truth, inside, 4 * E)
    result = diagnose(start(), measured(truth.with_effects(hidden)))
    assert result.names[0] == "stiff_inclusion"
    finding = result.effects[0]
    assert finding.elements and finding.nodes
    low = truth.mesh.rest_positions[truth.mesh.tetrahedra[inside]].min(axis=(0, 1))
    high = truth.mesh.rest_positions[truth.mesh.tetrahedra[inside]].max(axis=(0, 1))
    assert np.all((low <= finding.centroid) & (finding.centroid <= high)), finding.centroid
    assert finding.to_dict()["centroid"] == finding.centroid
    assert result.rms_after < result.rms_before


@pytest.mark.slow
def test_hidden_strain_stiffening_switches_the_law_to_yeoh_s():
    """A probe pressing 6 times harder (about 15 % strain) on tissue that stiffens with
    strain (Yeoh, C20 = 8 C10), diagnosed from a neo-Hookean start: the diagnosis names
    nonlinear_stiffening, makes the elements Yeoh's (not a force patch: no effect added) and
    recovers C20/C10; on neo-Hookean data it names none."""
    truth = block().with_elements(law="yeoh", stiffening=8.0)
    neo_hookean = start().with_elements(law="neo-hookean")
    result = diagnose(neo_hookean, measured(truth, force=0.3))
    assert result.names == ["nonlinear_stiffening"]
    assert set(result.model_.elements.law) == {2} and not result.model_.effects
    assert result.effects[0].parameters["stiffening"] == pytest.approx(8.0, rel=0.1)
    assert result.rms_after < 1.5 * result.noise_rms
    plain = diagnose(neo_hookean, measured(block().with_elements(law="neo-hookean"),
                                           force=0.3))
    assert plain.names == ["none"]


def test_the_ball_scan_scores_exactly_only_a_shortlist_that_holds_the_best():
    """An inclusion ball's sensitivity column costs about a simulation; the scan's balls are
    shortlisted by ``cᵀt`` from one backward sweep, and only the shortlist gets columns. On a
    hidden stiff region the shortlist holds the ball the exact scores of every ball rank
    first, and is a fraction of the scan."""
    from neurofuzzy.diagnosis.trajectory import TrajectoryEvidence
    from neurofuzzy.learn import GradientLearner

    truth = block()
    centroids = truth.mesh.rest_positions[truth.mesh.tetrahedra].mean(axis=1)
    inside = np.flatnonzero(np.all(np.abs(centroids - (0.015, 0.02, 0.015)) < 0.01, axis=1))
    data = measured(truth.with_effects(StiffInclusion.of_elements(truth, inside, 4 * E)))
    fitted = GradientLearner(substeps="auto").fit(start(), data)
    evidence = TrajectoryEvidence.of(fitted.model_, [data], fitted.substeps_,
                                     fitted.lack_of_fit_.noise_per_coordinate)
    _, balls, _ = evidence.first_scan(set())
    best = balls[int(np.argmax(evidence.ball_gains(balls)))]
    shortlist = evidence.shortlist(balls)
    assert len(shortlist) <= len(balls) // 2
    assert any(np.array_equal(best, members) for members in shortlist)


def test_the_finer_ball_scan_is_skipped_only_where_it_cannot_lift_an_inclusion_to_the_bar():
    """While the model explains the data to the noise, an inclusion must explain
    ``MIN_EXPLAINED`` of the misfit above it. A first scan whose best ball explains less than
    ``FINER_SCAN_SHARE`` of that gives its ball as the region without the finer scan (81
    sensitivity columns on the 4 mm block); one that explains more is refined as ever."""
    from neurofuzzy.diagnosis.trajectory import (FINER_SCAN_SHARE, MIN_EXPLAINED,
                                                 TrajectoryEvidence)
    from neurofuzzy.learn import GradientLearner

    truth = block()
    centroids = truth.mesh.rest_positions[truth.mesh.tetrahedra].mean(axis=1)
    inside = np.flatnonzero(np.all(np.abs(centroids - (0.015, 0.02, 0.015)) < 0.01, axis=1))
    relaxing = truth.with_elements(relaxation_moduli=[0.5], relaxation_times=[0.015])
    # relaxing data leave a misfit no ball explains; a stiff region, one the best ball does
    for data, expect_finer in ((measured(relaxing, force=0.1), False),
                               (measured(truth.with_effects(
                                   StiffInclusion.of_elements(truth, inside, 4 * E))), True)):
        fitted = GradientLearner(substeps="auto").fit(start(), data)
        evidence = TrajectoryEvidence.of(fitted.model_, [data], fitted.substeps_,
                                         fitted.lack_of_fit_.noise_per_coordinate,
                                         at_noise=True)
        scored, gains = [], evidence.ball_gains

        def counted(balls, target=None):
            scored.append(gains(balls, target))
            return scored[-1]

        evidence.ball_gains = counted
        region = evidence.element_region(set())
        first = scored[0].max() / evidence.excess
        assert evidence.excess > 0
        assert (first >= FINER_SCAN_SHARE * MIN_EXPLAINED) == expect_finer
        assert len(scored) == (2 if expect_finer else 1)
        assert region
        if not expect_finer:          # without the flag the finer scan is made
            evidence.at_noise, scored[:] = False, []
            evidence.element_region(set())
            assert len(scored) == 2


def test_relaxation_is_probed_a_little_of_the_way_where_its_secant_is_linear():
    """The evidence of ``relaxation`` is the secant of a switch to relaxing elements. The
    whole switch (g = 0.5) is far outside the linear range; a tenth of it explains much
    more of the misfit of a Kelvin–Voigt fit to relaxing data, and is what is scored."""
    from neurofuzzy.diagnosis.trajectory import TrajectoryEvidence
    from neurofuzzy.effects import Relaxation
    from neurofuzzy.effects.relaxation import PROBE_RELATIVE_MODULUS
    from neurofuzzy.experiment import duration
    from neurofuzzy.learn import GradientLearner

    truth = block().with_elements(relaxation_moduli=[0.5], relaxation_times=[0.015])
    data = measured(truth, force=0.1)
    fitted = GradientLearner(substeps="auto").fit(start(), data)
    evidence = TrajectoryEvidence.of(fitted.model_, [data], fitted.substeps_,
                                     fitted.lack_of_fit_.noise_per_coordinate)
    relaxation = Relaxation([0.0])
    probe = relaxation.probe_switch(fitted.model_, duration([data]))
    assert np.allclose(probe.elements.relaxation_moduli, PROBE_RELATIVE_MODULUS)
    assert np.allclose(probe.elements.relaxation_times,
                       relaxation.switch(fitted.model_, duration([data]))
                       .elements.relaxation_times)
    (scored,) = evidence.score([relaxation])

    class Whole(Relaxation):
        probe_switch = staticmethod(Relaxation.switch)

    (whole,) = evidence.score([Whole([0.0])])
    assert scored.score > 10
    assert scored.explained > 2 * whole.explained


def test_a_relaxation_refit_starts_where_the_linearised_fit_of_its_probe_points():
    """The switch a refit starts from: g = the share of the probe the linearised fit asks for
    times the probe's g, bounded; g = 0.5 without a share."""
    from neurofuzzy.effects.relaxation import MAX_START, PROBE_RELATIVE_MODULUS, Relaxation

    model = block()
    for share, g in ((None, 0.5), (2.74, 2.74 * PROBE_RELATIVE_MODULUS),
                     (-3.0, PROBE_RELATIVE_MODULUS), (1e3, MAX_START),
                     (float("nan"), 0.5)):
        switched = Relaxation.switch(model, 0.33, share=share)
        assert np.allclose(switched.elements.relaxation_moduli, g)
        assert np.allclose(switched.elements.relaxation_times, 0.33 / 5)


def test_the_winner_is_confirmed_without_fitting_again_at_the_step_its_refit_was_made():
    """The diagnosis refits at one step and confirms the winner at two (Richardson); with
    ``fitted_at`` the confirmation does not fit again at the first, which the refit did: the
    same values from fewer simulations."""
    from neurofuzzy.diagnosis.refits import confirm
    from neurofuzzy.learn import GradientLearner, auto_substeps

    data = measured(block(30 * E), force=1.0)     # stiff: stable only at several steps
    begin = block(20 * E)
    k = auto_substeps(begin, DT)
    refit = GradientLearner(substeps=k, windows=(), mesh_check=False).fit(begin, data)
    assert refit.substeps_ == k > 1
    again = GradientLearner(substeps="auto", windows=(), mesh_check=False).fit(refit.model_,
                                                                                data)
    confirmed = confirm(refit, [data])
    # the fitted model is stiffer than the start and would take more steps by itself; its
    # refit's are stable, so they are the first of the two
    assert auto_substeps(refit.model_, DT) > k
    assert confirmed.substeps_ == 2 * k
    # to the noise, and the values of a fit at the fitted model's own steps (other steps:
    # equal up to the integrator's error on our discrete data)
    assert confirmed.lack_of_fit_.explained and again.lack_of_fit_.explained
    assert confirmed.model_.elements.youngs_modulus == pytest.approx(
        again.model_.elements.youngs_modulus, rel=5e-3)
    assert len(confirmed.history_) < len(again.history_)


def test_a_relaxation_refit_starts_from_the_linearised_step_of_its_own_parameters_too():
    """A Prony term's g makes the elements stiffer at once, which the fitted E had made up
    for: the refit of relaxation starts from the model's own parameters moved by the
    linearised fit with the probe, and that start is nearer the data than the fitted
    values with the same g."""
    from neurofuzzy.diagnosis.refits import _with_candidate
    from neurofuzzy.diagnosis.trajectory import TrajectoryEvidence
    from neurofuzzy.effects import Relaxation
    from neurofuzzy.experiment import duration, rms_error
    from neurofuzzy.learn import GradientLearner

    truth = block().with_elements(relaxation_moduli=[0.5], relaxation_times=[0.015])
    data = measured(truth, force=0.1)
    fitted = GradientLearner(substeps="auto").fit(start(), data)
    evidence = TrajectoryEvidence.of(fitted.model_, [data], fitted.substeps_,
                                     fitted.lack_of_fit_.noise_per_coordinate)
    (candidate,) = evidence.score([Relaxation([0.0])])
    stepped = _with_candidate(candidate, fitted.model_, evidence, [data])
    own, share = evidence.linearised_step(candidate.effect)
    plain = Relaxation.switch(fitted.model_, duration([data]), share=float(share[0]))
    assert np.allclose(stepped.elements.relaxation_moduli, plain.elements.relaxation_moduli)
    assert not np.allclose(stepped.elements.youngs_modulus, plain.elements.youngs_modulus)
    steps = fitted.substeps_
    assert (rms_error(stepped, [data], substeps=steps)
            < rms_error(plain, [data], substeps=steps))
    # from another model than the evidence's (the start's values) only g is linearised
    again = _with_candidate(candidate, start(), evidence, [data])
    assert np.allclose(again.elements.youngs_modulus, start().elements.youngs_modulus)


def test_with_stable_steps_a_fit_goes_on_at_the_steps_its_values_need():
    """A stiff block fitted from a softer start passes through values the start's steps
    cannot simulate stably; with ``stable_steps`` the fit goes on at the steps those need and
    ends stable at the steps it reports, to the noise, at the modulus of the fit without
    (which crept through those values at the start's steps) within the integrator's error
    between the two steps (0.9 %)."""
    from neurofuzzy.learn import GradientLearner, auto_substeps
    from neurofuzzy.learn.steps import stable_at_one_step

    data = measured(block(30 * E), force=1.0)
    begin = block(20 * E)
    k = auto_substeps(begin, DT)
    plain, guarded = (GradientLearner(substeps="auto", windows=(), extrapolate=False,
                                      stable_steps=stable, mesh_check=False).fit(begin, data)
                      for stable in (False, True))
    assert plain.substeps_ == k < guarded.substeps_
    assert stable_at_one_step(guarded.model_, [data], substeps=guarded.substeps_)
    assert guarded.lack_of_fit_.explained
    assert guarded.model_.elements.youngs_modulus == pytest.approx(
        plain.model_.elements.youngs_modulus, rel=0.02)
    assert len(guarded.history_) < len(plain.history_)
