"""Shared fixtures: small synthetic data made with our own simulator (all randomness seeded)."""

import json
import sys
import time
from pathlib import Path

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


#: Seconds each slow test took (setup included) in a run of ``python -m pytest -m slow -n 2
#: --durations=60``; a slow test not listed counts as ``UNLISTED_SLOW`` seconds.
DURATIONS = Path(__file__).with_name("durations.json")
UNLISTED_SLOW = 20.0


def pytest_collection_modifyitems(config, items):
    """The longest tests first: with workers (``-n 2``) each takes the next test as it
    finishes one, so a long test collected last would run alone at the end (it did: the
    last ten minutes of a 34-minute CI run, one test on one core). Longest first, the short
    ones fill the gaps (the longest-processing-time rule). The order is deterministic, as
    xdist requires of every worker's collection."""
    known = json.loads(DURATIONS.read_text()) if DURATIONS.exists() else {}

    def seconds(item):
        if item.get_closest_marker("slow") is None:
            return 0.0
        return known.get(item.nodeid, UNLISTED_SLOW)

    order = {id(item): index for index, item in enumerate(items)}
    items.sort(key=lambda item: (-seconds(item), order[id(item)]))
