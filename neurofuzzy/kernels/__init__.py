"""The compiled (numba) kernels: one semi-implicit Euler update (:mod:`.integrator`), the
elements' material laws with their two derivatives generated from them (:mod:`.laws`), their
Prony relaxation (:mod:`.relaxation`), 3×3 matrices as tuples of scalars (:mod:`.tuples`),
and the sweeps that call them: the stepper
(:mod:`.stepper`, :func:`neurofuzzy.simulate`), the forward sensitivities (:mod:`.sensitivity`)
and the discrete adjoint (:mod:`.adjoint`) of the gradient learner.

What is inlined: a function of one item (a law, an element's strains, a product of tuples)
is inlined into its caller by numba (``inline="always"``). Its work is a few dozen
operations, and a call costs a share of that: with the law switch called instead, the
tangent and adjoint sweeps of the 10,368-tetrahedron block ran 1.13–1.35 times as long.
A function that loops over the items (a pass: ``_forces``, ``_nodal_sums``, ``_pull``, the
integrator's update) is called. Inlined, it saves nothing at run time, and numba copies its
whole body, every law included, into each caller. With the passes inlined, the cold
warm-up took 221 s of compilation on one core; with them called, 160 s (2026-12-03).

Each module compiles (or loads from numba's cache) on first use. numba's cache knows only the
file a function is defined in, not the files of the functions inlined into it: after an edit of
a law in ``laws.py`` the sweeps would load their old machine code. So the first import here
compares a fingerprint of all the kernels' sources with the one their cache was made from, and
drops the cache when they differ.
"""

import hashlib
from pathlib import Path


def _drop_stale_cache() -> None:
    """Remove this package's numba cache files when any kernel source changed since they were
    written (a source checkout; an installed package changes only as a whole)."""
    folder = Path(__file__).parent
    fingerprint = hashlib.sha256(b"".join(path.read_bytes()
                                          for path in sorted(folder.glob("*.py")))).hexdigest()
    cache = folder / "__pycache__"
    stamp = cache / "neurofuzzy-kernels.sha256"
    try:
        if stamp.read_text() == fingerprint:
            return
    except OSError:
        pass
    try:
        for path in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            path.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(fingerprint)
    except OSError:          # a read-only install: numba keeps its cache elsewhere
        pass


_drop_stale_cache()
