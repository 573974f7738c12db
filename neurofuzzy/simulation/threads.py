"""How many threads the compiled element passes use: both cores for a large model run from the
main thread, one otherwise.

The element passes scatter each element's nodal forces into the nodes it shares with its
neighbours, so they cannot simply be split over threads. Split into runs of consecutive
elements, each thread adds its run's forces into a buffer of its own, and the buffers are
summed per node afterwards (:func:`neurofuzzy.kernels.element_forces._passes_parallel`). A parallel
region costs its launch (about 30 µs for an empty one on this 2-core machine), and a step
of the nodal form starts four (two passes, two sums); a step of 1,296 tetrahedra takes
about 160 µs on one thread. So models under :data:`PARALLEL_FROM` elements stay on one
thread; ``benchmarks/threads.py`` measures the step rates either side.

Work that already runs side by side in threads (the learners' experiments and Jacobian
columns, :mod:`neurofuzzy.learn._passes`) or in worker processes (``fit-many``, whose workers
set ``NUMBA_NUM_THREADS=1``) keeps one thread per kernel: only the main thread splits, so the
cores are not asked for more threads than they have, and numba's threading layers never see
two parallel regions launched at once.
"""

from __future__ import annotations

import threading

import numpy as np

__all__ = ["PARALLEL_FROM", "element_threads", "element_buffers"]

#: Elements from which the passes run on more than one thread (3,072 tetrahedra step 1.7-1.8x
#: faster on two threads, ``benchmarks/threads.py``).
PARALLEL_FROM = 2000


def element_threads(n_elements: int) -> int:
    """Threads for the element passes of a model of ``n_elements``: numba's thread count
    (``NUMBA_NUM_THREADS``, :func:`numba.set_num_threads`), at most one per half of
    :data:`PARALLEL_FROM` elements, for a large model on the main thread; else 1."""
    if n_elements < PARALLEL_FROM or threading.current_thread() is not threading.main_thread():
        return 1
    import numba

    return max(1, min(numba.get_num_threads(), n_elements // (PARALLEL_FROM // 2)))


def element_buffers(n_elements: int, n_nodes: int, dtype=np.float64,
                    reuse: np.ndarray | None = None) -> np.ndarray | None:
    """The per-thread scratch of the element passes: None for one thread (the serial passes),
    else zeros (threads - 1, n_nodes, 3): ``reuse`` when it has that shape (the passes leave
    their buffers zero)."""
    threads = element_threads(n_elements)
    if threads < 2:
        return None
    if reuse is not None and reuse.shape == (threads - 1, n_nodes, 3):
        return reuse
    return np.zeros((threads - 1, n_nodes, 3), dtype)
