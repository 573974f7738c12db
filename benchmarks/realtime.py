"""The real-time factor at a simulator's step (issue 47, item 3): simulated seconds per wall
second, ours beside MuJoCo's on the same model.

    python benchmarks/realtime.py [--cells 6 12 20] [--steps 30] [--threads 1 2]

For each Kuhn block (a 2 cm cube of ``cells``³ cells, six tetrahedra a cell, bottom fixed,
St. Venant–Kirchhoff at ν 0.45 in the textbook element form, which is MuJoCo's flex), pushed
on its top:

- **explicit**, at the stable step (``stability_limit``): our compiled stepper and MuJoCo's
  ``Euler``;
- **implicit**, at 16 ms (graphics) and 1 ms (haptics): our backward Euler with one Newton
  iteration (:func:`neurofuzzy.simulation.implicit.simulate_implicit`, the step of MuJoCo's
  ``discrete`` integrator, which it reproduces: ``tests/test_implicit.py``) and MuJoCo's
  ``discrete``.

Ours at each of ``--threads`` (numba's threads and the BLAS's, :func:`numba.set_num_threads`
and threadpoolctl; the element passes split over threads from
:data:`~neurofuzzy.simulation.threads.PARALLEL_FROM` elements), MuJoCo on one thread (its
step of one model is serial). A factor above 1 is faster than real time. Each timing is the
best of three after a warm-up;
the explicit runs take ``--explicit-steps`` steps, the implicit ones ``--steps``. Prints the
table and writes ``benchmarks/realtime.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neurofuzzy.experiment import Experiment  # noqa: E402
from neurofuzzy.export.mujoco import mjcf  # noqa: E402
from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.simulation import simulate, stability_limit  # noqa: E402
from neurofuzzy.simulation.implicit import simulate_implicit  # noqa: E402

STEPS = {"16 ms": 0.016, "1 ms": 0.001}


def _block(cells):
    points, tets = kuhn_block((cells,) * 3, 0.02 / cells)
    mesh = from_tetra(points, tets).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0, volumetric="element")
    rest = mesh.rest_positions
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    load = np.zeros((model.n_nodes, 3))
    load[top] = (0.01 / len(top), 0.0, -0.05 / len(top))
    return model, load


def _best(function, repeat=3):
    function()                                     # warm: compiled, factorised, cached
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def _mujoco(model, load, h, integrator, steps):
    """Seconds for ``steps`` MuJoCo steps of ``h`` with ``integrator``, or None without
    MuJoCo."""
    try:
        import mujoco
    except ImportError:
        return None
    experiment = Experiment(mesh=model.mesh, dt=h, external_forces=np.stack([load] * 2),
                            positions=np.stack([model.mesh.rest_positions] * 2))
    text = mjcf(model, experiment=experiment, substeps=1)[0]
    handle = mujoco.MjModel.from_xml_string(
        text.replace('integrator="Euler"', f'integrator="{integrator}"'))
    data = mujoco.MjData(handle)
    bodies = [mujoco.mj_name2id(handle, mujoco.mjtObj.mjOBJ_BODY, f"node{i}")
              for i in range(model.n_nodes)]
    moving = [b for b in bodies if b >= 0]
    data.xfrc_applied[moving, :3] = load[[i for i, b in enumerate(bodies) if b >= 0]]

    def run():
        mujoco.mj_step(handle, data, nstep=steps)

    return _best(run)


def _ours(threads, function):
    """The best seconds of ``function`` on ``threads`` threads (numba's and the BLAS's)."""
    numba.set_num_threads(threads)
    try:
        with threadpool_limits(limits=threads):
            return _best(function)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)


def _threads(count):
    return f"{count} thread{'s' if count > 1 else ''}"


def _key(name, count):
    return f"{name}_{_threads(count).replace(' ', '_')}"


def measure(cells, steps, explicit_steps, threads=(1, 2)):
    """One block's factors: ours at each of ``threads`` (keys ``explicit_ours_1_thread``,
    ``implicit_ours_16 ms_2_threads``, …), MuJoCo's on one."""
    model, load = _block(cells)
    h_stable = stability_limit(model).max_step
    row = {"cells": cells, "tetrahedra": model.mesh.n_tetrahedra, "nodes": model.n_nodes,
           "stable_step_s": h_stable}
    for count in threads:
        seconds = _ours(count, lambda: simulate(model, dt=h_stable * explicit_steps,
                                                n_frames=2, external_forces=load,
                                                substeps=explicit_steps))
        row[_key("explicit_ours", count)] = h_stable * explicit_steps / seconds
    mujoco_seconds = _mujoco(model, load, h_stable, "Euler", explicit_steps)
    row["explicit_mujoco"] = (None if mujoco_seconds is None
                              else h_stable * explicit_steps / mujoco_seconds)
    for name, h in STEPS.items():
        for count in threads:
            seconds = _ours(count, lambda: simulate_implicit(model, dt=h, n_frames=steps + 1,
                                                             external_forces=load))
            row[_key(f"implicit_ours_{name}", count)] = h * steps / seconds
        mujoco_seconds = _mujoco(model, load, h, "discrete", steps)
        row[f"implicit_mujoco_{name}"] = (None if mujoco_seconds is None
                                          else h * steps / mujoco_seconds)
    return row


def _factor(value):
    return "-" if value is None else f"{value:.3g}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[6, 12, 20])
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--explicit-steps", type=int, default=2000)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", default=str(Path(__file__).with_suffix(".json")))
    args = parser.parse_args(argv)
    threads = [count for count in args.threads if count <= numba.config.NUMBA_NUM_THREADS]
    rows = []
    for cells in args.cells:
        rows.append(measure(cells, args.steps, args.explicit_steps, threads))
        r = rows[-1]
        print(f"{r['tetrahedra']} tetrahedra done", file=sys.stderr)
    print("real-time factor (simulated s per wall s; > 1 is faster than real time); ours at "
          + " / ".join(_threads(count) for count in threads)
          + ", MuJoCo on one")
    print(f"{'tets':>7} {'stable step':>11} {'explicit ours':>15} {'MuJoCo':>7} "
          f"{'16 ms ours':>15} {'MuJoCo':>7} {'1 ms ours':>15} {'MuJoCo':>7}")
    for r in rows:
        ours = {name: " / ".join(_factor(r[_key(name, count)]) for count in threads)
                for name in ("explicit_ours", "implicit_ours_16 ms", "implicit_ours_1 ms")}
        print(f"{r['tetrahedra']:>7} {1e3 * r['stable_step_s']:>9.3f}ms "
              f"{ours['explicit_ours']:>15} {_factor(r['explicit_mujoco']):>7} "
              f"{ours['implicit_ours_16 ms']:>15} "
              f"{_factor(r['implicit_mujoco_16 ms']):>7} "
              f"{ours['implicit_ours_1 ms']:>15} {_factor(r['implicit_mujoco_1 ms']):>7}")
    Path(args.out).write_text(json.dumps({"threads": threads, "rows": rows}, indent=1)
                              + "\n")


if __name__ == "__main__":
    main()
