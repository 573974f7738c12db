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
    (:mod:`neurofuzzy.warmup`; about 2½ minutes on two cores when the cache is cold, a few
    seconds when it is warm). Otherwise every worker, and every command a test runs, would
    compile the kernels it meets while the cache is still cold.

    The workers, and every command they run, then keep to their share of the cores: numba's
    threads per worker (``NUMBA_NUM_THREADS``, set before they start) are the cores over the
    workers, one each for ``-n 2`` on two cores. Two workers whose kernels each split over
    both cores asked them for four threads, and the oversubscribed threads wasted a third of
    the time: four of the longest slow tests took 244 s side by side, 166 s with a thread
    each. The results do not depend on the thread count: ``tests/test_threads.py`` checks
    two threads against one, in a process of its own where the workers have one."""
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
        _share_the_cores(config.option.numprocesses)
        return
    print(f"neurofuzzy: the kernels compiled or loaded before the workers start "
          f"({time.perf_counter() - began:.0f} s)", file=sys.stderr)
    _share_the_cores(config.option.numprocesses)


def _share_the_cores(workers) -> None:
    """``NUMBA_NUM_THREADS`` for the test workers about to start: the cores over the workers
    (unless the caller chose). Set after the kernels are compiled here: numba refuses a
    thread count that changes in a process once its threads run."""
    import os

    if isinstance(workers, int) and workers > 1 and "NUMBA_NUM_THREADS" not in os.environ:
        os.environ["NUMBA_NUM_THREADS"] = str(max(1, (os.cpu_count() or 1) // workers))

