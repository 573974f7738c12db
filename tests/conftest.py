"""Shared fixtures: small synthetic data made with our own simulator (all randomness seeded)."""

import sys
import time

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


def pytest_configure(config):
    """With test workers (``-n N``): the kernels compiled once, side by side, before the
    workers start (:mod:`neurofuzzy.warmup`; about 1¾ minutes on two cores when the cache is
    cold, a few seconds when it is warm). Otherwise every worker, and every command a test
    runs, would compile the kernels it meets while the cache is still cold."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from neurofuzzy.warmup import compile_kernels

    began = time.perf_counter()
    try:
        compile_kernels()
    except RuntimeError as error:       # the tests that meet the broken kernel will say more
        print(f"neurofuzzy: {error}", file=sys.stderr)
        return
    print(f"neurofuzzy: the kernels compiled or loaded before the workers start "
          f"({time.perf_counter() - began:.0f} s)", file=sys.stderr)

