"""Compile the simulation kernels ahead of time, side by side: :func:`compile_kernels`.

numba compiles each kernel the first time it runs and keeps it in its cache (the kernels'
``__pycache__``, or ``NUMBA_CACHE_DIR``), so the first run of the toolkit on a machine waits
for the compiler, on one core. The kernels fall into parts that share no compiled function;
:func:`compile_kernels` runs each part's small workload in a process of its own, so a machine
with two cores compiles in about the time of the largest part instead of the sum. A part whose
kernels are cached loads them in a second or two.

    python -m neurofuzzy.warmup            # every part, one process each
    python -m neurofuzzy.warmup stepper    # one part, in this process

The test suite runs it before its workers start (``tests/conftest.py``): two test processes
meeting a cold cache would each compile every kernel.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

__all__ = ["PARTS", "compile_kernels"]


def _cube_experiment(frames: int = 12):
    from .datasets import paper_cube_experiment, paper_cube_model

    model = paper_cube_model()
    return model, paper_cube_experiment(model, n_frames=frames)


def _learner_part() -> None:
    """The forward sensitivities (``kernels.sensitivity``), without the stepper:
    :func:`neurofuzzy.learn.warmup.run_with_tangents`."""
    from .learn.warmup import run_with_tangents

    run_with_tangents()


def _stepper() -> None:
    """The time stepper (``kernels.stepper``) and the adjoint sweep (``kernels.adjoint``) it
    feeds: the gradient of a pass, as L-BFGS takes it, for each kind of model the kernels
    compile apart (springs only, the cube; elements, a block of six tetrahedra)."""
    from .experiment import simulate_experiment
    from .learn import GradientLearner
    from .mesh import from_tetra, kuhn_block
    from .model import Model

    model, data = _cube_experiment()
    GradientLearner(method="lbfgs", max_iterations=2).fit(model.tied("global"), data)
    mesh = from_tetra(*kuhn_block((1, 1, 1), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    block = Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0)
    load = np.zeros((mesh.n_nodes, 3))
    load[mesh.rest_positions[:, 2] > 0.01 - 1e-9, 2] = -1e-3
    data = simulate_experiment(block, dt=1e-3, n_frames=6, external_forces=load)
    GradientLearner(method="lbfgs", max_iterations=2, mesh_check=False).fit(
        block.tied("global"), data)
    _parallel_passes()


def _parallel_passes() -> None:
    """The stepper's element passes on threads (``kernels.element_forces._passes_parallel``), which
    only a model of :data:`~neurofuzzy.simulation.threads.PARALLEL_FROM` elements or more
    takes, stepped from this (main) thread; nothing when numba has one thread."""
    from .mesh import from_tetra, kuhn_block
    from .model import Model
    from .simulation import simulate
    from .simulation.threads import PARALLEL_FROM, element_threads

    if element_threads(PARALLEL_FROM) < 2:
        return
    mesh = from_tetra(*kuhn_block((8, 8, 6), 0.01))      # 2,304 tetrahedra
    block = Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0)
    simulate(block, dt=1e-5, n_frames=2)


def _static() -> None:
    """The elements' stiffness (``kernels.element``, ``kernels.stiffness``): a static
    compression of a small block of each volumetric form."""
    from .mesh import from_tetra, kuhn_block
    from .model import Model
    from .simulation.static import Driven, equilibrium

    points, tetrahedra = kuhn_block((1, 1, 1), 0.01)
    mesh = from_tetra(points, tetrahedra)
    bottom = np.flatnonzero(points[:, 2] < 1e-9)
    top = np.flatnonzero(points[:, 2] > 0.01 - 1e-9)
    for volumetric in ("nodal", "element"):
        model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                                viscosity=3.0, density=1000.0, volumetric=volumetric,
                                law="neo-hookean")
        equilibrium(model, driven=[Driven(bottom, (0, 0, 0)), Driven(top, (0, 0, -1e-3))])


#: part name → its workload, the longest first; parts share no compiled function, so they
#: compile side by side (cold, with and without the element code, the first two at once
#: and then the third, 2026-12-02 on two cores: 107, 150 and 23 s, 150 s in all; 344 s
#: before the threaded passes and the adjoint stopped inlining their callees twice; on a
#: faster machine later that day, with the derivative sweeps' threaded passes, 68, 114 and
#: 18 s, 114 s in all, against 75, 96 and 16 s without them; on a slower machine on
#: 2026-12-03, 63, 89 and 19 s, 89 s in all, once the passes over the items stopped being
#: inlined into their callers, against 75, 130 and 19 s, 130 s in all, before)
PARTS = {"sensitivity": _learner_part, "stepper": _stepper, "static": _static}


def compile_kernels(parts=None, *, processes: int | None = None,
                    progress: bool = False) -> dict:
    """Compile (or load from the cache) the kernels of ``parts`` (default: every part of
    :data:`PARTS`), each part in a process of its own, at most ``processes`` at a time
    (default: the machine's cores). Returns ``{part: seconds}``.

    Raises
    ------
    RuntimeError
        A part's process failed (its stderr is in the message).
    """
    names = list(PARTS) if parts is None else list(parts)
    unknown = sorted(set(names) - set(PARTS))
    if unknown:
        raise ValueError(f"unknown part(s) {', '.join(unknown)}; known: {', '.join(PARTS)}")
    limit = max(1, processes or os.cpu_count() or 1)
    waiting, running, seconds = list(names), {}, {}
    while waiting or running:
        while waiting and len(running) < limit:
            name = waiting.pop(0)
            log = tempfile.TemporaryFile("w+")        # a pipe could fill and stall the part
            running[name] = (time.perf_counter(), log, subprocess.Popen(
                [sys.executable, "-m", "neurofuzzy.warmup", name],
                stdout=subprocess.DEVNULL, stderr=log, text=True))
        for name, (began, log, process) in list(running.items()):
            if process.poll() is None:
                continue
            del running[name]
            log.seek(0)
            stderr = log.read()
            log.close()
            if process.returncode:
                for _, other_log, other in running.values():
                    other.kill()
                    other.wait()
                    other_log.close()
                raise RuntimeError(f"compiling the kernels of '{name}' failed:\n{stderr}")
            seconds[name] = time.perf_counter() - began
            if progress:
                print(f"neurofuzzy: kernels of '{name}' ready ({seconds[name]:.0f} s)",
                      file=sys.stderr, flush=True)
        time.sleep(0.05)
    return seconds


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    unknown = [name for name in argv if name not in PARTS]
    if unknown:
        print(f"neurofuzzy.warmup: error: unknown part(s) {', '.join(unknown)}; known: "
              f"{', '.join(PARTS)}", file=sys.stderr)
        return 2
    if argv:
        for name in argv:
            PARTS[name]()
    else:
        compile_kernels(progress=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
