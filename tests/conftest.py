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


def pytest_collection_modifyitems(config, items):
    """Slow tests first, each group in collection order: with the tests handed to the
    workers two at a time (below), the long ones are spread over both workers from the start
    and the fast ones fill the end, instead of one long test running alone at the end."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


def pytest_configure(config):
    """With test workers (``-n N``): tests handed out at most two at a time
    (``--maxschedchunk 2`` unless given; xdist's default first hands each worker a quarter
    of its share, consecutive tests, so an order of long tests first would give one worker
    all of them), and the kernels compiled once, side by side, before the workers start
    (:mod:`neurofuzzy.warmup`; about 1¾ minutes on two cores when the cache is cold, a few
    seconds when it is warm). Otherwise every worker, and every command a test runs, would
    compile the kernels it meets while the cache is still cold."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    if getattr(config.option, "maxschedchunk", 0) is None:
        config.option.maxschedchunk = 2
    from neurofuzzy.warmup import compile_kernels

    began = time.perf_counter()
    try:
        compile_kernels()
    except RuntimeError as error:       # the tests that meet the broken kernel will say more
        print(f"neurofuzzy: {error}", file=sys.stderr)
        return
    print(f"neurofuzzy: the kernels compiled or loaded before the workers start "
          f"({time.perf_counter() - began:.0f} s)", file=sys.stderr)

