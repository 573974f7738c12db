import numpy as np
import pytest

from neurofuzzy.datasets import CUBE, paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.experiment import rms_error
from neurofuzzy.learn import PaperLearner


def test_tied_constants_are_recovered_within_a_tenth_of_a_percent(cube_experiment):
    """The paper's experiment 3: shared constants, predefined masses, +50 % start offset."""
    start = paper_cube_model(stiffness=1.5 * CUBE["stiffness"], damping=1.5 * CUBE["damping"],
                             tie="global")
    learner = PaperLearner(learning_rate=0.1, cycles=100).fit(start, cube_experiment)
    fitted = learner.model_
    assert np.allclose(fitted.springs.stiffness, CUBE["stiffness"], rtol=1e-3)
    assert np.allclose(fitted.springs.damping, CUBE["damping"], rtol=1e-3)
    assert np.array_equal(fitted.node_mass, start.node_mass)         # masses stay fixed
    assert learner.history_.shape == (100,)
    assert learner.history_[-1] < 1e-4 * learner.history_[0]
    assert learner.rms_error_ < 1e-3 * learner.rms_error_initial_


def test_error_history_is_the_papers_E_with_teacher_forcing(cube_experiment):
    start = paper_cube_model(stiffness=60.0, tie="global")
    learner = PaperLearner(learning_rate=0.0, cycles=2, teacher_forcing_limit=10)
    learner.fit(start, cube_experiment)
    # with η = 0 nothing changes, so both cycles see the same error
    assert learner.history_[0] == pytest.approx(learner.history_[1])
    assert np.array_equal(learner.model_.springs.stiffness, start.springs.stiffness)
    # without teacher forcing, E (eq. 2.2) is half the summed squared free-run error
    free = PaperLearner(learning_rate=0.0, cycles=1, teacher_forcing_limit=10_000)
    energy = free.fit(start, cube_experiment).history_[0]
    count = (cube_experiment.n_frames - 1) * int(cube_experiment.tracked().sum())
    length_unit = np.mean(start.springs.rest_length)          # the network's length unit
    expected = 0.5 * count * (rms_error(start, cube_experiment) / length_unit) ** 2
    assert energy == pytest.approx(expected, rel=1e-9)
    assert learner.history_[0] != pytest.approx(energy, rel=1e-3)   # forcing changes E


def test_learning_masses_improves_the_fit_and_keeps_parameters_positive(cube_experiment):
    rng = np.random.default_rng(3)
    truth = paper_cube_model()
    start = truth.with_springs(stiffness=truth.springs.stiffness * rng.uniform(0.5, 2, 86),
                               damping=truth.springs.damping * rng.uniform(0.5, 2, 86)
                               ).replace(node_mass=truth.node_mass * rng.uniform(0.7, 1.4, 27))
    learner = PaperLearner(learning_rate=0.01, mass_learning_rate=0.1, learn_masses=True,
                           cycles=30).fit(start, cube_experiment)
    fitted = learner.model_
    assert learner.rms_error_ < 0.5 * learner.rms_error_initial_
    assert np.all(fitted.springs.stiffness > 0) and np.all(fitted.springs.damping > 0)
    assert np.all(fitted.node_mass > 0)
    assert not np.array_equal(fitted.node_mass, start.node_mass)
    assert np.array_equal(fitted.node_mass[truth.mesh.fixed], start.node_mass[truth.mesh.fixed])


@pytest.mark.slow      # the fast suite covers eq. 3.22 with surface markers and gaps
def test_unobserved_inner_node_eq_3_22():
    """The centre node (13) has no marker; its springs are still learned from the others."""
    truth = paper_cube_model()
    observed = np.ones(27, bool)
    observed[13] = False
    data = paper_cube_experiment(truth).replace(observed=observed)
    data = data.replace(positions=np.where(observed[None, :, None], data.positions, np.nan))
    start = paper_cube_model(stiffness=1.3 * CUBE["stiffness"], damping=1.3 * CUBE["damping"],
                             tie="global")
    learner = PaperLearner(learning_rate=0.1, cycles=60).fit(start, data)
    assert learner.model_.springs.stiffness[0] == pytest.approx(CUBE["stiffness"], rel=5e-3)
    assert learner.rms_error_ < 0.01 * learner.rms_error_initial_


@pytest.mark.slow
def test_several_experiments_are_learned_together(cube_model):
    push = paper_cube_experiment(cube_model)
    pull = paper_cube_experiment(cube_model, force=(0.1, 0.0, 0.0), node=26)
    start = paper_cube_model(stiffness=70.0, damping=0.025, tie="global")
    learner = PaperLearner(learning_rate=0.1, cycles=40).fit(start, [push, pull])
    assert rms_error(learner.model_, [push, pull]) < 0.01 * rms_error(start, [push, pull])


def test_bad_options_and_mismatched_data(cube_experiment):
    with pytest.raises(InputError, match="learning_rate"):
        PaperLearner(learning_rate=-1).fit(paper_cube_model(), cube_experiment)
    with pytest.raises(InputError, match="teacher_forcing_limit"):
        PaperLearner(teacher_forcing_limit=0).fit(paper_cube_model(), cube_experiment)
    from neurofuzzy.mesh import lattice
    from neurofuzzy.model import Model
    other = Model.uniform(lattice((2, 2, 2)), stiffness=1.0, damping=1.0, node_mass=1.0)
    with pytest.raises(InputError, match="has 27 nodes; the model has 8"):
        PaperLearner(cycles=1).fit(other, cube_experiment)
