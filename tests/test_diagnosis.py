"""Diagnosis: hidden effects in data from our simulator are named, located and removed."""

import numpy as np
import pytest

from neurofuzzy.datasets import (CUBE, paper_cube_experiment, paper_cube_model, point_load,
                                 top_centre_node)
from neurofuzzy.diagnosis import diagnose
from neurofuzzy.effects import (Gravity, NodeDrag, NonlinearStiffening, SoftInclusion,
                                StiffInclusion, UnmodeledLoad)
from neurofuzzy.validation.integrators import reference_experiment

TRUTH = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0})
CENTRE = [j for j in range(86) if 13 in TRUTH.mesh.springs[j]]      # springs around node 13
NOISE = 0.002 * CUBE["edge_length"]                                  # 0.2 % of the edge

HIDDEN = {
    "gravity": lambda: Gravity([0.0, 0.0, -9.81]),
    "node_drag": lambda: NodeDrag([0.03]),
    "stiff_inclusion": lambda: StiffInclusion.for_model(TRUTH, [120.0, 70.0], springs=CENTRE),
    "soft_inclusion": lambda: SoftInclusion.for_model(TRUTH, [-36.0, -21.0], springs=CENTRE),
    "nonlinear_stiffening": lambda: NonlinearStiffening.for_model(TRUTH, [600.0, 350.0]),
    "unmodeled_load": lambda: UnmodeledLoad([0.05, 0.0, 0.0], node=26),
}


def start_model():
    return paper_cube_model(stiffness=50.0, damping=0.03, tie="groups")


def overlap(found, truth) -> float:
    truth = set(truth)
    return len(set(found) & truth) / len(truth)


def check_found(result, hidden):
    assert result.names == [hidden.name]
    finding = result.effects[0]
    assert 0.5 < finding.confidence <= 1.0
    if hidden.springs.size:
        assert overlap(finding.springs, hidden.springs) >= 0.8
        assert overlap(hidden.springs, finding.springs) >= 0.8        # few false springs
    if hidden.nodes.size:
        assert overlap(finding.nodes, hidden.nodes) >= 0.8
    assert finding.gap_after * 10 <= finding.gap_before
    assert result.rms_after < result.rms_before


def test_none_on_clean_data_without_an_effect(cube_experiment):
    result = diagnose(start_model(), paper_cube_experiment(TRUTH))
    assert result.names == ["none"] and result.effects == []
    assert result.model_.effects == () and result.rms_after < 1e-9   # fits exactly as it is
    assert result.candidates                              # still says what it tried
    assert result.to_dict()["answer"] == ["none"]


def test_no_candidate_below_one_at_the_noise_is_refitted(capsys):
    """Hidden gravity on the cube: its refit reaches the noise, so the four candidates
    ranked below it are not refitted (they could only tie within the noise); the answer is
    the one refitting them all gave."""
    hidden = paper_cube_model().with_effects(Gravity([0.0, 0.0, -9.81]))
    result = diagnose(start_model(), paper_cube_experiment(hidden), progress=True)
    said = capsys.readouterr().err
    assert result.names == ["gravity"]
    assert result.effects[0].parameters["gz"] == pytest.approx(-9.81, rel=1e-6)
    assert "gravity (ranked 1), refitted" in said and "(ranked 2)" not in said
    assert "the 4 candidate(s) after it are not refitted" in said


def test_diagnose_data_starts_checks_and_answers_as_the_command(tmp_path):
    """``diagnose_data``, what ``neurofuzzy diagnose`` runs: the fit's start from a model
    file, the inputs checked, the same answer as :func:`diagnose` of that model."""
    from neurofuzzy.diagnosis import DiagnosedData, diagnose_data
    from neurofuzzy.errors import InputError
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.io import save_experiment, save_model

    data = paper_cube_experiment(paper_cube_model().with_effects(Gravity([0.0, 0.0, -9.81])))
    path = save_experiment(data, tmp_path / "gravity.npz")
    start = save_model(start_model(), tmp_path / "start.yaml")
    run = diagnose_data(path, start=start, max_effects=1)
    direct = diagnose(start_model(), data, max_effects=1)
    assert isinstance(run, DiagnosedData) and run.diagnosis.names == direct.names == ["gravity"]
    assert run.diagnosis.rms_after == pytest.approx(direct.rms_after, rel=1e-6, abs=1e-12)
    assert run.model is run.diagnosis.model_ and run.start.how == "model"
    summary = run.to_dict()
    assert summary["answer"] == ["gravity"] and summary["experiments"] == [str(path)]
    assert summary["start"]["how"] == "model" and "rules" not in summary
    with pytest.raises(InputError, match="rule base to locate an inclusion"):
        diagnose_data(data, start=start_model(), localise=True)
    still = simulate_experiment(TRUTH, dt=data.dt, n_frames=20)
    with pytest.raises(InputError, match="motion|move"):
        diagnose_data(still, start=start_model())


def test_out_of_time_the_answer_so_far_is_provisional(capsys):
    """max_time spent after the first fit: no candidate is refitted, the answer is what the
    fitted model says (it misses the data: unexplained), marked provisional with what was
    left out; with time enough the same data give gravity and nothing provisional."""
    data = paper_cube_experiment(paper_cube_model().with_effects(Gravity([0.0, 0.0, -9.81])))
    hurried = diagnose(start_model(), data, max_time=1e-6, progress=True)
    said = capsys.readouterr().err
    assert hurried.effects == [] and hurried.names == ["unexplained"]
    assert hurried.provisional.startswith("stopped after ")
    assert hurried.provisional.endswith(" s of max_time 1e-06 s: 5 of 5 candidates of round 1 "
                                        "not refitted")
    assert hurried.verdict.startswith("provisional (stopped after")
    assert hurried.to_dict()["provisional"] == hurried.provisional
    assert "refitting" not in said and "the answer is provisional" in said
    calm = diagnose(start_model(), data, max_time=600.0, progress=True)
    said = capsys.readouterr().err
    assert calm.names == ["gravity"] and calm.provisional is None
    assert "refitting gravity (1 of 5; about " in said and " s left in this round)" in said


@pytest.mark.parametrize("seconds", [0.0, -1.0, float("nan")])
def test_max_time_must_be_positive(seconds):
    from neurofuzzy.errors import InputError

    with pytest.raises(InputError, match="expected a positive number of seconds"):
        diagnose(start_model(), paper_cube_experiment(TRUTH), max_time=seconds)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(HIDDEN))
def test_hidden_effect_is_named_located_and_removed(name):
    hidden = HIDDEN[name]()
    result = diagnose(start_model(), paper_cube_experiment(TRUTH.with_effects(hidden)))
    check_found(result, hidden)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(HIDDEN))
def test_hidden_effect_with_marker_noise(name):
    hidden = HIDDEN[name]()
    data = paper_cube_experiment(TRUTH.with_effects(hidden), noise=NOISE, seed=5)
    result = diagnose(start_model(), data)
    check_found(result, hidden)
    assert result.noise_rms == pytest.approx(NOISE * np.sqrt(3), rel=0.1)


@pytest.mark.slow
def test_none_on_noisy_data_without_an_effect():
    result = diagnose(start_model(), paper_cube_experiment(TRUTH, noise=NOISE, seed=3))
    assert result.names == ["none"]


@pytest.mark.slow
def test_no_effect_is_made_up_on_clean_data_from_another_integrator():
    """Noise-free RK4 data: what is left is the integrator's error, not a missing effect. No
    effect is added, and the answer says the small misfit is unexplained rather than none
    (the data carry no noise to hide it in)."""
    load = point_load(TRUTH.mesh, top_centre_node(TRUTH.mesh), CUBE["force"])
    data = reference_experiment(TRUTH, dt=CUBE["dt"], n_frames=251, external_forces=load,
                                method="rk4", substeps=10)
    result = diagnose(start_model(), data)
    assert result.effects == [] and result.names == ["unexplained"]
    assert result.lack_of_fit.noise == 0 and result.rms_after < 1e-5          # 10 µm
    assert "no measurable noise" in result.verdict


@pytest.mark.slow
@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_two_effects_are_found_one_after_the_other(noise):
    inclusion = SoftInclusion.for_model(TRUTH, [-36.0, -21.0], springs=CENTRE)
    data = paper_cube_experiment(TRUTH.with_effects(Gravity([0, 0, -9.81]), inclusion),
                                 noise=noise, seed=2)
    result = diagnose(start_model(), data)
    assert sorted(result.names) == ["gravity", "soft_inclusion"]
    found = {f.name: f for f in result.effects}
    assert overlap(found["soft_inclusion"].springs, CENTRE) >= 0.8
    assert found["gravity"].parameters["gz"] == pytest.approx(-9.81, rel=0.02)
    gap_first = result.effects[0].gap_before
    assert result.effects[-1].gap_after * 10 <= gap_first


def test_the_inclusion_region_search_makes_the_moves_of_the_definition(monkeypatch):
    """The region search scores every trial from one product (|c ± t_j|², (c ± t_j)·r); it
    grows the region the definition does: from the best star, add or drop the neighbouring
    spring that explains most of the residual (the explained share of the region's summed
    template, recomputed from scratch here) while it gains at least REGION_GAIN."""
    from types import SimpleNamespace

    from neurofuzzy.diagnosis import candidates

    model = paper_cube_model()
    rng = np.random.default_rng(4)
    n = 300
    templates = rng.normal(size=(n, model.n_springs))
    springs = model.mesh.springs
    region_truth = np.flatnonzero((springs[:, 0] == 13) | (springs[:, 1] == 13))[:4]
    target = templates[:, region_truth].sum(axis=1) * 3.0 + rng.normal(0, 0.5, n)
    base = rng.normal(size=(n, 2))
    monkeypatch.setattr(candidates, "spring_templates", lambda model, samples: templates)
    found = candidates.inclusion_region(model, SimpleNamespace(force=target), set(), base)

    basis = np.linalg.qr(base)[0]
    t = templates - basis @ (basis.T @ templates)
    r = target - basis @ (basis.T @ target)

    def explained(region):
        column = t[:, sorted(region)].sum(axis=1)
        return (column @ r) ** 2 / (column @ column) / (r @ r)

    stars = [set(np.flatnonzero((springs[:, 0] == k) | (springs[:, 1] == k)).tolist())
             for k in range(model.n_nodes)]
    region = max(stars, key=explained)
    best = explained(region)
    while True:
        nodes = np.unique(springs[sorted(region)])
        border = [j for j in np.flatnonzero(np.isin(springs, nodes).any(axis=1))
                  if j not in region]
        trials = [(explained(region | {j}), region | {j}) for j in border]
        trials += [(explained(region - {j}), region - {j}) for j in region if len(region) > 1]
        gain, moved = max(trials, key=lambda trial: trial[0])
        if gain < best + candidates.REGION_GAIN:
            break
        region, best = moved, gain
    assert found == sorted(region)
    assert set(region_truth) <= set(found)


def test_spring_templates_are_each_springs_force_at_its_two_nodes():
    """The spring templates, built for all frames at once, are the stacked per-frame force
    templates ``s_j (l - L0) u_j`` of every spring (the generic :func:`templates` of a
    per-frame force, the definition)."""
    from neurofuzzy.diagnosis.residuals import sample, spring_templates, templates
    from neurofuzzy.forces import incidence

    model = paper_cube_model()
    data = paper_cube_experiment(model).first_frames(60)
    samples = sample(model.with_springs(stiffness=model.springs.stiffness * 0.8), [data], 1)
    maps = incidence(model.mesh)

    def force_of(p, v):
        force = model.springs.stiffness[:, None] * model.springs.parameter_templates(
            model.springs.state(model, p, v))["stiffness"]
        return maps.group_sums(force, np.arange(model.n_springs), model.n_springs)

    definition = templates(model, samples, force_of)
    built = spring_templates(model, samples)
    assert built.shape == definition.shape == (len(samples.force) * 3, model.n_springs)
    assert np.abs(definition).max() > 0
    np.testing.assert_allclose(built, definition, rtol=0, atol=1e-12 * np.abs(definition).max())
