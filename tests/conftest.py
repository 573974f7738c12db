"""Shared fixtures: small synthetic data made with our own simulator (all randomness seeded)."""

import numpy as np
import pytest

from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model


@pytest.fixture(scope="session")
def cube_model():
    return paper_cube_model()


@pytest.fixture(scope="session")
def cube_experiment(cube_model):
    return paper_cube_experiment(cube_model)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
